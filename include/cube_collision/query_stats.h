#pragma once

#include <cstddef>

namespace cube {

/// What one query did, filled by the query overloads that take a QueryStats*. Each query adds to
/// the counters, so one struct can total several queries; each thread uses its own. A
/// self-collide served from the pair list (Config::keep_pairs) visits no cube and tests no box:
/// it counts callbacks only.
struct QueryStats {
  /// Pairs of cubes (or cube and query object) taken from the traversal stack and examined.
  std::size_t cubes_visited = 0;
  /// Box-against-box tests: cube bounds against cube bounds, and object AABB against object AABB.
  std::size_t box_tests = 0;
  /// Calls of the user's callback.
  std::size_t callbacks = 0;
};

}  // namespace cube
