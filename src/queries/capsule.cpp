// The capsule query (include/cube_collision/spatial_queries.h): objectsInCapsule as a region of
// the core's search (its unbounded list, then its cubes). A cube is tested as an object's box
// is, on its float bounds in the same double arithmetic: the box widened by the capsule's reach,
// met by the segment (crossBox). Widening and crossBox are monotone in the bounds and a cube
// contains its objects' boxes, so a cube that fails holds no object that passes. The objects that
// pass are put to FCL's narrow phase with the query's capsule, which decides.

#include <fcl/geometry/shape/capsule.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/spatial_queries.h"
#include "pipeline/fcl_narrow.h"
#include "queries/ray_tests.h"
#include "queries/region_search.h"

namespace cube {

namespace {

using detail::crossBox;
using detail::Item;
using detail::Segment;

template <typename S>
using Found = detail::RegionFound<S>;

// The capsule as a region: the segment and its reach prune boxes, FCL decides.
template <typename S>
struct CapsuleRegion {
  using State = char;
  static constexpr bool kOrdered = false;
  const Segment& seg;
  double reach;  // radius plus the rounding allowance
  const fcl::CollisionObject<S>& capsule;
  Found<S>& out;

  static bool before(State, State) { return false; }
  bool worth(State) const { return true; }
  template <class T>
  bool near(const T* lo, const T* hi) const {
    double l[3], h[3];
    for (int k = 0; k < 3; ++k) {
      l[k] = double(lo[k]) - reach;
      h[k] = double(hi[k]) + reach;
    }
    double enter, exit;
    return crossBox(seg, l, h, enter, exit);
  }
  bool enters(const float* lo, const float* hi, State&) const { return near(lo, hi); }
  bool touches(const fcl::CollisionObject<S>& obj) const {
    if (obj.collisionGeometry() == nullptr) return false;
    fcl::CollisionRequest<S> request;
    fcl::CollisionResult<S> result;
    return detail::fclCollide<S>(&capsule, &obj, request, result) > 0;
  }
  void leaf(const Item<S>* items, std::uint32_t n, const std::uint32_t* seq) {
    for (std::uint32_t i = 0; i < n; ++i) {
      const Item<S>& it = items[i];
      if (it.obj != nullptr && near(it.box.lo, it.box.hi) && touches(*it.obj))
        out.emplace_back(seq[it.id], it.obj);
    }
  }
};

template <typename S>
void checkCapsule(const fcl::Vector3<S>& a, const fcl::Vector3<S>& b, S radius) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(double(a[k])))
      throw std::invalid_argument("cube::objectsInCapsule: `a` is not finite");
    if (!std::isfinite(double(b[k])))
      throw std::invalid_argument("cube::objectsInCapsule: `b` is not finite");
    if (!std::isfinite(b[k] - a[k]))
      throw std::invalid_argument("cube::objectsInCapsule: b - a overflows");
  }
  if (!(radius >= S(0)) || !std::isfinite(radius))
    throw std::invalid_argument("cube::objectsInCapsule: radius is negative, NaN or infinite");
  // FCL squares lengths: the extent's square must be finite.
  const S extent = (b - a).norm() + S(2) * radius;
  if (!std::isfinite(extent * extent))
    throw std::invalid_argument("cube::objectsInCapsule: the capsule's extent overflows");
}

}  // namespace

template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsInCapsule(const CubeCollisionManager<S>& manager,
                                                       const fcl::Vector3<S>& a,
                                                       const fcl::Vector3<S>& b, S radius,
                                                       std::optional<QueryFilter> filter) {
  checkCapsule(a, b, radius);
  // The capsule as the contract places it.
  const fcl::Vector3<S> d = b - a;
  const S length = d.norm();
  fcl::Matrix3<S> rot = fcl::Matrix3<S>::Identity();
  if (length != S(0)) rot = detail::rotationFromZ<S>(d);
  const fcl::CollisionObject<S> capsule(std::make_shared<fcl::Capsule<S>>(radius, length), rot,
                                        fcl::Vector3<S>(a + d / S(2)));

  // Widening the boxes by radius plus this allowance keeps every object FCL's rounding may
  // count as touching.
  double largest = 0;
  for (int k = 0; k < 3; ++k)
    largest = std::max({largest, std::abs(double(a[k])), std::abs(double(b[k]))});
  const double reach = double(radius) + 1e-5 * (double(radius) + largest + 1);
  const Segment seg = detail::makeSegment(a, b);
  Found<S> found;
  CapsuleRegion<S> r{seg, reach, capsule, found};
  return detail::searchInOrder(manager, r, found, filter);
}

#define CUBE_CAPSULE_INSTANTIATE(S)                                                      \
  template std::vector<fcl::CollisionObject<S>*> objectsInCapsule<S>(                    \
      const CubeCollisionManager<S>&, const fcl::Vector3<S>&, const fcl::Vector3<S>&, S, \
      std::optional<QueryFilter>);

CUBE_CAPSULE_INSTANTIATE(double)
CUBE_CAPSULE_INSTANTIATE(float)

}  // namespace cube
