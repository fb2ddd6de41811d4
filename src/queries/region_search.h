#pragma once

// What every region query (region.cpp, capsule.cpp) does around its region: the core's search
// under the query's filter bits, then the objects found in registration order.

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/spatial_queries.h"

namespace cube {
namespace detail {

/// The objects a region finds: each with its registration number, in the order found.
template <typename S>
using RegionFound = std::vector<std::pair<std::uint32_t, fcl::CollisionObject<S>*>>;

/// Runs `region` (which appends to `found`) over the manager's objects that `filter` lets
/// through (none: every object) and returns them in registration order.
template <typename S, class Region>
std::vector<fcl::CollisionObject<S>*> searchInOrder(const CubeCollisionManager<S>& manager,
                                                    Region& region, RegionFound<S>& found,
                                                    const std::optional<QueryFilter>& filter) {
  if (filter) {
    const Filter bits{filter->category, filter->mask};
    coreOf(manager).search(region, &bits);
  } else {
    coreOf(manager).search(region);
  }
  std::sort(found.begin(), found.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<fcl::CollisionObject<S>*> out;
  out.reserve(found.size());
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

}  // namespace detail
}  // namespace cube
