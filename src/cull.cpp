// Tight volumes and the separating-axis tests behind surelyApart.

#include "cull.h"

#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cmath>

namespace cube {
namespace detail {

namespace {

// An object's tight volumes in world coordinates: an oriented box (centre c, axes the columns
// of R, half extents e) and a sphere about the same centre (radius r).
template <typename S>
struct Tight {
  fcl::Vector3<S> c;
  fcl::Matrix3<S> R;
  fcl::Vector3<S> e;
  S r;
  bool sphere;  // the geometry is a sphere: r is exact and the box adds nothing
};

// False if the object has no finite tight volume.
template <typename S>
bool tightOf(const fcl::CollisionObject<S>& o, Tight<S>& t) {
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr) return false;
  switch (g->getNodeType()) {
    case fcl::GEOM_PLANE:
    case fcl::GEOM_HALFSPACE:
    case fcl::GEOM_OCTREE:  // its cells, not its box, decide; and it may carry costs
      return false;
    default:
      break;
  }
  const fcl::AABB<S>& local = g->aabb_local;
  t.e = (local.max_ - local.min_) * S(0.5);
  t.R = o.getRotation();
  t.c = t.R * ((local.max_ + local.min_) * S(0.5)) + o.getTranslation();
  t.sphere = g->getNodeType() == fcl::GEOM_SPHERE;
  t.r = t.sphere ? static_cast<const fcl::Sphere<S>*>(g)->radius : t.e.norm();
  return t.e.allFinite() && t.c.allFinite() && t.R.allFinite() && std::isfinite(t.r) &&
         (t.e.array() >= S(0)).all();
}

// Distance from point p to the box b, minus nothing: 0 inside.
template <typename S>
S pointBoxDistance(const fcl::Vector3<S>& p, const Tight<S>& b) {
  const fcl::Vector3<S> q = b.R.transpose() * (p - b.c);
  const fcl::Vector3<S> out = (q.cwiseAbs() - b.e).cwiseMax(S(0));
  return out.norm();
}

// Separating-axis test of two oriented boxes grown by m/2 each: true if one of the 15 axes
// (three face normals of each, nine edge cross products) separates them. |R| gets a small term
// so that near-parallel edges, whose cross product is almost zero, cannot fake a separation.
template <typename S>
bool boxesApart(const Tight<S>& a, const Tight<S>& b, S m) {
  const S h = m * S(0.5);
  const fcl::Vector3<S> ea = a.e.array() + h, eb = b.e.array() + h;
  const fcl::Matrix3<S> R = a.R.transpose() * b.R;  // b's axes in a's frame
  const fcl::Vector3<S> t = a.R.transpose() * (b.c - a.c);
  const fcl::Matrix3<S> A = R.cwiseAbs().array() + S(16) * std::numeric_limits<S>::epsilon();
  for (int i = 0; i < 3; ++i)
    if (std::abs(t[i]) > ea[i] + eb.dot(A.row(i))) return true;
  for (int j = 0; j < 3; ++j)
    if (std::abs(t.dot(R.col(j))) > ea.dot(A.col(j)) + eb[j]) return true;
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      // Axis: a's axis i cross b's axis j.
      const S dist = std::abs(t[i2] * R(i1, j) - t[i1] * R(i2, j));
      const S ra = ea[i1] * A(i2, j) + ea[i2] * A(i1, j);
      const S rb = eb[j1] * A(i, j2) + eb[j2] * A(i, j1);
      if (dist > ra + rb) return true;
    }
  }
  return false;
}

}  // namespace

template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance) {
  Tight<S> ta, tb;
  if (!tightOf(a, ta) || !tightOf(b, tb)) return false;
  const S floor = sizeof(S) >= 8 ? S(1e-6) : S(1e-4);
  const S scale = std::max({ta.c.cwiseAbs().maxCoeff(), tb.c.cwiseAbs().maxCoeff(), ta.r, tb.r});
  const S m = std::max(S(2) * tolerance, floor) * (S(1) + scale);
  // The spheres first: the cheapest test, and exact for spheres.
  const S gap = (ta.c - tb.c).norm() - ta.r - tb.r;
  if (gap > m) return true;
  if (ta.sphere && tb.sphere) return false;
  if (ta.sphere) return pointBoxDistance(ta.c, tb) > ta.r + m;
  if (tb.sphere) return pointBoxDistance(tb.c, ta) > tb.r + m;
  return boxesApart(ta, tb, m);
}

template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                  const fcl::CollisionObject<double>&, double);
template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                 const fcl::CollisionObject<float>&, float);

}  // namespace detail
}  // namespace cube
