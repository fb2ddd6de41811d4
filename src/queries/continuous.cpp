#include "cube_collision/continuous.h"

#include <fcl/math/motion/screw_motion.h>
#include <fcl/math/motion/translation_motion.h>
#include <fcl/narrowphase/continuous_collision.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "adapter/manager_access.h"
#include "adapter/query_guard.h"
#include "core/broadphase.h"
#include "pipeline/fcl_narrow.h"

namespace cube {

namespace {

using detail::Box;
using detail::ObjectId;

[[noreturn]] void fail(const char* where, const std::string& what) {
  throw std::invalid_argument(std::string("cube::") + where + ": " + what);
}

template <typename S>
bool finite(const fcl::Transform3<S>& tf) {
  return tf.matrix().allFinite();
}

void checkMotionType(fcl::CCDMotionType type, const char* where) {
  if (type == fcl::CCDM_TRANS || type == fcl::CCDM_SCREW) return;
  if (type == fcl::CCDM_LINEAR)
    fail(where,
         "CCDM_LINEAR is not supported: FCL 0.7's InterpMotion leaves its reference point "
         "uninitialized, so its poses are undefined");
  if (type == fcl::CCDM_SPLINE)
    fail(where,
         "CCDM_SPLINE is not supported: FCL 0.7's SplineMotion from two transforms is empty");
  fail(where, "unknown motion type " + std::to_string(int(type)));
}

// The sweep is computed in double whatever S is: FCL runs its motions in double (the only
// precision its continuous collision compiles for), and the box is rounded outward to S at the
// end.
struct DBox {
  fcl::Vector3d lo = fcl::Vector3d::Constant(std::numeric_limits<double>::infinity());
  fcl::Vector3d hi = fcl::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  void add(const fcl::Vector3d& c, const fcl::Vector3d& half) {
    lo = lo.cwiseMin(c - half);
    hi = hi.cwiseMax(c + half);
  }
};

// The local AABB (centre m, half sides e) at pose (R, T): a box at R m + T with half sides
// |R| e, never larger than the sphere of radius |e| FCL's computeAABB uses for rotated objects.
void addPosed(DBox& box, const fcl::Matrix3d& R, const fcl::Vector3d& T, const fcl::Vector3d& m,
              const fcl::Vector3d& e) {
  box.add(R * m + T, R.cwiseAbs() * e);
}

template <typename S>
DBox sweep(const fcl::CollisionObject<S>& object, const fcl::Transform3<S>& end,
           fcl::CCDMotionType type) {
  const fcl::AABB<S>& local = object.collisionGeometry()->aabb_local;
  const fcl::Vector3d lo = local.min_.template cast<double>();
  const fcl::Vector3d hi = local.max_.template cast<double>();
  DBox box;
  const fcl::Vector3d m = (lo + hi) * 0.5;
  const fcl::Vector3d e = (hi - lo) * 0.5;
  const double rho = e.norm();  // every point of the geometry is within rho of m
  // Planes and halfspaces have local AABBs of +-max(S), whose sizes overflow: anywhere.
  if (!m.allFinite() || !std::isfinite(rho)) {
    box.lo.setConstant(-std::numeric_limits<double>::infinity());
    box.hi.setConstant(std::numeric_limits<double>::infinity());
    return box;
  }
  const fcl::Transform3d tf1 = object.getTransform().template cast<double>();
  const fcl::Transform3d tf2 = end.template cast<double>();
  const fcl::Vector3d T1 = tf1.translation();
  const fcl::Vector3d T2 = tf2.translation();
  double scale = 0;  // magnitude of what FCL and we compute, for the rounding pad
  if (type == fcl::CCDM_TRANS) {
    // TranslationMotion: the rotation (through a quaternion) of the start at every time, the
    // translation T1 + (T2 - T1) t. A box translated along a segment sweeps the hull of its ends.
    const fcl::Matrix3d R = fcl::Quaterniond(tf1.linear()).toRotationMatrix();
    addPosed(box, R, T1, m, e);
    addPosed(box, R, T1 + (T2 - T1), m, e);
    scale = T1.norm() + T2.norm() + m.norm() + rho;
  } else {
    // ScrewMotion: x(t) = D(t theta) (x0 - p) + p + axis * (t lv), D a rotation about the unit
    // axis by t theta, theta in [0, pi]. Read from FCL's own object, so that its quirks hold here
    // too: below 1e-10 rad, axis = T2 - T1 unnormalized and lv = |T2 - T1|, so the object moves
    // by |T2 - T1| (T2 - T1) and does not end at T2.
    const fcl::ScrewMotion<double> motion(tf1, tf2);
    const double theta = motion.getAngularVelocity();
    const fcl::Vector3d p = motion.getAxisOrigin();
    const fcl::Vector3d v = motion.getAxis() * motion.getLinearVelocity();
    const fcl::Vector3d c0 = tf1 * m;  // the centre of the local AABB at the start
    fcl::Vector3d base = c0;
    fcl::Vector3d arc = fcl::Vector3d::Zero();  // half sides of the box of the centre's arc
    if (theta > 0) {
      // The centre circles the axis: with d = c0 - p = h a + u (u normal to a), it is at
      // p + h a + D(phi) u + t v. For phi in [0, theta], theta <= pi, D(phi) u lies within
      // |u| sin(theta / 2) of the midpoint of its chord ((u + D(theta) u) / 2): the arc is in
      // the ball on the chord as diameter (|q - mid|^2 = |u|^2 (1 + c^2 - 2 c cos(phi -
      // theta / 2)) <= |u|^2 (1 - c^2) with c = cos(theta / 2) >= 0).
      const fcl::Vector3d a = motion.getAxis();
      const fcl::Vector3d d = c0 - p;
      const double h = a.dot(d);
      const fcl::Vector3d u = d - h * a;
      const fcl::Vector3d u1 = std::cos(theta) * u + std::sin(theta) * a.cross(u);
      base = p + h * a + (u + u1) * 0.5;
      // The arc is also in the plane through the midpoint normal to a: in a disc, whose box has
      // half sides r sqrt(1 - a_k^2).
      const double r = u.norm() * std::sin(theta * 0.5);
      arc = r * (fcl::Vector3d::Ones() - a.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
      scale = p.norm() + d.norm();
    }
    // The centre is in base + [0, 1] v + the arc's box, every point within rho of the centre.
    const fcl::Vector3d grow = arc + fcl::Vector3d::Constant(rho);
    box.add(base, grow);
    box.add(base + v, grow);
    // Never smaller than the two end boxes (FCL's pose at t = 1 is where its motion ends).
    addPosed(box, tf1.linear(), T1, m, e);
    motion.integrate(1);
    fcl::Transform3d at_end;
    motion.getCurrentTransform(at_end);
    addPosed(box, at_end.linear(), at_end.translation(), m, e);
    scale += c0.norm() + v.norm() + rho + T1.norm() + T2.norm() + at_end.translation().norm();
  }
  // FCL's evaluation of the motion and ours round differently: a few hundred ulps of the
  // magnitudes involved keep its poses inside. FCL also turns the start rotation into a
  // quaternion and back, which moves a point x by up to about |R1^T R1 - I| |x|: a rotation
  // rounded to float is orthonormal to 1e-7 only.
  const fcl::Matrix3d gram = tf1.linear().transpose() * tf1.linear() - fcl::Matrix3d::Identity();
  const double skew = gram.cwiseAbs().maxCoeff();
  const double pad =
      256 * std::numeric_limits<double>::epsilon() * scale + 8 * skew * (m.norm() + rho);
  box.lo.array() -= pad;
  box.hi.array() += pad;
  return box;
}

// Outward rounding to S; beyond S's range, infinity (the conversion itself would be undefined).
template <typename S>
S down(double x) {
  if (x < -double(std::numeric_limits<S>::max())) return -std::numeric_limits<S>::infinity();
  const S y = S(x);
  return double(y) <= x ? y : std::nextafter(y, -std::numeric_limits<S>::infinity());
}

template <typename S>
S up(double x) {
  if (x > double(std::numeric_limits<S>::max())) return std::numeric_limits<S>::infinity();
  const S y = S(x);
  return double(y) >= x ? y : std::nextafter(y, std::numeric_limits<S>::infinity());
}

template <typename S>
void checkObjectMotion(const fcl::CollisionObject<S>& object, const fcl::Transform3<S>& end,
                       const char* where, const std::string& name) {
  if (!object.collisionGeometry()) fail(where, name + " has no geometry");
  if (!finite(object.getTransform()))
    fail(where, name + "'s current transform has a NaN or infinite entry");
  if (!finite(end)) fail(where, name + "'s end transform has a NaN or infinite entry");
}

template <typename S>
using ObjectPairs = std::vector<std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>>;

// What the two walks report, before ordering.
template <typename S>
struct Found {
  const detail::ObjectTable<S>* table;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seqs;
  std::vector<std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>> pairs;

  // Each pair with its lower registration number first.
  static bool add(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b, ObjectId ib,
                  void* data) {
    Found& f = *static_cast<Found*>(data);
    std::uint32_t sa = f.table->seq(ia), sb = f.table->seq(ib);
    if (sb < sa) {
      std::swap(a, b);
      std::swap(sa, sb);
    }
    f.seqs.emplace_back(sa, sb);
    f.pairs.emplace_back(a, b);
    return false;
  }
};

// fcl::continuousCollide's naive sampling (fcl::collide at t = i / (n - 1), i < n, with FCL's
// default request; the first t in contact) for a pair whose contact test FCL 0.7 gets wrong,
// with the library's test (fclCollide) in place of FCL's.
void sampledCollide(const fcl::CollisionObjectd& a, const fcl::Transform3d& end_a,
                    const fcl::CollisionObjectd& b, const fcl::Transform3d& end_b,
                    const fcl::ContinuousCollisionRequestd& request,
                    fcl::ContinuousCollisionResultd& result) {
  const auto motion = [&](const fcl::Transform3d& from,
                          const fcl::Transform3d& to) -> std::unique_ptr<fcl::MotionBase<double>> {
    if (request.ccd_motion_type == fcl::CCDM_SCREW)
      return std::make_unique<fcl::ScrewMotion<double>>(from, to);
    return std::make_unique<fcl::TranslationMotion<double>>(from, to);
  };
  const std::unique_ptr<fcl::MotionBase<double>> ma = motion(a.getTransform(), end_a);
  const std::unique_ptr<fcl::MotionBase<double>> mb = motion(b.getTransform(), end_b);
  const std::size_t n =
      std::min(request.num_max_iterations, std::size_t(std::ceil(1 / request.toc_err)));
  fcl::Transform3d tf_a, tf_b;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = double(i) / double(n - 1);
    ma->integrate(t);
    mb->integrate(t);
    ma->getCurrentTransform(tf_a);
    mb->getCurrentTransform(tf_b);
    fcl::CollisionResultd c;
    if (detail::collideDefective(a.collisionGeometry().get(), tf_a, b.collisionGeometry().get(),
                                 tf_b, fcl::CollisionRequestd(), c) > 0) {
      result.is_collide = true;
      result.time_of_contact = t;
      result.contact_tf1 = tf_a;
      result.contact_tf2 = tf_b;
      return;
    }
  }
  result.is_collide = false;
  result.time_of_contact = 1;
}

}  // namespace

template <typename S>
fcl::AABB<S> sweptBox(const fcl::CollisionObject<S>& object, const fcl::Transform3<S>& end,
                      fcl::CCDMotionType motion_type) {
  checkMotionType(motion_type, "sweptBox");
  checkObjectMotion(object, end, "sweptBox", "the object");
  const DBox b = sweep(object, end, motion_type);
  fcl::AABB<S> out;
  for (int k = 0; k < 3; ++k) {
    out.min_[k] = down<S>(b.lo[k]);
    out.max_[k] = up<S>(b.hi[k]);
  }
  return out;
}

template <typename S>
ObjectPairs<S> sweptPairs(const CubeCollisionManager<S>& manager,
                          const std::vector<Motion<S>>& motions, fcl::CCDMotionType motion_type) {
  const char* where = "sweptPairs";
  checkMotionType(motion_type, where);
  const detail::Broadphase<S>& core = detail::coreOf(manager);
  const detail::ObjectTable<S>& table = core.table();
  std::vector<char> moving(table.idBound(), 0);
  for (std::size_t i = 0; i < motions.size(); ++i) {
    const std::string name = "motions[" + std::to_string(i) + "]";
    fcl::CollisionObject<S>* obj = motions[i].object;
    if (obj == nullptr) fail(where, name + ".object is null");
    const ObjectId id = table.find(obj);
    if (id == detail::kNone) fail(where, name + ".object is not registered in the manager");
    if (moving[id]) fail(where, name + ".object is listed twice");
    moving[id] = 1;
    checkObjectMotion(*obj, motions[i].end, where, name + ".object");
  }

  // The movers' swept boxes through the core's sweep query: with one another, then with the
  // objects that stay, under the manager's margins, filter bits and pair predicate.
  std::vector<ObjectId> ids(motions.size());
  std::vector<Box<S>> boxes(motions.size());
  for (std::size_t i = 0; i < motions.size(); ++i) {
    ids[i] = table.find(motions[i].object);
    const fcl::AABB<S> b = sweptBox(*motions[i].object, motions[i].end, motion_type);
    for (int k = 0; k < 3; ++k) {
      boxes[i].lo[k] = b.min_[k];
      boxes[i].hi[k] = b.max_[k];
    }
  }
  Found<S> found{&table, {}, {}};
  {
    // The pair predicate is the user's code: a mutation of the manager from it is refused, as
    // from the manager's own queries.
    const detail::QueryScope scope(&core);
    core.collideMoving(ids.data(), boxes.data(), ids.size(), &found, &Found<S>::add);
  }

  std::vector<std::size_t> order(found.pairs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t x, std::size_t y) { return found.seqs[x] < found.seqs[y]; });
  ObjectPairs<S> out;
  out.reserve(order.size());
  for (std::size_t i : order) out.push_back(found.pairs[i]);
  return out;
}

