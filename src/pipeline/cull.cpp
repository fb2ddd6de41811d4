// Tight volumes and the separating-axis tests behind surelyApart.

#include "pipeline/cull.h"

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

namespace cube {
namespace detail {

namespace {

// An object's tight volumes in world coordinates: a sphere (centre c, radius r) and an oriented
// box about the same centre (axes the columns of R, half extents e). The sphere comes first and
// costs one matrix-vector product; the box only when the spheres do not settle the pair.
template <typename S>
struct Tight {
  const fcl::Transform3<S>* tf;
  const fcl::CollisionGeometry<S>* g;
  fcl::Vector3<S> c;
  S r;
  bool sphere;  // the geometry is a sphere: r is exact and the box adds nothing
  fcl::Matrix3<S> R;
  fcl::Vector3<S> e;

  // The box from the geometry's local AABB (its centre replaces c); false if not finite.
  // computeLocalAABB() sets aabb_center to that centre, so c usually stands as it is.
  bool withBox() {
    const fcl::AABB<S>& local = g->aabb_local;
    e = (local.max_ - local.min_) * S(0.5);
    R = tf->linear();
    const fcl::Vector3<S> mid = (local.max_ + local.min_) * S(0.5);
    if (mid != g->aabb_center) {
      c = R * mid + tf->translation();
      if (!c.allFinite()) return false;
    }
    return e.allFinite() && R.allFinite() && (e.array() >= S(0)).all();
  }
};

// The sphere of an object, from what FCL keeps per geometry (aabb_center, aabb_radius: the
// local AABB's circumscribed sphere); false if the object has none that is finite.
template <typename S>
bool tightOf(const fcl::CollisionObject<S>& o, Tight<S>& t) {
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr) return false;
  const fcl::NODE_TYPE type = g->getNodeType();
  switch (type) {
    case fcl::GEOM_PLANE:
    case fcl::GEOM_HALFSPACE:
    case fcl::GEOM_OCTREE:  // its cells, not its box, decide; and it may carry costs
      return false;
    default:
      break;
  }
  t.g = g;
  t.tf = &o.getTransform();
  t.sphere = type == fcl::GEOM_SPHERE;
  t.c = t.tf->linear() * g->aabb_center + t.tf->translation();
  t.r = t.sphere ? static_cast<const fcl::Sphere<S>*>(g)->radius : g->aabb_radius;
  return t.c.allFinite() && std::isfinite(t.r) && t.r >= S(0);
}

// Distance from point p to the box b (0 inside).
template <typename S>
S pointBoxDistance(const fcl::Vector3<S>& p, const Tight<S>& b) {
  const fcl::Vector3<S> q = b.R.transpose() * (p - b.c);
  const fcl::Vector3<S> out = (q.cwiseAbs() - b.e).cwiseMax(S(0));
  return out.norm();
}

// A lower bound on the distance between two oriented boxes: the largest gap along the 15 axes
// of the separating-axis test (three face normals of each, nine edge cross products, each
// gap divided by its axis' length; edge axes only where positive), or the first gap found above
// `stop` (the caller needs no more). |R| gets a small term so that rounding makes gaps smaller,
// never larger; cross products of near-parallel edges (length below 1e-3) are left out. The face
// axes come first: they separate most pairs that are apart, and cost no square root.
template <typename S>
S boxGap(const Tight<S>& a, const Tight<S>& b, S stop) {
  const fcl::Matrix3<S> R = a.R.transpose() * b.R;  // b's axes in a's frame
  const fcl::Vector3<S> t = a.R.transpose() * (b.c - a.c);
  const fcl::Matrix3<S> A = R.cwiseAbs().array() + S(16) * std::numeric_limits<S>::epsilon();
  S gap = -std::numeric_limits<S>::infinity();
  for (int i = 0; i < 3; ++i) gap = std::max(gap, std::abs(t[i]) - a.e[i] - b.e.dot(A.row(i)));
  for (int j = 0; j < 3; ++j)
    gap = std::max(gap, std::abs(t.dot(R.col(j))) - a.e.dot(A.col(j)) - b.e[j]);
  if (gap > stop) return gap;
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const S len2 = S(1) - R(i, j) * R(i, j);
      if (!(len2 >= S(1e-6))) continue;  // length below 1e-3
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      // Axis: a's axis i cross b's axis j.
      const S dist = std::abs(t[i2] * R(i1, j) - t[i1] * R(i2, j));
      const S ra = a.e[i1] * A(i2, j) + a.e[i2] * A(i1, j);
      const S rb = b.e[j1] * A(i, j2) + b.e[j2] * A(i, j1);
      const S slack = dist - ra - rb;
      // A gap of 0 or less bounds nothing the callers use: no square root for it.
      if (slack <= S(0)) continue;
      gap = std::max(gap, slack / std::sqrt(len2));
      if (gap > stop) return gap;
    }
  }
  return gap;
}

