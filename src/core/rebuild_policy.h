#pragma once

// When the cubes are rebuilt rather than refitted. Asked by the core between operations, never
// by the tree itself: no mutation triggers another from inside.

#include <algorithm>
#include <cstddef>

#include "core/cube_tree.h"
#include "cube_collision/config.h"

namespace cube {
namespace detail {

class RebuildPolicy {
 public:
  explicit RebuildPolicy(const Config& config) : config_(config) {}

  /// After an insertion or a removal: with UpdatePolicy::automatic, once many objects came or
  /// went since the last build, or the cubes degraded past Config::rebuild_threshold.
  template <typename S>
  bool dueAfterChange(const CubeTree<S>& tree) const {
    if (config_.update_policy != UpdatePolicy::automatic) return false;
    if (tree.changesSinceBuild() > std::max<std::size_t>(64, tree.size() / 2)) return true;
    return tree.built() && tree.quality() > config_.rebuild_threshold;
  }
  /// After objects moved (update()): always with UpdatePolicy::rebuild; with automatic, once
  /// many objects came or went since the last build, or once the tree is past
  /// Config::rebuild_threshold and the stretch of the updates since the last build, summed,
  /// passes Config::rebuild_budget. Each call counts as one update.
  template <typename S>
  bool dueAfterUpdate(const CubeTree<S>& tree) {
    if (config_.update_policy == UpdatePolicy::rebuild) return true;
    if (config_.update_policy != UpdatePolicy::automatic) return false;
    if (tree.changesSinceBuild() > std::max<std::size_t>(64, tree.size() / 2)) return true;
    if (!tree.built()) return false;
    if (tree.buildCount() != counted_build_) {
      counted_build_ = tree.buildCount();
      stretch_ = 0;
    }
    // Rent or buy: each update's stretch stands for what the walks after it pay on the stale
    // tree; rebuild once their sum passes what the caller says a rebuild is worth.
    const double q = tree.quality();
    stretch_ += std::max(0.0, q - 1.0);
    return q > config_.rebuild_threshold && stretch_ > config_.rebuild_budget;
  }
  /// At setup(): the first one (`first`) gives the canonical tree if anything changed since the
  /// last build; later ones keep the incremental work, as FCL's tree manager does, and rebuild
  /// only a degraded tree, or under a forced policy any changed one.
  template <typename S>
  bool dueAtSetup(const CubeTree<S>& tree, bool first) const {
    const bool changed = tree.changesSinceBuild() > 0;
    const bool forced = config_.update_policy != UpdatePolicy::automatic;
    return !tree.built() || (changed && (first || forced)) || dueAfterChange(tree);
  }

 private:
  const Config& config_;
  std::size_t counted_build_ = 0;  // the build stretch_ counts from
  double stretch_ = 0;             // quality - 1, summed over the updates since that build
};

}  // namespace detail
}  // namespace cube