std::vector<ContinuousContact> continuousCollideAll(
    const CubeCollisionManager<double>& manager, const std::vector<Motion<double>>& motions,
    const fcl::ContinuousCollisionRequest<double>& request, bool earliest_only) {
  const char* where = "continuousCollideAll";
  if (request.ccd_solver_type != fcl::CCDC_NAIVE)
    fail(where,
         "only ccd_solver_type CCDC_NAIVE is supported (FCL's other solvers report contact "
         "within a tolerance or not at all)");
  if (!(request.toc_err > 0) || !std::isfinite(request.toc_err))
    fail(where, "request.toc_err must be a positive number");
  // FCL samples t = i / (n - 1) for i < n: n < 2 divides by zero.
  const double samples =
      std::min(double(request.num_max_iterations), std::ceil(1 / request.toc_err));
  if (samples < 2)
    fail(where,
         "the request samples fewer than two times (min(num_max_iterations, "
         "ceil(1 / toc_err)) < 2)");
  checkMotionType(request.ccd_motion_type, where);

  const auto pairs = sweptPairs(manager, motions, request.ccd_motion_type);
  // Each mover's end; a still object ends where it is.
  const detail::ObjectTable<double>& table = detail::coreOf(manager).table();
  std::vector<const fcl::Transform3d*> end(table.idBound(), nullptr);
  for (const Motion<double>& m : motions) end[table.find(m.object)] = &m.end;
  const auto endOf = [&](const fcl::CollisionObject<double>* obj) -> const fcl::Transform3d& {
    const fcl::Transform3d* e = end[table.find(obj)];
    return e ? *e : obj->getTransform();
  };

  std::vector<ContinuousContact> out;
  for (const auto& [a, b] : pairs) {
    fcl::ContinuousCollisionResult<double> result;
    if (detail::contactDefective(a->getNodeType(), b->getNodeType()))
      sampledCollide(*a, endOf(a), *b, endOf(b), request, result);
    else
      fcl::continuousCollide(a, endOf(a), b, endOf(b), request, result);
    if (!result.is_collide) continue;
    ContinuousContact c;
    c.a = a;
    c.b = b;
    c.time_of_contact = result.time_of_contact;
    c.tf_a = result.contact_tf1;
    c.tf_b = result.contact_tf2;
    out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const ContinuousContact& x, const ContinuousContact& y) {
                     return x.time_of_contact < y.time_of_contact;
                   });
  if (earliest_only && out.size() > 1) out.resize(1);
  return out;
}

#define CUBE_INSTANTIATE_CONTINUOUS(S)                                                      \
  template fcl::AABB<S> sweptBox(const fcl::CollisionObject<S>&, const fcl::Transform3<S>&, \
                                 fcl::CCDMotionType);                                       \
  template ObjectPairs<S> sweptPairs(const CubeCollisionManager<S>&,                        \
                                     const std::vector<Motion<S>>&, fcl::CCDMotionType);

CUBE_INSTANTIATE_CONTINUOUS(double)
CUBE_INSTANTIATE_CONTINUOUS(float)
#undef CUBE_INSTANTIATE_CONTINUOUS

}  // namespace cube