// A ball inside the geometry (centre c in world coordinates, radius r), for the shapes that
// have an obvious one; false for the others and for non-finite or non-positive sizes. FCL's
// primitives are centred on their frame's origin; a cone's base is at z = -lz/2 and its apex at
// +lz/2.
template <typename S>
bool inscribedBall(const fcl::CollisionObject<S>& o, fcl::Vector3<S>& c, S& r) {
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr || !g->isOccupied()) return false;
  const fcl::Transform3<S>& tf = o.getTransform();
  c = tf.translation();
  switch (g->getNodeType()) {
    case fcl::GEOM_SPHERE:
      r = static_cast<const fcl::Sphere<S>*>(g)->radius;
      break;
    case fcl::GEOM_BOX:
      r = S(0.5) * static_cast<const fcl::Box<S>*>(g)->side.minCoeff();
      break;
    case fcl::GEOM_CAPSULE: {
      const auto* cap = static_cast<const fcl::Capsule<S>*>(g);
      if (!(cap->lz >= S(0))) return false;
      r = cap->radius;
      break;
    }
    case fcl::GEOM_CYLINDER: {
      const auto* cyl = static_cast<const fcl::Cylinder<S>*>(g);
      r = std::min(cyl->radius, S(0.5) * cyl->lz);
      break;
    }
    case fcl::GEOM_ELLIPSOID:
      r = static_cast<const fcl::Ellipsoid<S>*>(g)->radii.minCoeff();
      break;
    case fcl::GEOM_CONE: {
      // The ball touching the base and the side: r = R h / (R + slant), centred r above the base.
      const auto* cone = static_cast<const fcl::Cone<S>*>(g);
      const S h = cone->lz, R = cone->radius;
      if (!(h > S(0) && R > S(0))) return false;
      r = R * h / (R + std::hypot(R, h));
      c = tf * fcl::Vector3<S>(0, 0, r - S(0.5) * h);
      break;
    }
    default:
      return false;
  }
  return c.allFinite() && std::isfinite(r) && r > S(0) && tf.linear().allFinite();
}

}  // namespace

