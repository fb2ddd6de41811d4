#pragma once

// Brute force for planes and halfspaces, written apart from the library's code: an object's
// lowest value of n . x (world frame) from each geometry's own description (a box's corners, a
// capsule's end balls, a cylinder's and cone's lowest rim point by formula, an ellipsoid as the
// image of a unit ball, vertices of polytopes and meshes, the corners of an octree's occupied
// cells), and from it the distance to a plane (two-sided, n . x = d) or halfspace (n . x <= d),
// and the true contact answer of a shape against one of them.

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace cube {
namespace brute {

/// min over the object of n . x, n a world unit vector.
template <typename S>
double lowest(const fcl::CollisionObject<S>& o, const Eigen::Vector3d& n) {
  const fcl::CollisionGeometry<S>& g = *o.collisionGeometry();
  const Eigen::Matrix3d R = o.getTransform().linear().template cast<double>();
  const Eigen::Vector3d t = o.getTransform().translation().template cast<double>();
  const Eigen::Vector3d axis = R.col(2);
  const double c = t.dot(n);
  const double an = axis.dot(n);
  const double across = std::sqrt(std::max(0.0, 1 - an * an));  // |n| off the axis
  double best = std::numeric_limits<double>::infinity();
  const auto point = [&](const Eigen::Vector3d& local) {
    best = std::min(best, (R * local + t).dot(n));
  };
  switch (g.getNodeType()) {
    case fcl::GEOM_SPHERE:
      return c - double(static_cast<const fcl::Sphere<S>&>(g).radius);
    case fcl::GEOM_BOX: {
      const Eigen::Vector3d s = static_cast<const fcl::Box<S>&>(g).side.template cast<double>();
      for (int i = 0; i < 8; ++i)
        point(Eigen::Vector3d(i & 1 ? s[0] / 2 : -s[0] / 2, i & 2 ? s[1] / 2 : -s[1] / 2,
                              i & 4 ? s[2] / 2 : -s[2] / 2));
      return best;
    }
    case fcl::GEOM_CAPSULE: {
      const auto& k = static_cast<const fcl::Capsule<S>&>(g);
      return c - std::abs(an) * double(k.lz) / 2 - double(k.radius);
    }
    case fcl::GEOM_CYLINDER: {
      const auto& k = static_cast<const fcl::Cylinder<S>&>(g);
      return c - std::abs(an) * double(k.lz) / 2 - double(k.radius) * across;
    }
    case fcl::GEOM_CONE: {
      // Apex at +lz/2 on the axis, base disc at -lz/2.
      const auto& k = static_cast<const fcl::Cone<S>&>(g);
      const double apex = c + an * double(k.lz) / 2;
      const double base = c - an * double(k.lz) / 2 - double(k.radius) * across;
      return std::min(apex, base);
    }
    case fcl::GEOM_ELLIPSOID: {
      // The image of the unit ball under R diag(radii): lowest at c - |diag(radii) R^T n|.
      const Eigen::Vector3d r =
          static_cast<const fcl::Ellipsoid<S>&>(g).radii.template cast<double>();
      return c - (r.asDiagonal() * (R.transpose() * n)).norm();
    }
    case fcl::GEOM_CONVEX: {
      for (const auto& v : static_cast<const fcl::Convex<S>&>(g).getVertices())
        point(v.template cast<double>());
      return best;
    }
    case fcl::BV_OBBRSS: {
      const auto& m = static_cast<const fcl::BVHModel<fcl::OBBRSS<S>>&>(g);
      for (int i = 0; i < m.num_vertices; ++i) point(m.vertices[i].template cast<double>());
      return best;
    }
    case fcl::BV_AABB: {
      const auto& m = static_cast<const fcl::BVHModel<fcl::AABB<S>>&>(g);
      for (int i = 0; i < m.num_vertices; ++i) point(m.vertices[i].template cast<double>());
      return best;
    }
    case fcl::GEOM_OCTREE: {
      for (const auto& b : static_cast<const fcl::OcTree<S>&>(g).toBoxes())
        for (int i = 0; i < 8; ++i) {
          const double h = double(b[3]) / 2;
          point(Eigen::Vector3d(double(b[0]) + (i & 1 ? h : -h), double(b[1]) + (i & 2 ? h : -h),
                                double(b[2]) + (i & 4 ? h : -h)));
        }
      return best;
    }
    default:
      throw std::logic_error("brute::lowest: a kind this test does not know");
  }
}

/// The convex parts of a mesh (its triangles) or an octree (its occupied cells, 8 corners each),
/// as world points; empty for any other kind (itself convex).
template <typename S>
std::vector<std::vector<Eigen::Vector3d>> parts(const fcl::CollisionObject<S>& o) {
  const fcl::CollisionGeometry<S>& g = *o.collisionGeometry();
  const auto world = [&](const Eigen::Vector3d& local) {
    return Eigen::Vector3d(o.getTransform().linear().template cast<double>() * local +
                           o.getTransform().translation().template cast<double>());
  };
  std::vector<std::vector<Eigen::Vector3d>> out;
  const auto mesh = [&](const auto& m) {
    for (int t = 0; t < m.num_tris; ++t) {
      out.emplace_back();
      for (int k = 0; k < 3; ++k)
        out.back().push_back(world(m.vertices[m.tri_indices[t][k]].template cast<double>()));
    }
  };
  if (g.getNodeType() == fcl::BV_OBBRSS) mesh(static_cast<const fcl::BVHModel<fcl::OBBRSS<S>>&>(g));
  if (g.getNodeType() == fcl::BV_AABB) mesh(static_cast<const fcl::BVHModel<fcl::AABB<S>>&>(g));
  if (g.getNodeType() == fcl::GEOM_OCTREE)
    for (const auto& b : static_cast<const fcl::OcTree<S>&>(g).toBoxes()) {
      out.emplace_back();
      const double h = double(b[3]) / 2;
      for (int i = 0; i < 8; ++i)
        out.back().push_back(
            world(Eigen::Vector3d(double(b[0]) + (i & 1 ? h : -h), double(b[1]) + (i & 2 ? h : -h),
                                  double(b[2]) + (i & 4 ? h : -h))));
    }
  return out;
}

/// A plane or halfspace object's boundary in the world frame: n . x = d.
template <typename S>
void boundary(const fcl::CollisionObject<S>& p, Eigen::Vector3d& n, double& d) {
  const fcl::CollisionGeometry<S>& g = *p.collisionGeometry();
  Eigen::Vector3d ln;
  double ld;
  if (g.getNodeType() == fcl::GEOM_PLANE) {
    ln = static_cast<const fcl::Plane<S>&>(g).n.template cast<double>();
    ld = double(static_cast<const fcl::Plane<S>&>(g).d);
  } else {
    ln = static_cast<const fcl::Halfspace<S>&>(g).n.template cast<double>();
    ld = double(static_cast<const fcl::Halfspace<S>&>(g).d);
  }
  n = p.getTransform().linear().template cast<double>() * ln;
  d = ld + n.dot(p.getTransform().translation().template cast<double>());
}

inline bool planar(fcl::NODE_TYPE t) {
  return t == fcl::GEOM_PLANE || t == fcl::GEOM_HALFSPACE;
}

/// The signed gap of object o to the plane or halfspace p: > 0 apart (the distance), <= 0 they
/// meet. For a plane, a mesh or octree is the union of its triangles or cells.
template <typename S>
double gap(const fcl::CollisionObject<S>& p, const fcl::CollisionObject<S>& o) {
  Eigen::Vector3d n;
  double d;
  boundary(p, n, d);
  const double lo = lowest(o, n) - d;
  if (p.getNodeType() == fcl::GEOM_HALFSPACE) return lo;
  // A plane: the least gap over the convex parts, each above (its lowest point's height), below
  // (its highest point's depth) or across (<= 0).
  const auto split = parts(o);
  if (split.empty()) return std::max(lo, d - (-lowest(o, Eigen::Vector3d(-n))));
  double best = std::numeric_limits<double>::infinity();
  for (const auto& part : split) {
    double plo = std::numeric_limits<double>::infinity(), phi = -plo;
    for (const auto& x : part) {
      plo = std::min(plo, x.dot(n) - d);
      phi = std::max(phi, x.dot(n) - d);
    }
    best = std::min(best, std::max(plo, -phi));
  }
  return best;
}

/// The distance of a pair with a plane or halfspace (the other not planar): the gap, or -1 (FCL's
/// answer for objects that meet) when they meet.
template <typename S>
double distance(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b) {
  const double g = planar(a.getNodeType()) ? gap(a, b) : gap(b, a);
  return g > 0 ? g : -1;
}

/// Whether two objects touch: from the geometry for a cylinder, cone or convex polytope against
/// a plane or halfspace (FCL 0.7 answers some of these wrongly or crashes), fcl::collide (FCL's
/// default request) otherwise.
template <typename S>
bool touch(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b) {
  const auto round = [](fcl::NODE_TYPE t) {
    return t == fcl::GEOM_CYLINDER || t == fcl::GEOM_CONE || t == fcl::GEOM_CONVEX;
  };
  if (planar(a.getNodeType()) && round(b.getNodeType())) return gap(a, b) <= 0;
  if (planar(b.getNodeType()) && round(a.getNodeType())) return gap(b, a) <= 0;
  fcl::CollisionRequest<S> req;
  fcl::CollisionResult<S> res;
  return fcl::collide(&a, &b, req, res) > 0;
}

}  // namespace brute
}  // namespace cube
