#pragma once

// Closed-form answers for planes and halfspaces where FCL 0.7 gives none or a wrong one: the
// distance of any object to a plane or halfspace (fcl::distance crashes on them), and the
// cylinder-plane and cone-halfspace contact tests (FCL's yes/no cylinder-plane test projects lz
// where lz/2 belongs; its cone-halfspace test takes every cone whose apex points into the
// halfspace for one lying on its side). Included by callbacks.cpp only.

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
#include <fcl/geometry/shape/triangle_p.h>
#include <fcl/geometry/shape/utility.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <cmath>
#include <limits>

namespace cube {
namespace detail {
namespace planes {

template <typename S>
using V3 = fcl::Vector3<S>;

/// A plane or a halfspace boundary in the world frame: n . x = d, n a unit vector.
template <typename S>
struct WorldPlane {
  V3<S> n;
  S d;
};

template <typename S>
WorldPlane<S> worldPlane(const fcl::CollisionGeometry<S>* g, const fcl::Transform3<S>& tf) {
  V3<S> n;
  S d;
  if (g->getNodeType() == fcl::GEOM_PLANE) {
    const auto& p = static_cast<const fcl::Plane<S>&>(*g);
    n = p.n, d = p.d;
  } else {
    const auto& h = static_cast<const fcl::Halfspace<S>&>(*g);
    n = h.n, d = h.d;
  }
  const V3<S> nw = tf.linear() * n;
  return {nw, d + nw.dot(tf.translation())};
}

/// An object's extent along a world unit direction u: the least and greatest u . x over it and
/// points where they are reached (world frame).
template <typename S>
struct Extent {
  S lo = std::numeric_limits<S>::infinity();
  S hi = -std::numeric_limits<S>::infinity();
  V3<S> at_lo = V3<S>::Zero(), at_hi = V3<S>::Zero();