namespace {

// inscribedBall in the geometry's frame: the ball's centre is on the z axis at `z`.
template <typename S>
bool localInscribedBall(const fcl::CollisionGeometry<S>& g, double& z, double& r) {
  if (!g.isOccupied()) return false;
  z = 0;
  switch (g.getNodeType()) {
    case fcl::GEOM_SPHERE:
      r = static_cast<const fcl::Sphere<S>&>(g).radius;
      break;
    case fcl::GEOM_BOX:
      r = 0.5 * double(static_cast<const fcl::Box<S>&>(g).side.minCoeff());
      break;
    case fcl::GEOM_CAPSULE: {
      const auto& cap = static_cast<const fcl::Capsule<S>&>(g);
      if (!(cap.lz >= S(0))) return false;
      r = cap.radius;
      break;
    }
    case fcl::GEOM_CYLINDER: {
      const auto& cyl = static_cast<const fcl::Cylinder<S>&>(g);
      r = std::min(double(cyl.radius), 0.5 * double(cyl.lz));
      break;
    }
    case fcl::GEOM_ELLIPSOID:
      r = static_cast<const fcl::Ellipsoid<S>&>(g).radii.minCoeff();
      break;
    case fcl::GEOM_CONE: {
      const auto& cone = static_cast<const fcl::Cone<S>&>(g);
      const double h = cone.lz, R = cone.radius;
      if (!(h > 0 && R > 0)) return false;
      r = R * h / (R + std::hypot(R, h));
      z = r - 0.5 * h;
      break;
    }
    default:
      return false;
  }
  return std::isfinite(r) && r > 0;
}

// kVolumeCapsule, kVolumeCylinder or kVolumeCone for such a primitive whose sizes are finite and
// >= 0 and whose local AABB's half extents `e` are the ones its sizes give (volume.h; not after a
// resize in place without computeLocalAABB()), else 0.
template <typename S>
std::uint32_t roundKind(const fcl::CollisionGeometry<S>& g, const Eigen::Vector3d& e) {
  const auto sized = [&e](S radius, S lz, double ez) {
    const double r = radius, tol = 8.0 * std::numeric_limits<S>::epsilon() * (1 + r + ez);
    return std::isfinite(r) && std::isfinite(double(lz)) && r >= 0 && lz >= S(0) &&
           std::fabs(e[0] - r) <= tol && std::fabs(e[1] - r) <= tol && std::fabs(e[2] - ez) <= tol;
  };
  switch (g.getNodeType()) {
    case fcl::GEOM_CAPSULE: {
      const auto& cap = static_cast<const fcl::Capsule<S>&>(g);
      return sized(cap.radius, cap.lz, 0.5 * double(cap.lz) + double(cap.radius)) ? kVolumeCapsule
                                                                                  : 0u;
    }
    case fcl::GEOM_CYLINDER: {
      const auto& cyl = static_cast<const fcl::Cylinder<S>&>(g);
      return sized(cyl.radius, cyl.lz, 0.5 * double(cyl.lz)) ? kVolumeCylinder : 0u;
    }
    case fcl::GEOM_CONE: {
      const auto& cone = static_cast<const fcl::Cone<S>&>(g);
      return sized(cone.radius, cone.lz, 0.5 * double(cone.lz)) ? kVolumeCone : 0u;
    }
    default:
      return 0u;
  }
}

// The geometry's part of an object's records (VolumeSource).
template <typename S>
void localVolume(const fcl::CollisionGeometry<S>* g, VolumeSource& local) {
  local = VolumeSource{};
  local.flags = kVolumeNone;
  if (g == nullptr) return;
  const fcl::NODE_TYPE type = g->getNodeType();
  if (type == fcl::GEOM_PLANE || type == fcl::GEOM_HALFSPACE || type == fcl::GEOM_OCTREE) return;
  const Eigen::Vector3d lo = g->aabb_local.min_.template cast<double>();
  const Eigen::Vector3d hi = g->aabb_local.max_.template cast<double>();
  const Eigen::Vector3d e = (hi - lo) * 0.5;
  const Eigen::Vector3d mid = (hi + lo) * 0.5;
  const bool is_sphere = type == fcl::GEOM_SPHERE;
  // A sphere's own radius about its frame's origin; any other geometry, its local AABB's
  // circumscribed sphere (FCL's aabb_radius) about that box's centre.
  const double r = is_sphere ? double(static_cast<const fcl::Sphere<S>*>(g)->radius) : e.norm();
  if (!(e.allFinite() && mid.allFinite() && std::isfinite(r) && r >= 0 && (e.array() >= 0).all() &&
        r < 1e30))
    return;
  for (int k = 0; k < 3; ++k) {
    local.mid[k] = is_sphere ? 0.f : static_cast<float>(mid[k]);
    local.e[k] = static_cast<float>(e[k]);
  }
  local.r = static_cast<float>(r);
  local.flags = is_sphere                                                 ? kVolumeSphere
                : type == fcl::GEOM_BOX                                   ? kVolumeBox
                : type == fcl::GEOM_CAPSULE || type == fcl::GEOM_CYLINDER ? kVolumeRound
                : g->getObjectType() == fcl::OT_BVH                       ? kVolumeHeavy
                                                                          : 0u;
  double z = 0, inner = 0;
  // The ball's centre is given from the box's centre: only for geometries centred on their
  // frame's origin, as FCL's primitives are; so are the round bounds' axes.
  const bool centred = is_sphere || mid.cwiseAbs().maxCoeff() <= 1e-12 * (1 + r);
  if (centred && localInscribedBall(*g, z, inner)) {
    local.inner_r = static_cast<float>(inner);
    local.inner_z = static_cast<float>(z);
  }
  if (centred) local.flags |= roundKind(*g, e);
}

// The records from the geometry's part and the object's transform.
template <typename S>
void placeVolume(const fcl::CollisionObject<S>& o, VolumeSource& local, VolumeSphere& sphere,
                 VolumeShape& shape) {
  sphere = kNoVolume;
  shape = VolumeShape{};
  const S* m = o.getTransform().matrix().data();  // 4x4, by columns
  double R[9], t[3], mid[3];
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      R[3 * k + j] = double(m[4 * j + k]);
      shape.R[3 * k + j] = static_cast<float>(R[3 * k + j]);  // kept for refreshVolume
    }
    t[k] = double(m[12 + k]);
    local.t[k] = static_cast<float>(t[k]);
    mid[k] = double(local.mid[k]);
  }
  if ((local.flags & kVolumeNone) != 0) return;
  double c[3], cmax = 0, tmax = 0, midmax = 0;
  bool finite = true;
  for (int k = 0; k < 3; ++k) {
    c[k] = R[3 * k] * mid[0] + R[3 * k + 1] * mid[1] + R[3 * k + 2] * mid[2] + t[k];
    finite = finite && std::isfinite(c[k]) && std::isfinite(R[3 * k]) &&
             std::isfinite(R[3 * k + 1]) && std::isfinite(R[3 * k + 2]);
    cmax = std::max(cmax, std::fabs(c[k]));
    tmax = std::max(tmax, std::fabs(t[k]));
    midmax = std::max(midmax, std::fabs(mid[k]));
  }
  if (!finite) return;
  const double r = local.r;
  // 8 float ulps of |c|, |t|, 3 |mid| and r. Rounding the centre (under 1 ulp of |c| a
  // coordinate), the axes (1.5 ulps of r) and the local sizes and centre to floats (half an ulp
  // of each) moves the shape by less than half of that, and a record kept for a transform that
  // rounds to the same floats as the one it was built from (refreshVolume) is off by under an
  // ulp of |t| and of 3 |mid| for the centre, and an ulp of each axis: the rest.
  const double slack = 4.0 * FLT_EPSILON * (cmax + tmax + 3 * midmax + r) + FLT_MIN;
  for (int k = 0; k < 3; ++k) {
    sphere.c[k] = static_cast<float>(c[k]);
    shape.e[k] = static_cast<float>(double(local.e[k]) + slack);
  }
  shape.scale = static_cast<float>(std::max(cmax, r));
  shape.flags = local.flags & kVolumeKinds;
  if (local.inner_r > 0.f && double(local.inner_r) - slack > 0) {
    shape.inner_r = static_cast<float>(double(local.inner_r) - slack);
    shape.inner_z = local.inner_z;
  }
  const float rf = static_cast<float>(r + slack);
  // Out of float's range: no volumes (r stays negative).
  if (std::isfinite(rf) && std::isfinite(shape.scale) && std::isfinite(sphere.c[0]) &&
      std::isfinite(sphere.c[1]) && std::isfinite(sphere.c[2]) && std::isfinite(shape.e[0]) &&
      std::isfinite(shape.e[1]) && std::isfinite(shape.e[2]))
    sphere.r = rf;
}

}  // namespace

