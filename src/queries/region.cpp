// Region queries (include/cube_collision/spatial_queries.h): objectsInBox and objectsNear as one
// region of the core's search (its cubes and its unbounded list). A cube is
// tested as its objects are, on its float bounds in the same double arithmetic: a cube contains
// its objects' boxes and each test is monotone in the bounds, so a cube that fails cannot hold an
// object that passes, and the walk returns exactly what a loop over every object would.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/spatial_queries.h"
#include "queries/region_search.h"

namespace cube {

namespace {

using detail::Item;

constexpr double kInf = std::numeric_limits<double>::infinity();

void checkFinite(const double* v, const char* what) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(v[k])) throw std::invalid_argument(std::string(what) + " is not finite");
}

// Region queries: cubes and boxes through one predicate on (lo, hi), a region of the core's
// search (Broadphase::search).
template <typename S, class Pred>
struct Region {
  using State = char;
  static constexpr bool kOrdered = false;
  const Pred& pred;
  std::vector<std::pair<std::uint32_t, fcl::CollisionObject<S>*>>& out;
  static bool before(State, State) { return false; }
  bool worth(State) const { return true; }
  bool enters(const float* lo, const float* hi, State&) const { return pred(lo, hi); }
  void leaf(const Item<S>* items, std::uint32_t n, const std::uint32_t* seq) {
    for (std::uint32_t i = 0; i < n; ++i)
      if (items[i].obj != nullptr && pred(items[i].box.lo, items[i].box.hi))
        out.emplace_back(seq[items[i].id], items[i].obj);
  }
};

template <typename S, class Pred>
std::vector<fcl::CollisionObject<S>*> region(const CubeCollisionManager<S>& manager,
                                             const Pred& pred,
                                             const std::optional<QueryFilter>& filter) {
  detail::RegionFound<S> found;
  Region<S, Pred> r{pred, found};
  return detail::searchInOrder(manager, r, found, filter);
}

// The closed box overlap, in double.
struct InBox {
  double lo[3], hi[3];
  template <class T>
  bool operator()(const T* l, const T* h) const {
    return (double(l[0]) <= hi[0]) & (lo[0] <= double(h[0])) & (double(l[1]) <= hi[1]) &
           (lo[1] <= double(h[1])) & (double(l[2]) <= hi[2]) & (lo[2] <= double(h[2]));
  }
};

// The distance from a point to a box within r (see objectsNear's contract).
struct Near {
  double p[3];
  double r;
  template <class T>
  bool operator()(const T* l, const T* h) const {
    if (r == kInf) return true;
    double g[3];
    for (int k = 0; k < 3; ++k) {
      const double below = double(l[k]) - p[k], above = p[k] - double(h[k]);
      double gap = below > above ? below : above;
      gap = gap > 0 ? gap : 0;
      if (gap > r) return false;
      g[k] = gap;
    }
    if (r <= 1e150) return g[0] * g[0] + g[1] * g[1] + g[2] * g[2] <= r * r;
    for (double& x : g) x /= r;
    return g[0] * g[0] + g[1] * g[1] + g[2] * g[2] <= 1.0;
  }
};

}  // namespace

template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsInBox(const CubeCollisionManager<S>& manager,
                                                   const fcl::AABB<S>& box,
                                                   std::optional<QueryFilter> filter) {
  InBox pred;
  for (int k = 0; k < 3; ++k) {
    pred.lo[k] = double(box.min_[k]);
    pred.hi[k] = double(box.max_[k]);
    if (std::isnan(pred.lo[k]) || std::isnan(pred.hi[k]))
      throw std::invalid_argument("cube::objectsInBox: the box has a NaN bound");
    if (pred.lo[k] > pred.hi[k])
      throw std::invalid_argument("cube::objectsInBox: the box's min exceeds its max");
  }
  return region(manager, pred, filter);
}

template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsNear(const CubeCollisionManager<S>& manager,
                                                  const fcl::Vector3<S>& point, S radius,
                                                  std::optional<QueryFilter> filter) {
  Near pred;
  for (int k = 0; k < 3; ++k) pred.p[k] = double(point[k]);
  checkFinite(pred.p, "cube::objectsNear: the point");
  pred.r = double(radius);
  if (!(pred.r >= 0)) throw std::invalid_argument("cube::objectsNear: radius is negative or NaN");
  return region(manager, pred, filter);
}

#define CUBE_REGION_INSTANTIATE(S)                                                      \
  template std::vector<fcl::CollisionObject<S>*> objectsInBox<S>(                       \
      const CubeCollisionManager<S>&, const fcl::AABB<S>&, std::optional<QueryFilter>); \
  template std::vector<fcl::CollisionObject<S>*> objectsNear<S>(                        \
      const CubeCollisionManager<S>&, const fcl::Vector3<S>&, S, std::optional<QueryFilter>);

CUBE_REGION_INSTANTIATE(double)
CUBE_REGION_INSTANTIATE(float)

}  // namespace cube
