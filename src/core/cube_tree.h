#pragma once

// The cube tree: the seed's hierarchy of cuboids over object slots. Build (longest side, median
// object), refit, incremental insertion and removal, compaction, and the invariant check. It
// decides nothing: when to rebuild is RebuildPolicy's call, made by the core between operations.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.h"

namespace cube {
namespace detail {

/// The object table's per-id arrays that the tree reads (registration numbers: the build's
/// tie-breaker, and the order within a leaf) and writes (each id's slot, whenever a slot moves).
struct IdArrays {
  const std::uint32_t* seq;
  std::uint32_t* loc;
  /// Per id: its filter group, when the core wants groups kept apart (ObjectTable::separable);
  /// null otherwise. See CubeTree::rebuild.
  const Group* group = nullptr;
};

template <typename S>
class CubeTree {
 public:
  /// Uses Config::max_depth and Config::leaf_size (checked by the caller).
  explicit CubeTree(const Config& config) : config_(config) {}

  /// Objects in the cubes.
  std::size_t size() const { return live_; }
  bool empty() const { return live_ == 0; }
  /// What the traversals walk.
  View<S> view() const {
    return View<S>{nodes_.data(), items_.data(), root_, std::uint32_t(items_.size()),
                   group_.empty() ? nullptr : group_.data()};
  }

  /// Builds the cubes from scratch over the live slots. The same objects always give the same
  /// tree. With ids.group, a cube holding several filter groups splits between groups first (at
  /// the boundary nearest its median), and each cube records the group of its objects
  /// (View::groups), which the walks use to drop pairs of cubes that cannot pair; without, no
  /// cube records one. Its peak: the slots and 64 bytes an object of build records.
  void rebuild(IdArrays ids);
  /// The same over the live slots plus `extra` (items not yet in the tree, whose ids have no slot
  /// yet), taken: an empty tree keeps `extra`'s array as its slots, so that the objects are
  /// not held twice during a first build.
  void rebuild(IdArrays ids, ItemArray<S>&& extra);
  /// Puts one item (finite box, id without a slot) into the leaf it enlarges least (with groups:
  /// a cube of its own group first), splitting the leaf if it overflows. The cubes' groups stay
  /// true: those that gain another group become mixed. Without ids.group they are forgotten.
  void insert(Item<S> item, IdArrays ids);
  /// Forgets the cubes' groups (an object's group changed); the next rebuild makes them again.
  void forgetGroups() { group_ = {}; }
  /// Whether the cubes record groups.
  bool grouped() const { return !group_.empty(); }
  /// Takes the object at `slot` out of its leaf; an emptied leaf merges its sibling upwards.
  void remove(std::uint32_t slot, IdArrays ids);
  /// Whether dead cubes or slots outnumber the live ones (and are more than 64).
  bool sparse() const {
    const std::size_t live_nodes = nodes_.size() - dead_nodes_;
    return (dead_items_ > 64 && dead_items_ > live_) ||
           (dead_nodes_ > 64 && dead_nodes_ > live_nodes);
  }
  /// Re-lays the tree without its dead cubes and slots if sparse().
  void compactIfSparse(IdArrays ids);
  /// Forgets everything.
  void clear();

  /// The slots, for the core's update loop: it may change boxes in place, then must refit.
  Item<S>* slots() { return items_.data(); }
  std::uint32_t slotCount() const { return std::uint32_t(items_.size()); }
  /// Refits the cubes from `leaf` up to the root, stopping where nothing changes.
  void refitPath(std::uint32_t leaf);
  /// Refits every cube bottom-up, and recomputes the total area exactly.
  void refitAll();

  // Inspection.
  const NodeArray& nodes() const { return nodes_; }
  const ItemArray<S>& items() const { return items_; }
  std::uint32_t root() const { return root_; }
  std::uint32_t parent(std::uint32_t cube) const { return parent_[cube]; }
  /// Total surface area of the live cubes, kept up to date by refits.
  double area() const { return area_; }
  /// Area right after the last build.
  double builtArea() const { return built_area_; }
  /// Objects in the cubes right after the last build.
  std::size_t builtSize() const { return built_live_; }
  /// Right after the last build: the leaves' surface area over their objects' (exact boxes),
  /// the room the leaves leave around their objects; small where objects crowd. 1 if the
  /// objects have no area.
  double builtRoom() const { return built_room_; }
  /// Tree quality: cube area per object now over the same right after the last build (1 after
  /// a build; grows as objects wander or land badly).
  double quality() const;
  /// Insertions and removals since the last build.
  std::size_t changesSinceBuild() const { return changes_; }
  /// Builds so far, and whether there was one since the last clear().
  std::size_t buildCount() const { return builds_; }
  bool built() const { return built_; }
  std::size_t deadCubes() const { return dead_nodes_; }
  std::size_t deadSlots() const { return dead_items_; }
  /// Heap bytes owned.
  std::size_t bytes() const;
  /// Checks every invariant of the cubes, that `loc` points each live id at its slot and, if the
  /// cubes record groups, that each one's group is that of all its objects by `group` (per id).
  bool validate(const std::uint32_t* loc, const Group* group, std::string* why) const;

 private:
  void growLeaf(std::uint32_t leaf, const Item<S>& item, IdArrays ids);
  std::uint32_t addChildren(std::uint32_t cube, std::uint32_t begin, std::uint32_t middle,
                            std::uint32_t end);
  void splitLeaf(std::uint32_t leaf, IdArrays ids);
  void splitCrowded(std::uint32_t top, IdArrays ids);
  std::uint32_t chooseLeaf(const Box<S>& box, Group group) const;
  void setGroups(const Group* group);
  Group leafGroup(const Node& leaf, const Group* group) const;
  std::uint32_t depthOf(std::uint32_t cube) const;
  bool canSplit(std::uint32_t depth) const;
  double refitCube(std::uint32_t cube);
  void startRoot(Item<S> item, IdArrays ids);
  /// Lays the items out as items_[p] = old items_[order[p]] (order a permutation of all slots);
  /// leaves order as the identity.
  void permuteInPlace(std::vector<std::uint32_t>& order);

  Config config_;
  NodeArray nodes_;
  std::vector<std::uint32_t> parent_;  // per cube; kNone for the root and dead cubes
  std::vector<Group> group_;           // per cube, or empty: no groups recorded
  std::uint32_t root_ = kNone;
  ItemArray<S> items_;  // leaf order; dead slots have obj == nullptr
  std::size_t live_ = 0;
  std::size_t dead_items_ = 0;
  std::size_t dead_nodes_ = 0;
  double area_ = 0;
  // Sum of the magnitudes of the area changes since the area was last summed afresh: the scale
  // of the rounding error that the running total may carry (see validate()).
  double area_churn_ = 0;
  std::size_t area_steps_ = 0;  // changes added since then
  double built_area_ = 0;
  std::size_t built_live_ = 0;
  double built_room_ = 1.0;
  std::size_t changes_ = 0;
  std::size_t builds_ = 0;
  bool built_ = false;
};

extern template class CubeTree<float>;
extern template class CubeTree<double>;

}  // namespace detail
}  // namespace cube