template <typename S>
void buildVolume(const fcl::CollisionObject<S>& o, VolumeSphere& sphere, VolumeShape& shape) {
  VolumeSource local;
  rebuildVolume(o, local, sphere, shape);
}

template <typename S>
void rebuildVolume(const fcl::CollisionObject<S>& o, VolumeSource& local, VolumeSphere& sphere,
                   VolumeShape& shape) {
  localVolume(o.collisionGeometry().get(), local);
  placeVolume(o, local, sphere, shape);
}

template <typename S>
void moveVolume(const fcl::CollisionObject<S>& o, VolumeSource& local, VolumeSphere& sphere,
                VolumeShape& shape) {
  // A moved object's geometry may have been resized in place too (then its box changed): its
  // local AABB, rounded as localVolume keeps it, says so for a few loads.
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  bool same = g != nullptr && (local.flags & kVolumeNone) == 0;
  for (int k = 0; k < 3 && same; ++k) {
    const double lo = g->aabb_local.min_[k], hi = g->aabb_local.max_[k];
    same =
        static_cast<float>((hi - lo) * 0.5) == local.e[k] &&
        ((local.flags & kVolumeSphere) != 0 || static_cast<float>((hi + lo) * 0.5) == local.mid[k]);
  }
  if (!same) localVolume(g, local);
  placeVolume(o, local, sphere, shape);
}

template <typename S>
bool refreshVolume(const fcl::CollisionObject<S>& o, VolumeSource& local, VolumeSphere& sphere,
                   VolumeShape& shape) {
  const S* m = o.getTransform().matrix().data();
  float R[9], t[3];
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) R[3 * k + j] = static_cast<float>(m[4 * j + k]);
    t[k] = static_cast<float>(m[12 + k]);
  }
  if (std::memcmp(R, shape.R, sizeof R) == 0 && std::memcmp(t, local.t, sizeof t) == 0)
    return false;
  placeVolume(o, local, sphere, shape);
  return true;
}

