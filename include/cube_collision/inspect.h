#pragma once

// Read-only inspection of a cube hierarchy in the vocabulary of the cube collision model: cells
// (getNumberCells / getCubeData / isLeaf), a cube's child cubes (getInternalChildren) and the
// objects below it (getExternalChildren), an object's leaf (getLeafIndex), every cube's corners
// (getBoundingTree), plus levels and statistics. For debugging, tuning `Config::max_depth` and
// `Config::leaf_size`, and export.

#include <array>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <utility>
#include <vector>

namespace fcl {
template <typename S>
class CollisionObject;
}  // namespace fcl

namespace cube {

template <typename S>
class CubeCollisionManager;

/// One cube as the inspection API numbers it. Cube numbers are dense, breadth-first from the root
/// (0) over the live cubes; object positions index HierarchyView::objects().
struct CubeData {
  /// Corners of the cube (the stored bounds, rounded outward from the objects' exact AABBs).
  std::array<double, 3> min;
  std::array<double, 3> max;
  /// Child cubes [first_child, end_child): two for an internal cube, none for a leaf.
  int first_child;
  int end_child;
  /// Objects below the cube, [first_object, end_object) in objects(): a leaf's own objects, or
  /// for an internal cube every object of its subtree.
  int first_object;
  int end_object;
  /// Parent cube number, -1 for the root.
  int parent;
  /// Level: 0 for the root, parent's level + 1 below.
  int level;
};

/// A (min corner, max corner) pair, as getBoundingTree() fills them.
using BoundingBox = std::pair<std::array<double, 3>, std::array<double, 3>>;

/// Shape and cost of a hierarchy, from HierarchyView::stats().
struct HierarchyStats {
  std::size_t objects = 0;            ///< objects in the cubes
  std::size_t unbounded_objects = 0;  ///< objects kept outside the cubes (planes, halfspaces)
  std::size_t cubes = 0;              ///< live cubes
  std::size_t leaves = 0;             ///< live leaf cubes
  /// Deepest level (the root is level 0; -1 when there are no cubes). Never above a nonzero
  /// Config::max_depth.
  int depth = -1;
  /// leaf_size_histogram[k]: number of leaves holding exactly k objects.
  std::vector<std::size_t> leaf_size_histogram;
  /// cubes_per_level[l]: number of cubes at level l.
  std::vector<std::size_t> cubes_per_level;
  double mean_leaf_size = 0;  ///< objects / leaves
  std::size_t max_leaf_size = 0;
  double surface_area = 0;  ///< sum of the live cubes' surface areas
  double volume = 0;        ///< sum of the live cubes' volumes (nested cubes counted each)
  /// Cube area per object now over the same right after the last build: 1 after a build,
  /// growing as refits stretch the cubes or insertions land badly. UpdatePolicy::automatic
  /// rebuilds once it exceeds Config::rebuild_threshold. Infinity if the build had zero area and
  /// the cubes now have some.
  double quality_ratio = 1;
  double rebuild_threshold = 0;       ///< Config::rebuild_threshold, for comparison
  std::size_t dead_cubes = 0;         ///< unreachable cubes awaiting compaction
  std::size_t dead_object_slots = 0;  ///< removed objects' slots awaiting compaction
  std::size_t builds = 0;             ///< full builds so far
  /// Live cubes whose objects all have one filter group (equal filter bits), when the cubes keep
  /// groups apart (Config::filter_groups; laid out by update() or setup() after bits change);
  /// 0 when they do not.
  std::size_t one_group_cubes = 0;
  std::size_t bytes = 0;        ///< heap bytes owned by the hierarchy
  double bytes_per_object = 0;  ///< bytes / all registered objects (0 if none)
};

/// Writes the statistics as a few human-readable lines.
std::ostream& operator<<(std::ostream& os, const HierarchyStats& stats);

/// A read-only snapshot of a cube hierarchy, numbered for users. Construction walks the tree once
/// (iteratively, O(cubes + objects)); afterwards every accessor is O(1) except getLeafIndex
/// (O(log n)). The snapshot does not follow later changes to the manager: make a new view after
/// registering, unregistering, updating or setup(). It holds no pointer into the hierarchy, so it
/// stays safe to read after the manager changes or dies (the object pointers are only reported).
///
/// Numbering: cubes are numbered breadth-first from the root over the live cubes only, so the
/// numbers are dense (0 .. getNumberCells() - 1), each level is a contiguous range, the two
/// children of a cube are consecutive, and the numbering is the same for the same tree whatever
/// its internal storage. Objects are listed in depth-first leaf order, so the objects below any
/// cube are a contiguous range of objects().
template <typename S>
class HierarchyView {
 public:
  using Object = fcl::CollisionObject<S>;

  /// Contiguous objects of the snapshot, usable in range-for.
  struct ObjectRange {
    Object* const* first;
    Object* const* last;
    Object* const* begin() const { return first; }
    Object* const* end() const { return last; }
    std::size_t size() const { return static_cast<std::size_t>(last - first); }
    bool empty() const { return first == last; }
  };

  /// Snapshot of a manager's hierarchy.
  explicit HierarchyView(const CubeCollisionManager<S>& manager);

  /// Number of cubes.
  int getNumberCells() const { return static_cast<int>(cubes_.size()); }
  /// Cube `i` (0 <= i < getNumberCells(); out of range throws std::out_of_range).
  const CubeData& getCubeData(int i) const;
  /// True if cube `i` holds objects rather than child cubes.
  bool isLeaf(int i) const;
  /// Child cubes of `i` as a [begin, end) range of cube numbers; empty for a leaf.
  std::pair<int, int> getInternalChildren(int i) const;
  /// Objects below cube `i` (the model's "external children": objects, not cubes): a leaf's own,
  /// or every object in an internal cube's subtree.
  ObjectRange getExternalChildren(int i) const;
  /// The leaf holding `object`, or -1 if the object is not in the cubes
  /// (unregistered, or kept in the unbounded list).
  int getLeafIndex(const Object* object) const;
  /// Replaces `out` with every cube's (min, max) corners, indexed by cube number.
  void getBoundingTree(std::vector<BoundingBox>& out) const;

  /// Deepest level, 0 for a root alone, -1 for no cubes.
  int depth() const { return static_cast<int>(level_begin_.size()) - 2; }
  /// Number of levels (depth() + 1).
  int levelCount() const { return static_cast<int>(level_begin_.size()) - 1; }
  /// Cubes of level `l` as a [begin, end) range of cube numbers (out of range: empty).
  std::pair<int, int> levelCubes(int l) const;

  /// Objects in the cubes, depth-first leaf order (see CubeData::first_object).
  const std::vector<Object*>& objects() const { return objects_; }
  /// Exact AABB of objects()[k] as the hierarchy cached it.
  const BoundingBox& objectBox(int k) const {
    return object_boxes_.at(static_cast<std::size_t>(k));
  }
  /// Objects kept outside the cubes, in the hierarchy's order.
  const std::vector<Object*>& unboundedObjects() const { return unbounded_; }

  /// Statistics of the snapshot.
  const HierarchyStats& stats() const { return stats_; }

 private:
  std::vector<CubeData> cubes_;
  std::vector<int> level_begin_;  // level l is [level_begin_[l], level_begin_[l + 1])
  std::vector<Object*> objects_;
  std::vector<BoundingBox> object_boxes_;
  std::vector<Object*> unbounded_;
  std::vector<std::pair<const Object*, int>> leaf_of_;  // sorted by object, for getLeafIndex
  HierarchyStats stats_;
};

extern template class HierarchyView<float>;
extern template class HierarchyView<double>;

}  // namespace cube
