#pragma once

// When the cubes are rebuilt rather than refitted. Asked by the core between operations, never
// by the tree itself: no mutation triggers another from inside.

#include <algorithm>
#include <cmath>
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
  /// Config::rebuild_threshold and what the walks are predicted to have lost on the stale tree
  /// since the last build (staleCost, summed over the updates) passes Config::rebuild_budget.
  /// Each call counts as one update.
  template <typename S>
  bool dueAfterUpdate(const CubeTree<S>& tree) {
    if (config_.update_policy == UpdatePolicy::rebuild) return true;
    if (config_.update_policy != UpdatePolicy::automatic) return false;
    if (tree.changesSinceBuild() > std::max<std::size_t>(64, tree.size() / 2)) return true;
    if (!tree.built()) return false;
    if (tree.buildCount() != counted_build_) {
      counted_build_ = tree.buildCount();
      lost_ = 0;
    }
    // Rent or buy: each update stands for one walk on the stale tree; rebuild once what those
    // walks lost adds up to what the caller says a rebuild is worth.
    const double q = tree.quality();
    lost_ += staleCost(q, tree.builtRoom());
    return q > config_.rebuild_threshold && lost_ > config_.rebuild_budget;
  }
  /// What one self-collide walk of a tree at quality `q` is predicted to cost more than on a
  /// fresh build, in builds: the quality lost (q - 1, which tracks the walk's slowdown) times a
  /// walk's cost in builds, which falls as the leaves' room around their objects
  /// (CubeTree::builtRoom) grows: a walk of a crowded scene costs up to two builds, of a sparse
  /// one a sixth. Fitted on cube_rebuild_probe's scenes (uniform, clustered and thin, 10,000 and
  /// 100,000 objects, each object moved once by up to its size or turned about the centre),
  /// builds timed on memory the process already holds (docs/tuning.md).
  static double staleCost(double q, double room) {
    if (!(q > 1.0)) return 0.0;
    if (!(room > 0.05)) room = room > 0 ? 0.05 : 1.0;  // NaN and none: a plain scene
    return (q - 1.0) * 0.8 * std::pow(std::min(room, 1e6), -1.2);
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
  std::size_t counted_build_ = 0;  // the build lost_ counts from
  double lost_ = 0;                // staleCost, summed over the updates since that build
};

}  // namespace detail
}  // namespace cube