template <typename S>
Separation<S> separation(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                         S tolerance, S enough) {
  Tight<S> ta, tb;
  if (!tightOf(a, ta) || !tightOf(b, tb)) return {-std::numeric_limits<S>::infinity(), S(0)};
  const S floor = sizeof(S) >= 8 ? S(1e-6) : S(1e-4);
  const S scale = std::max({ta.c.cwiseAbs().maxCoeff(), tb.c.cwiseAbs().maxCoeff(), ta.r, tb.r});
  const S margin = std::max(S(2) * tolerance, floor) * (S(1) + scale);
  // The spheres: the cheapest bound, and exact for spheres.
  const S centres = (ta.c - tb.c).norm();
  const S spheres = centres - ta.r - tb.r;
  if ((ta.sphere && tb.sphere) || spheres > enough + margin) return {spheres, margin};
  if (!ta.withBox() || !tb.withBox()) return {spheres, margin};
  // Each box holds the ball of its smallest half extent about its centre, so no gap of the
  // boxes exceeds the gap of those balls; when that cannot clear `enough`, the boxes' tests
  // could not settle the pair and are skipped (most pairs a distance search offers).
  const S inner =
      centres - (ta.sphere ? ta.r : ta.e.minCoeff()) - (tb.sphere ? tb.r : tb.e.minCoeff());
  if (enough < std::numeric_limits<S>::infinity() && !(inner > enough + margin))
    return {spheres, margin};
  if (ta.sphere) return {std::max(spheres, pointBoxDistance(ta.c, tb) - ta.r), margin};
  if (tb.sphere) return {std::max(spheres, pointBoxDistance(tb.c, ta) - tb.r), margin};
  return {std::max(spheres, boxGap(ta, tb, enough + margin)), margin};
}

template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance) {
  const Separation<S> s = separation(a, b, tolerance, S(0));
  return s.lower_bound > s.margin;
}

template <typename S>
bool surelyTouching(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                    S tolerance) {
  fcl::Vector3<S> ca, cb;
  S ra, rb;
  if (!inscribedBall(a, ca, ra) || !inscribedBall(b, cb, rb)) return false;
  // separation's margin, from the same scale: the balls' centres and radii bound it from below
  // (each ball lies in its object's bounding sphere), so the margin here is at least as large.
  const S floor = sizeof(S) >= 8 ? S(1e-6) : S(1e-4);
  const S scale =
      std::max({ca.cwiseAbs().maxCoeff(), cb.cwiseAbs().maxCoeff(),
                S(a.collisionGeometry()->aabb_radius), S(b.collisionGeometry()->aabb_radius)});
  const S margin = std::max(S(2) * tolerance, floor) * (S(1) + scale + ra + rb);
  return (ca - cb).norm() < ra + rb - margin;
}

template <typename S>
Verdict verdict(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance,
                bool prove) {
  if (surelyApart(a, b, tolerance)) return Verdict::kApart;
  if (prove && surelyTouching(a, b, tolerance)) return Verdict::kTouching;
  return Verdict::kUnknown;
}

template void buildVolume<double>(const fcl::CollisionObject<double>&, VolumeSphere&, VolumeShape&);
template void buildVolume<float>(const fcl::CollisionObject<float>&, VolumeSphere&, VolumeShape&);
template void moveVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&, VolumeSphere&,
                                 VolumeShape&);
template void moveVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&, VolumeSphere&,
                                VolumeShape&);
template void rebuildVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&,
                                    VolumeSphere&, VolumeShape&);
template void rebuildVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&, VolumeSphere&,
                                   VolumeShape&);
template bool refreshVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&,
                                    VolumeSphere&, VolumeShape&);
template bool refreshVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&, VolumeSphere&,
                                   VolumeShape&);
template Separation<double> separation<double>(const fcl::CollisionObject<double>&,
                                               const fcl::CollisionObject<double>&, double, double);
template Separation<float> separation<float>(const fcl::CollisionObject<float>&,
                                             const fcl::CollisionObject<float>&, float, float);
template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                  const fcl::CollisionObject<double>&, double);
template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                 const fcl::CollisionObject<float>&, float);
template bool surelyTouching<double>(const fcl::CollisionObject<double>&,
                                     const fcl::CollisionObject<double>&, double);
template bool surelyTouching<float>(const fcl::CollisionObject<float>&,
                                    const fcl::CollisionObject<float>&, float);
template Verdict verdict<double>(const fcl::CollisionObject<double>&,
                                 const fcl::CollisionObject<double>&, double, bool);
template Verdict verdict<float>(const fcl::CollisionObject<float>&,
                                const fcl::CollisionObject<float>&, float, bool);

}  // namespace detail
}  // namespace cube
