// Config::check (include/cube_collision/config.h): the knobs' ranges.

#include "cube_collision/config.h"

#include <stdexcept>

namespace cube {

void Config::check() const {
  if (max_depth < 0) throw std::invalid_argument("cube::Config: max_depth must be >= 0");
  if (leaf_size < 1) throw std::invalid_argument("cube::Config: leaf_size must be >= 1");
  if (!(rebuild_threshold > 1.0))
    throw std::invalid_argument("cube::Config: rebuild_threshold must be > 1");
  if (!(rebuild_budget >= 0.0))
    throw std::invalid_argument("cube::Config: rebuild_budget must be >= 0");
  if (!(unbounded_limit > 0.0))
    throw std::invalid_argument("cube::Config: unbounded_limit must be > 0");
  if (all_pairs_limit > kMaxAllPairsLimit)
    throw std::invalid_argument("cube::Config: all_pairs_limit must be <= 64");
  if (filter_groups < 0 || filter_groups > 64)
    throw std::invalid_argument("cube::Config: filter_groups must be in [0, 64]");
}

}  // namespace cube
