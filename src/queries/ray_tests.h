#pragma once

// The exact ray tests shared by the ray queries (ray.cpp) over a manager's cubes and by
// raycastObject: the segment and its crossing of a box, the narrow phase's exact first hit for
// spheres, boxes, capsules, cylinders, ellipsoids, planes and halfspaces (ray_tests.cpp), the
// bisection with an FCL capsule for the other geometries, and hitOne, the per-object test.

#include <fcl/geometry/shape/capsule.h>
#include <fcl/narrowphase/collision_object.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <utility>

#include "cube_collision/spatial_queries.h"
#include "pipeline/fcl_narrow.h"

namespace cube {
namespace detail {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The segment as the box test reads it (see raycastObject's contract).
struct Segment {
  double o[3];
  double inv[3];
  bool moves[3];
};

template <typename S>
Segment makeSegment(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to) {
  Segment s;
  for (int k = 0; k < 3; ++k) {
    s.o[k] = double(from[k]);
    const double d = double(to[k]) - double(from[k]);
    s.inv[k] = 1.0 / d;
    // An infinite inverse (no motion, or below 1 / DBL_MAX) would make 0 * inf = NaN below.
    s.moves[k] = std::isfinite(s.inv[k]);
  }
  return s;
}

// Where the segment enters and leaves the closed box [lo, hi], in [0, 1]; false if it misses.
// No NaN can arise: the inverse is finite and non-zero, the origin finite.
template <class T>
inline bool crossBox(const Segment& s, const T* lo, const T* hi, double& enter, double& exit) {
  double tn = 0, tf = 1;
  for (int k = 0; k < 3; ++k) {
    const double l = double(lo[k]), h = double(hi[k]);
    if (!s.moves[k]) {
      if (!(l <= s.o[k] && s.o[k] <= h)) return false;
      continue;
    }
    double a = (l - s.o[k]) * s.inv[k];
    double b = (h - s.o[k]) * s.inv[k];
    // Chosen by the sign, not by min/max, so that an emptied cube (lo > hi) is missed.
    if (s.inv[k] < 0) std::swap(a, b);
    tn = a > tn ? a : tn;
    tf = b < tf ? b : tf;
  }
  enter = tn;
  exit = tf;
  return tn <= tf;
}

// Geometries whose fcl::collide against a capsule FCL 0.7 answers (checked in the tests against
// the analytic intersections). Octrees carry occupancy thresholds and costs; triangles and custom
// geometries are untested here.
template <typename S>
bool narrowable(const fcl::CollisionObject<S>& obj) {
  if (obj.collisionGeometry() == nullptr) return false;
  switch (obj.collisionGeometry()->getNodeType()) {
    case fcl::BV_AABB:
    case fcl::BV_OBB:
    case fcl::BV_RSS:
    case fcl::BV_kIOS:
    case fcl::BV_OBBRSS:
    case fcl::BV_KDOP16:
    case fcl::BV_KDOP18:
    case fcl::BV_KDOP24:
    case fcl::GEOM_BOX:
    case fcl::GEOM_SPHERE:
    case fcl::GEOM_ELLIPSOID:
    case fcl::GEOM_CAPSULE:
    case fcl::GEOM_CONE:
    case fcl::GEOM_CYLINDER:
    case fcl::GEOM_CONVEX:
    case fcl::GEOM_PLANE:
    case fcl::GEOM_HALFSPACE:
      return true;
    default:
      return false;
  }
}

/// Eigen::Quaternion<S>::FromTwoVectors(UnitZ, v).toRotationMatrix(): a capsule's local z axis
/// turned onto v. Compiled once (ray_tests.cpp): Eigen's solver behind it is slow to compile.
template <typename S>
fcl::Matrix3<S> rotationFromZ(const fcl::Vector3<S>& v);

// The bisection of the other geometries: a capsule of radius 0 from `from` along the segment,
// stretched to each t asked. Owned by the query (one per call), so queries share nothing.
template <typename S>
class Caster {
 public:
  Caster(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to)
      : from_(from),
        d_(to - from),
        len_(double(d_.norm())),
        cap_(std::make_shared<fcl::Capsule<S>>(S(0), S(0))),
        obj_(cap_) {
    rot_.setIdentity();
    // The capsule's axis is its local z.
    if (len_ > 0) rot_ = rotationFromZ<S>(d_ / S(len_));
  }
  // Whether the part of the segment from t = 0 to t meets the object.
  bool reaches(const fcl::CollisionObject<S>& obj, double t) {
    cap_->lz = S(t * len_);
    cap_->computeLocalAABB();
    obj_.setTransform(rot_, fcl::Vector3<S>(from_ + S(0.5 * t) * d_));
    obj_.computeAABB();
    fcl::CollisionRequest<S> request;
    fcl::CollisionResult<S> result;
    return detail::fclCollide<S>(&obj_, &obj, request, result) > 0;
  }

 private:
  fcl::Vector3<S> from_, d_;
  double len_;
  fcl::Matrix3<S> rot_;
  std::shared_ptr<fcl::Capsule<S>> cap_;
  fcl::CollisionObject<S> obj_;
};

// The first t in [0, 1] at which the segment o + t d (in the geometry's frame) is in the closed
// solid, kInf if never; false if the geometry is not one solved here (ray_tests.cpp).
template <typename S>
bool exactFirst(const fcl::CollisionGeometry<S>& geo, const double* o, const double* d, double& t);

// The narrow phase of one query: the segment in double for the exact tests, and the bisection's
// capsule, made on first use only (most scenes need none).
template <typename S>
class Narrow {
 public:
  Narrow(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to, S tolerance)
      : from_(from), to_(to) {
    for (int k = 0; k < 3; ++k) {
      o_[k] = double(from[k]);
      d_[k] = double(to[k]) - double(from[k]);
    }
    // As the bisection's capsule measures it.
    const double len = double((to - from).norm());
    tol_t_ = len > 0 ? double(tolerance) / len : kInf;
  }
  double tolT() const { return tol_t_; }
  Caster<S>& caster() {
    if (!caster_) caster_.emplace(from_, to_);
    return *caster_;
  }
  // exactFirst on the object's geometry, the segment taken into its frame.
  bool exact(const fcl::CollisionObject<S>& obj, double& t) const {
    const fcl::Transform3<S>& tf = obj.getTransform();
    double rel[3], lo[3], ld[3];
    for (int k = 0; k < 3; ++k) rel[k] = o_[k] - double(tf.translation()[k]);
    for (int j = 0; j < 3; ++j) {  // R^T: the object's axes are R's columns
      lo[j] = ld[j] = 0;
      for (int k = 0; k < 3; ++k) {
        const double r = double(tf.linear()(k, j));
        lo[j] += r * rel[k];
        ld[j] += r * d_[k];
      }
    }
    return exactFirst(*obj.collisionGeometry(), lo, ld, t);
  }

 private:
  fcl::Vector3<S> from_, to_;
  double o_[3], d_[3];
  double tol_t_;
  std::optional<Caster<S>> caster_;
};

// The narrow phase of hitOne, given where the segment enters and leaves the object's box
// (ray_tests.cpp): out of line.
template <typename S>
[[gnu::noinline]] bool narrowHit(const fcl::CollisionObject<S>& obj, Narrow<S>& narrow,
                                 double enter, double exit, double bound, double& t);

// The per-object test of raycastObject. `bound`: a hit beyond it is of no interest (the walk's
// best so far), and the bisection may give up once it is passed; the t returned otherwise does
// not depend on `bound`, so a pruned walk finds the same t as a loop over every object.
template <typename S, class T>
bool hitOne(const Segment& s, const T* lo, const T* hi, const fcl::CollisionObject<S>& obj,
            Narrow<S>* narrow, double bound, double& t, HitKind& kind) {
  double enter, exit;
  if (!crossBox(s, lo, hi, enter, exit) || enter > bound) return false;
  if (narrow == nullptr || !narrowable(obj)) {
    t = enter;
    kind = HitKind::box;
    return true;
  }
  kind = HitKind::narrow_phase;
  return narrowHit(obj, *narrow, enter, exit, bound, t);
}

}  // namespace detail
}  // namespace cube
