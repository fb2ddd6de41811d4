// The objects' float records (core/volume.h: buildVolume, rebuildVolume, moveVolume,
// refreshVolume): the geometry's part (its local box, bounding and inscribed balls, the kind of
// round primitive) and its placement by the object's transform, rounded outwards.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/volume.h"

namespace cube {
namespace detail {

namespace {

// A ball inside the geometry, in its frame: the ball's centre is on the z axis at `z`.
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
  // Beyond what the cull's float arithmetic takes: no volumes (r stays negative).
  if (std::isfinite(rf) && shape.scale <= kVolumeMaxScale && std::isfinite(sphere.c[0]) &&
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
void buildBall(const fcl::CollisionObject<S>& o, VolumeBall<S>& ball) {
  ball.sphere = kNoVolume;
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr) return;
  const fcl::NODE_TYPE type = g->getNodeType();
  if (type == fcl::GEOM_PLANE || type == fcl::GEOM_HALFSPACE || type == fcl::GEOM_OCTREE) return;
  const bool is_sphere = type == fcl::GEOM_SPHERE;
  const S* m = o.getTransform().matrix().data();  // 4x4, by columns
  ball.geometry = g;
  ball.pose = m;
  // A sphere about its frame's origin; any other geometry, its local AABB's circumscribed
  // sphere about that box's centre, as FCL keeps them (what buildVolume computes from the box).
  const S r = is_sphere ? static_cast<const fcl::Sphere<S>*>(g)->radius : g->aabb_radius;
  S c[3] = {m[12], m[13], m[14]};
  if (!is_sphere) {
    const S* a = g->aabb_center.data();
    for (int k = 0; k < 3; ++k) c[k] += m[k] * a[0] + m[4 + k] * a[1] + m[8 + k] * a[2];
  }
  const S scale = std::max({std::fabs(c[0]), std::fabs(c[1]), std::fabs(c[2]), r});
  // Beyond what the cull's float arithmetic takes (and not finite, and r < 0): no volumes.
  if (!(std::isfinite(c[0] + c[1] + c[2] + r) && r >= S(0) && scale <= S(kVolumeMaxScale))) return;
  // Rounding the centre to floats moves it by under an ulp of |c|, and the radius rounds by half
  // an ulp of r; a geometry of float S keeps aabb_radius to a few ulps of r and the centre to a
  // few of |c| (volumeMarginRate's floor for float covers far more).
  for (int k = 0; k < 3; ++k) ball.sphere.c[k] = static_cast<float>(c[k]);
  ball.sphere.r = static_cast<float>(double(r) + 8.0 * FLT_EPSILON * double(scale) + FLT_MIN);
  ball.scale = static_cast<float>(scale);
  ball.exact = is_sphere;
}

template <typename S>
bool buildBox(const VolumeBall<S>& ball, VolumeShape& shape) {
  shape.scale = ball.scale;
  shape.inner_r = 0.f;
  shape.inner_z = 0.f;
  if (ball.exact) {
    shape.flags = kVolumeSphere;
    return true;
  }
  shape.flags = 0u;
  const fcl::CollisionGeometry<S>* g = ball.geometry;
  const fcl::AABB<S>& local = g->aabb_local;
  if ((local.max_ + local.min_) * S(0.5) != g->aabb_center) return false;
  const S* m = ball.pose;
  // The axes round by half an ulp each (1.5 ulps of r at a corner), the half extents by half an
  // ulp, the centre (buildBall) by an ulp of |c|: buildBall's slack covers it.
  const double slack = 8.0 * FLT_EPSILON * double(ball.scale) + FLT_MIN;
  float sum = 0.f;  // not finite if any axis or extent is not
  bool sized = true;
  for (int k = 0; k < 3; ++k) {
    const double e = 0.5 * (double(local.max_[k]) - double(local.min_[k]));
    shape.e[k] = static_cast<float>(e + slack);
    sized = sized && e >= 0;
    sum += shape.e[k];
    for (int j = 0; j < 3; ++j) {
      shape.R[3 * k + j] = static_cast<float>(m[4 * j + k]);
      sum += shape.R[3 * k + j];
    }
  }
  return sized && std::isfinite(sum);
}

template <typename S>
bool buildInner(const VolumeBall<S>& ball, VolumeShape& shape) {
  const fcl::CollisionGeometry<S>* g = ball.geometry;
  // As localVolume: only for geometries centred on their frame's origin.
  const double mid = ball.exact ? 0.0 : double(g->aabb_center.cwiseAbs().maxCoeff());
  double z = 0, inner = 0;
  if (!(mid <= 1e-12 * (1.0 + double(ball.scale))) || !localInscribedBall(*g, z, inner))
    return false;
  if (ball.exact)  // a sphere's box record has no axes; its ball is about its centre
    for (float& x : shape.R) x = 0.f;
  // buildBox's slack for the rounded centre and axes, and the ball's centre being the geometry's
  // origin, not its box's centre (under 2 mid away).
  const double r = inner - 8.0 * FLT_EPSILON * double(ball.scale) - FLT_MIN - 2.0 * mid;
  if (!(r > 0)) return false;
  shape.inner_r = static_cast<float>(r);
  shape.inner_z = static_cast<float>(z);
  return true;
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

template void buildVolume<double>(const fcl::CollisionObject<double>&, VolumeSphere&, VolumeShape&);
template void buildVolume<float>(const fcl::CollisionObject<float>&, VolumeSphere&, VolumeShape&);
template void buildBall<double>(const fcl::CollisionObject<double>&, VolumeBall<double>&);
template void buildBall<float>(const fcl::CollisionObject<float>&, VolumeBall<float>&);
template bool buildBox<double>(const VolumeBall<double>&, VolumeShape&);
template bool buildBox<float>(const VolumeBall<float>&, VolumeShape&);
template bool buildInner<double>(const VolumeBall<double>&, VolumeShape&);
template bool buildInner<float>(const VolumeBall<float>&, VolumeShape&);
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

}  // namespace detail
}  // namespace cube