  void add(const V3<S>& p, S s) {
    if (s < lo) lo = s, at_lo = p;
    if (s > hi) hi = s, at_hi = p;
  }
  bool empty() const { return !(lo <= hi); }
};

// Component signs with 0 counted positive: a support point exists for any direction.
template <typename S>
S signOf(S x) {
  return x < 0 ? S(-1) : S(1);
}

// The point of a circle of radius r in the local xy plane farthest along v (its centre when v
// is along z).
template <typename S>
V3<S> rimPoint(const V3<S>& v, S r) {
  const S rho = std::sqrt(v[0] * v[0] + v[1] * v[1]);
  if (!(rho > 0)) return V3<S>::Zero();
  return V3<S>(r * v[0] / rho, r * v[1] / rho, 0);
}

// A local point of a shape farthest along the local direction v (unit): the shape's support.
// False for a geometry that is not one of the primitives.
template <typename S>
bool localSupport(const fcl::CollisionGeometry<S>& g, const V3<S>& v, V3<S>& p) {
  switch (g.getNodeType()) {
    case fcl::GEOM_SPHERE:
      p = static_cast<const fcl::Sphere<S>&>(g).radius * v;
      return true;
    case fcl::GEOM_BOX: {
      const V3<S> half = static_cast<const fcl::Box<S>&>(g).side * S(0.5);
      p = V3<S>(signOf(v[0]) * half[0], signOf(v[1]) * half[1], signOf(v[2]) * half[2]);
      return true;
    }
    case fcl::GEOM_CAPSULE: {
      const auto& c = static_cast<const fcl::Capsule<S>&>(g);
      p = V3<S>(0, 0, signOf(v[2]) * c.lz / 2) + c.radius * v;
      return true;
    }
    case fcl::GEOM_CYLINDER: {
      const auto& c = static_cast<const fcl::Cylinder<S>&>(g);
      p = rimPoint(v, c.radius) + V3<S>(0, 0, signOf(v[2]) * c.lz / 2);
      return true;
    }
    case fcl::GEOM_CONE: {
      // The apex at +lz/2 or the base's rim at -lz/2, whichever reaches farther.
      const auto& c = static_cast<const fcl::Cone<S>&>(g);
      const V3<S> apex(0, 0, c.lz / 2);
      const V3<S> rim = rimPoint(v, c.radius) - apex;
      p = v.dot(apex) >= v.dot(rim) ? apex : rim;
      return true;
    }
    case fcl::GEOM_ELLIPSOID: {
      // x . v is largest over x^T diag(1/r^2) x = 1 at diag(r^2) v / |diag(r) v|.
      const V3<S>& r = static_cast<const fcl::Ellipsoid<S>&>(g).radii;
      const S h = r.cwiseProduct(v).norm();
      p = h > 0 ? V3<S>(r.cwiseProduct(r).cwiseProduct(v) / h) : V3<S>::Zero();
      return true;
    }
    default:
      return false;
  }
}

// The convex parts of a mesh: its triangles, or its points when it has none (a point cloud).
template <typename BV, typename F>
void meshParts(const fcl::CollisionGeometry<typename BV::S>& g,
               const fcl::Transform3<typename BV::S>& tf, const V3<typename BV::S>& u, F& part) {
  using S = typename BV::S;
  const auto& m = static_cast<const fcl::BVHModel<BV>&>(g);
  if (m.vertices == nullptr) return;
  const auto world = [&](int i, Extent<S>& e) {
    const V3<S> w = tf * m.vertices[i];
    e.add(w, u.dot(w));
  };
  if (m.tri_indices != nullptr && m.num_tris > 0) {
    for (int t = 0; t < m.num_tris; ++t) {
      Extent<S> e;
      for (int k = 0; k < 3; ++k) world(int(m.tri_indices[t][k]), e);
      part(e);
    }
    return;
  }
  for (int i = 0; i < m.num_vertices; ++i) {
    Extent<S> e;
    world(i, e);
    part(e);
  }
}

// The occupied cells of an octree, each a box: its corner farthest along u and the opposite one.
template <typename S, typename F>
void octreeParts(const fcl::OcTree<S>& tree, const fcl::Transform3<S>& tf, const V3<S>& u,
                 F& part) {
  const V3<S> v = tf.linear().transpose() * u;
  const V3<S> corner(signOf(v[0]), signOf(v[1]), signOf(v[2]));
  for (const auto& b : tree.toBoxes()) {
    const V3<S> c(b[0], b[1], b[2]);
    const S half = b[3] / 2;
    Extent<S> e;
    for (const S side : {S(1), S(-1)}) {
      const V3<S> w = tf * V3<S>(c + side * half * corner);
      e.add(w, u.dot(w));
    }
    part(e);
  }
}

/// Calls part(extent) with the extent along the world unit direction u of each convex part of
/// geometry g posed by tf, whose union is the geometry: the shape itself for a primitive or a
/// convex polytope, each triangle of a mesh (each point of one without triangles), each
/// occupied cell of an octree. False for a geometry it does not know (a plane, a halfspace, an
/// unknown kind).
template <typename S, typename F>
bool forEachPart(const fcl::CollisionGeometry<S>& g, const fcl::Transform3<S>& tf, const V3<S>& u,
                 F&& part) {
  const V3<S> v = tf.linear().transpose() * u;
  Extent<S> e;
  V3<S> p;
  if (localSupport(g, v, p)) {
    const V3<S> hi = tf * p;
    e.add(hi, u.dot(hi));
    localSupport(g, V3<S>(-v), p);
    const V3<S> lo = tf * p;
    e.add(lo, u.dot(lo));
    part(e);
    return true;
  }
  switch (g.getNodeType()) {
    case fcl::GEOM_CONVEX: {
      for (const V3<S>& x : static_cast<const fcl::Convex<S>&>(g).getVertices()) {
        const V3<S> w = tf * x;
        e.add(w, u.dot(w));
      }
      if (!e.empty()) part(e);
      return true;
    }
    case fcl::GEOM_TRIANGLE: {
      const auto& t = static_cast<const fcl::TriangleP<S>&>(g);
      for (const V3<S>* x : {&t.a, &t.b, &t.c}) {
        const V3<S> w = tf * *x;
        e.add(w, u.dot(w));
      }
      part(e);
      return true;
    }
    case fcl::GEOM_OCTREE:
      octreeParts(static_cast<const fcl::OcTree<S>&>(g), tf, u, part);
      return true;
    case fcl::BV_AABB:
      return meshParts<fcl::AABB<S>>(g, tf, u, part), true;
    case fcl::BV_OBB:
      return meshParts<fcl::OBB<S>>(g, tf, u, part), true;
    case fcl::BV_RSS:
      return meshParts<fcl::RSS<S>>(g, tf, u, part), true;
    case fcl::BV_kIOS:
      return meshParts<fcl::kIOS<S>>(g, tf, u, part), true;
    case fcl::BV_OBBRSS:
      return meshParts<fcl::OBBRSS<S>>(g, tf, u, part), true;
    case fcl::BV_KDOP16:
      return meshParts<fcl::KDOP<S, 16>>(g, tf, u, part), true;
    case fcl::BV_KDOP18:
      return meshParts<fcl::KDOP<S, 18>>(g, tf, u, part), true;
    case fcl::BV_KDOP24:
      return meshParts<fcl::KDOP<S, 24>>(g, tf, u, part), true;
    default:
      return false;
  }
}

inline bool isPlanar(fcl::NODE_TYPE t) {
  return t == fcl::GEOM_PLANE || t == fcl::GEOM_HALFSPACE;
}

/// The distance between a and b, one of them a plane or a halfspace, in closed form: for a
/// halfspace, the height of the other's lowest point above its boundary; for a plane, the least
/// gap between it and a convex part of the other (forEachPart), which meets it where a part
/// reaches across it. Put into `result` as fcl::distance puts its answer (result.update with the
/// nearest points, world frame); -1, as FCL's GJK answers for objects that meet, when they meet
/// (the nearest points then a point of the other object nearest the plane and its projection
/// onto the plane).
/// False, with `result` untouched, for a geometry forEachPart does not know, or an object with
/// nothing in it (an empty mesh or octree).
template <typename S>
bool planeDistance(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                   fcl::DistanceResult<S>& result, S& distance) {
  const bool a_planar = isPlanar(a.getNodeType());
  const fcl::CollisionObject<S>& pl = a_planar ? a : b;
  const fcl::CollisionObject<S>& other = a_planar ? b : a;
  const WorldPlane<S> w = worldPlane(pl.collisionGeometry().get(), pl.getTransform());
  const bool solid = pl.getNodeType() == fcl::GEOM_HALFSPACE;
  V3<S> on_other, on_plane;
  if (isPlanar(other.getNodeType())) {
    // Two planes or halfspaces are apart only when parallel: then along the first's normal the
    // other is a single value (a plane) or a half line (a halfspace).
    const WorldPlane<S> o = worldPlane(other.collisionGeometry().get(), other.getTransform());
    const bool o_solid = other.getNodeType() == fcl::GEOM_HALFSPACE;
    const S tol = S(8) * std::numeric_limits<S>::epsilon();
    distance = S(-1);
    const bool parallel = w.n.cross(o.n).norm() <= tol;
    // The other along w.n: [o_lo, o_hi].
    S o_lo = -std::numeric_limits<S>::infinity(), o_hi = -o_lo;
    if (parallel) {
      const S s = w.n.dot(o.n) > 0 ? S(1) : S(-1);  // o.n = s w.n
      const S at = s * o.d;                         // the other's boundary: w.n . x = at
      if (!o_solid)
        o_lo = o_hi = at;
      else if (s > 0)
        o_hi = at;  // w.n . x <= at
      else
        o_lo = at;  // w.n . x >= at
      if (o_lo > w.d) {
        distance = o_lo - w.d;
      } else if (!solid && o_hi < w.d) {
        distance = w.d - o_hi;
      }
    }
    const V3<S> line = w.n.cross(o.n);
    // Apart: w's point nearest the origin and its image on the other. Meeting: a point of both
    // boundaries where they cross, else w's point nearest the origin.
    on_plane = parallel ? V3<S>(w.n * w.d)
                        : V3<S>((w.d * o.n - o.d * w.n).cross(line) / line.squaredNorm());
    on_other =
        distance > 0 ? V3<S>(on_plane + w.n * (o_lo > w.d ? distance : -distance)) : on_plane;
  } else {
    // A halfspace: the lowest point of all. A plane: each part's gap to either side, or a part
    // across it (the union of convex parts meets the plane where one of them does).
    Extent<S> all;
    S above = std::numeric_limits<S>::infinity(), below = above;
    V3<S> at_above = V3<S>::Zero(), at_below = at_above, at_across = at_above;
    bool across = false;
    const auto part = [&](const Extent<S>& e) {
      all.add(e.at_lo, e.lo);
      all.add(e.at_hi, e.hi);
      if (e.lo > w.d) {
        if (e.lo - w.d < above) above = e.lo - w.d, at_above = e.at_lo;
      } else if (e.hi < w.d) {
        if (w.d - e.hi < below) below = w.d - e.hi, at_below = e.at_hi;
      } else if (!across) {
        across = true;
        // The part's extreme nearer the plane.
        at_across = w.d - e.lo <= e.hi - w.d ? e.at_lo : e.at_hi;
      }
    };
    if (!forEachPart(*other.collisionGeometry(), other.getTransform(), w.n, part) || all.empty())
      return false;
    if (solid) {
      distance = all.lo > w.d ? all.lo - w.d : S(-1);
      on_other = all.at_lo;
    } else if (across) {
      distance = S(-1);
      on_other = at_across;
    } else {
      distance = std::min(above, below);
      on_other = above <= below ? at_above : at_below;
    }
    on_plane = on_other - w.n * (w.n.dot(on_other) - w.d);
  }
  const V3<S>& pa = a_planar ? on_plane : on_other;
  const V3<S>& pb = a_planar ? on_other : on_plane;
  result.update(distance, a.collisionGeometry().get(), b.collisionGeometry().get(),
                fcl::DistanceResult<S>::NONE, fcl::DistanceResult<S>::NONE, pa, pb);
  return true;
}

// The box FCL's shape collision gives a cost source's overlap: computeBV of the shape posed.
template <typename S>
fcl::AABB<S> shapeBox(const fcl::CollisionGeometry<S>& g, const fcl::Transform3<S>& tf) {
  fcl::AABB<S> box;
  switch (g.getNodeType()) {
    case fcl::GEOM_CYLINDER:
      fcl::computeBV(static_cast<const fcl::Cylinder<S>&>(g), tf, box);
      break;
    case fcl::GEOM_CONE:
      fcl::computeBV(static_cast<const fcl::Cone<S>&>(g), tf, box);
      break;
    case fcl::GEOM_PLANE:
      fcl::computeBV(static_cast<const fcl::Plane<S>&>(g), tf, box);
      break;
    case fcl::GEOM_HALFSPACE:
      fcl::computeBV(static_cast<const fcl::Halfspace<S>&>(g), tf, box);
      break;
    default:
      break;
  }
  return box;
}

/// fcl::collide for a pair contactDefective lists, answered from the geometry: they meet where
/// the shape reaches the plane (both sides of it, or on it) or the halfspace (its lowest point
/// at or below the boundary). Contacts, costs and the result's limits as FCL's shape collision
/// gives them; the contact as FCL's (correct) contact-computing tests place it: for the plane,
/// the shape's extreme point nearer the plane, depth its distance to the plane, position its
/// projection onto the plane; for the halfspace, the lowest point, depth its depth, position
/// moved half the depth back up; the normal along the plane's, from a to b.
template <typename S>
std::size_t defectiveCollide(const fcl::CollisionGeometry<S>* ga, const fcl::Transform3<S>& tfa,
                             const fcl::CollisionGeometry<S>* gb, const fcl::Transform3<S>& tfb,
                             const fcl::CollisionRequest<S>& request,
                             fcl::CollisionResult<S>& result) {
  if (request.isSatisfied(result)) return result.numContacts();
  if (request.enable_cached_gjk_guess) result.cached_gjk_guess = request.cached_gjk_guess;
  const bool a_planar = isPlanar(ga->getNodeType());
  const WorldPlane<S> w = a_planar ? worldPlane(ga, tfa) : worldPlane(gb, tfb);
  // A cylinder or a cone: one convex part.
  Extent<S> e;
  const auto part = [&e](const Extent<S>& x) { e = x; };
  if (a_planar)
    forEachPart(*gb, tfb, w.n, part);
  else
    forEachPart(*ga, tfa, w.n, part);
  const S d_lo = e.lo - w.d, d_hi = e.hi - w.d;
  const bool solid = (a_planar ? ga : gb)->getNodeType() == fcl::GEOM_HALFSPACE;
  const bool hit = solid ? d_lo <= 0 : (d_lo <= 0 && d_hi >= 0);
  if (!hit) return result.numContacts();
  const bool occupied = ga->isOccupied() && gb->isOccupied();
  if (occupied && request.num_max_contacts > result.numContacts()) {
    if (request.enable_contact) {
      // From the shape to the plane, then turned to run from a to b.
      V3<S> normal, pos;
      S depth;
      if (solid) {
        depth = -d_lo;
        normal = -w.n;
        pos = e.at_lo + w.n * (depth / 2);
      } else if (std::abs(d_lo) <= std::abs(d_hi)) {
        depth = std::abs(d_lo);
        normal = d_lo < 0 ? V3<S>(-w.n) : w.n;
        pos = e.at_lo - w.n * d_lo;
      } else {
        depth = std::abs(d_hi);
        normal = d_hi < 0 ? V3<S>(-w.n) : w.n;
        pos = e.at_hi - w.n * d_hi;
      }
      result.addContact(fcl::Contact<S>(ga, gb, fcl::Contact<S>::NONE, fcl::Contact<S>::NONE, pos,
                                        a_planar ? V3<S>(-normal) : normal, depth));
    } else {
      result.addContact(fcl::Contact<S>(ga, gb, fcl::Contact<S>::NONE, fcl::Contact<S>::NONE));
    }
  }
  if (request.enable_cost && (occupied || (!ga->isFree() && !gb->isFree()))) {
    fcl::AABB<S> overlap;
    shapeBox(*ga, tfa).overlap(shapeBox(*gb, tfb), overlap);
    result.addCostSource(fcl::CostSource<S>(overlap, ga->cost_density * gb->cost_density),
                         request.num_max_cost_sources);
  }
  return result.numContacts();
}

}  // namespace planes
}  // namespace detail
}  // namespace cube
