// The cube tree after its build: refit, incremental insertion and removal (a crowded leaf split
// by the build's rule, core/split_rule.h), compaction, and the invariant check.

#include "core/cube_tree.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <type_traits>
#include <utility>

#include "core/kernels/box_ops.h"
#include "core/split_rule.h"
#include "core/walk.h"

namespace cube {
namespace detail {

// ---------------------------------------------------------------------------------------------
// Refit

template <typename S>
double CubeTree<S>::refitCube(std::uint32_t cube) {
  Node& n = nodes_[cube];
  const double before = surfaceArea(n);
  if (n.isLeaf())
    fitLeaf(n, items_.data());
  else
    fitParent(n, nodes_[n.first], nodes_[n.first + 1]);
  const double change = surfaceArea(n) - before;
  area_churn_ += std::fabs(change);
  ++area_steps_;
  return change;
}

template <typename S>
void CubeTree<S>::refitPath(std::uint32_t cube) {
  while (cube != kNone) {
    const Node before = nodes_[cube];
    area_ += refitCube(cube);
    if (sameBounds(before, nodes_[cube])) return;  // nothing above can change
    cube = parent_[cube];
  }
}

template <typename S>
void CubeTree<S>::refitAll() {
  // Children always have larger indices than their parent, so one backward pass is bottom-up.
  double total = 0;
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    if (isDead(nodes_[i])) continue;
    refitCube(static_cast<std::uint32_t>(i));
    total += surfaceArea(nodes_[i]);
  }
  area_ = total;
  area_churn_ = 0;
  area_steps_ = 0;
}

// ---------------------------------------------------------------------------------------------
// Incremental changes

template <typename S>
std::uint32_t CubeTree<S>::chooseLeaf(const Box<S>& box, Group group) const {
  float lo[3], hi[3];
  roundOut(box, lo, hi);
  std::uint32_t cube = root_;
  const bool by_group = !group_.empty() && group != kMixedGroup;
  while (!nodes_[cube].isLeaf()) {
    const std::uint32_t c = nodes_[cube].first;
    // Into the child of its own group if only one is: the cubes above then stay apart.
    if (by_group && (group_[c] == group) != (group_[c + 1] == group)) {
      cube = group_[c] == group ? c : c + 1;
      continue;
    }
    double growth[2];
    for (int i = 0; i < 2; ++i) {
      Node u = nodes_[c + i];
      const double before = surfaceArea(u);
      for (int k = 0; k < 3; ++k) {
        u.lo[k] = std::min(u.lo[k], lo[k]);
        u.hi[k] = std::max(u.hi[k], hi[k]);
      }
      growth[i] = surfaceArea(u) - before;
    }
    cube = growth[1] < growth[0] ? c + 1 : c;
  }
  return cube;
}

template <typename S>
std::uint32_t CubeTree<S>::depthOf(std::uint32_t cube) const {
  std::uint32_t depth = 0;
  while (parent_[cube] != kNone) {
    cube = parent_[cube];
    ++depth;
  }
  return depth;
}

template <typename S>
void CubeTree<S>::growLeaf(std::uint32_t leaf, const Item<S>& item, IdArrays ids) {
  const std::uint32_t first = nodes_[leaf].first;
  const std::uint32_t end = first + nodes_[leaf].count;
  std::uint32_t pos;
  if (end == items_.size()) {
    pos = end;
    items_.push_back(item);
  } else if (items_[end].obj == nullptr) {
    pos = end;
    items_[end] = item;
    --dead_items_;
  } else {
    // No room behind the leaf: move its range to the end of the array. The old slots die and
    // are reclaimed by the next compaction or build.
    const std::uint32_t moved_to = static_cast<std::uint32_t>(items_.size());
    for (std::uint32_t p = first; p < end; ++p) {
      items_.push_back(items_[p]);
      items_[p].obj = nullptr;
      ids.loc[items_.back().id] = moved_to + (p - first);
    }
    dead_items_ += end - first;
    nodes_[leaf].first = moved_to;
    pos = static_cast<std::uint32_t>(items_.size());
    items_.push_back(item);
  }
  items_[pos].leaf = leaf;
  ids.loc[item.id] = pos;
  ++nodes_[leaf].count;
}

template <typename S>
void CubeTree<S>::splitLeaf(std::uint32_t leaf, IdArrays ids) {
  const std::uint32_t b = nodes_[leaf].first;
  const std::uint32_t e = b + nodes_[leaf].count;
  std::vector<BuildRecord> rec(e - b), scratch(e - b);
  for (std::uint32_t p = b; p < e; ++p) {
    BuildRecord& r = rec[p - b];
    roundOut(items_[p].box, r.lo, r.hi);
    r.seq = ids.seq[items_[p].id];
    r.item = p;
  }
  Node bounds = nodes_[leaf];
  unionOfRecords(rec.data(), rec.data() + rec.size(), bounds);
  std::uint32_t half = (e - b) / 2;
  // A leaf of several groups splits between groups first, as the build does.
  const Group* group = ids.group != nullptr && !group_.empty() ? ids.group : nullptr;
  std::vector<Group> rg;
  if (group != nullptr) {
    const auto groupOf = [&](const BuildRecord& x) { return group[items_[x.item].id]; };
    std::stable_sort(rec.begin(), rec.end(), [&](const BuildRecord& x, const BuildRecord& y) {
      return groupOf(x) < groupOf(y);
    });
    for (const BuildRecord& x : rec) rg.push_back(groupOf(x));
  }
  if (!rg.empty() && rg.front() != rg.back())
    half = groupBoundary(rg.data(), 0, e - b);
  else
    splitRecords(rec.data(), rec.data() + half, rec.data() + rec.size(), bounds, scratch.data());
  sortLeaf(rec.data(), rec.data() + half);
  sortLeaf(rec.data() + half, rec.data() + rec.size());
  const std::uint32_t c = addChildren(leaf, b, b + half, e);
  ItemArray<S> range(e - b);
  for (std::uint32_t i = 0; i < e - b; ++i) range[i] = items_[rec[i].item];
  for (std::uint32_t i = 0; i < e - b; ++i) {
    items_[b + i] = range[i];
    items_[b + i].leaf = i < half ? c : c + 1;
    ids.loc[range[i].id] = b + i;
  }
  if (group != nullptr) {
    group_[c] = leafGroup(nodes_[c], group);
    group_[c + 1] = leafGroup(nodes_[c + 1], group);
  }
  area_ += refitCube(c);
  area_ += refitCube(c + 1);
}

template <typename S>
void CubeTree<S>::startRoot(Item<S> item, IdArrays ids) {
  nodes_.clear();
  parent_.clear();
  items_.clear();
  dead_items_ = dead_nodes_ = 0;
  Node root{};
  setEmpty(root);
  root.first = 0;
  root.count = 1;
  nodes_.push_back(root);
  parent_.push_back(kNone);
  group_.clear();
  if (ids.group != nullptr) group_.push_back(ids.group[item.id]);
  root_ = 0;
  item.leaf = 0;
  items_.push_back(item);
  ids.loc[item.id] = 0;
  area_ = refitCube(0);
  area_churn_ = 0;
  area_steps_ = 0;
}

template <typename S>
void CubeTree<S>::insert(Item<S> item, IdArrays ids) {
  assert(item.obj != nullptr && ids.loc[item.id] == kNone);
  ++live_;
  ++changes_;
  if (root_ == kNone) {
    startRoot(item, ids);
    return;
  }
  if (ids.group == nullptr) group_ = {};  // groups no longer wanted: they could not be kept
  const Group g = group_.empty() ? kMixedGroup : ids.group[item.id];
  const std::uint32_t leaf = chooseLeaf(item.box, g);
  growLeaf(leaf, item, ids);
  if (!group_.empty())
    for (std::uint32_t c = leaf; c != kNone && group_[c] != kMixedGroup && group_[c] != g;
         c = parent_[c])
      group_[c] = kMixedGroup;
  if (nodes_[leaf].count > static_cast<std::uint32_t>(config_.leaf_size) && canSplit(depthOf(leaf)))
    splitLeaf(leaf, ids);
  refitPath(leaf);
}

template <typename S>
void CubeTree<S>::remove(std::uint32_t pos, IdArrays ids) {
  assert(pos < items_.size() && items_[pos].obj != nullptr);
  ++changes_;
  const std::uint32_t leaf = items_[pos].leaf;
  ids.loc[items_[pos].id] = kNone;
  const std::uint32_t last = nodes_[leaf].first + nodes_[leaf].count - 1;
  if (pos != last) {
    items_[pos] = items_[last];
    ids.loc[items_[pos].id] = pos;
  }
  items_[last].obj = nullptr;
  ++dead_items_;
  --live_;
  if (--nodes_[leaf].count > 0) {
    refitPath(leaf);
    return;
  }
  // The leaf is empty: it and its sibling die, the sibling's content moves up into the parent.
  area_ -= surfaceArea(nodes_[leaf]);
  area_churn_ += surfaceArea(nodes_[leaf]);
  if (leaf == root_) {
    nodes_.clear();
    parent_.clear();
    group_.clear();
    items_.clear();
    root_ = kNone;
    dead_items_ = dead_nodes_ = 0;
    area_ = area_churn_ = 0;
    area_steps_ = 0;
    return;
  }
  const std::uint32_t up = parent_[leaf];
  const std::uint32_t c = nodes_[up].first;
  const std::uint32_t sibling = leaf == c ? c + 1 : c;
  area_ -= surfaceArea(nodes_[up]);
  area_churn_ += surfaceArea(nodes_[up]);
  nodes_[up] = nodes_[sibling];
  if (!group_.empty()) {  // the cubes above held both; holding fewer groups, they stay true
    group_[up] = group_[sibling];
    group_[c] = group_[c + 1] = kMixedGroup;
  }
  const Node& moved = nodes_[up];
  if (moved.isLeaf()) {
    for (std::uint32_t p = moved.first; p < moved.first + moved.count; ++p) items_[p].leaf = up;
  } else {
    parent_[moved.first] = up;
    parent_[moved.first + 1] = up;
  }
  for (std::uint32_t dead : {c, c + 1}) {
    nodes_[dead].first = kNone;
    nodes_[dead].count = 0;
    setEmpty(nodes_[dead]);
    parent_[dead] = kNone;
  }
  dead_nodes_ += 2;
  // With a depth cap, the sibling's subtree moved one level up: leaves that were full because
  // they sat at the cap may now be split further.
  if (config_.max_depth > 0) splitCrowded(up, ids);
  if (parent_[up] != kNone) refitPath(parent_[up]);
}

template <typename S>
void CubeTree<S>::splitCrowded(std::uint32_t top, IdArrays ids) {
  walkPreorder(
      nodes_, top, depthOf(top),
      [&](std::uint32_t cube, std::uint32_t depth) {
        const Node& n = nodes_[cube];
        if (n.isLeaf()) {
          if (n.count <= static_cast<std::uint32_t>(config_.leaf_size) || !canSplit(depth))
            return Step::skip;
          splitLeaf(cube, ids);
          area_ += refitCube(cube);
        }
        return Step::open;
      },
      [](int, std::uint32_t depth) { return depth + 1; });
}

template <typename S>
void CubeTree<S>::compactIfSparse(IdArrays ids) {
  if (!sparse()) return;
  const std::size_t live_nodes = nodes_.size() - dead_nodes_;
  // Re-lay the same tree depth-first: same cubes, same leaves, no dead slots.
  NodeArray nodes;
  std::vector<std::uint32_t> parents;
  std::vector<Group> groups;
  ItemArray<S> items;
  nodes.reserve(live_nodes);
  parents.reserve(live_nodes);
  items.reserve(live_);
  const bool grouped = !group_.empty();
  const auto copy = [&](std::uint32_t from, std::uint32_t up) {
    nodes.push_back(nodes_[from]);
    parents.push_back(up);
    if (grouped) groups.push_back(group_[from]);
  };
  copy(root_, kNone);
  // The state is the cube's index in the new array.
  walkPreorder(
      nodes_, root_, 0u,
      [&](std::uint32_t from, std::uint32_t to) {
        const Node n = nodes_[from];
        if (n.isLeaf()) {
          nodes[to].first = static_cast<std::uint32_t>(items.size());
          for (std::uint32_t p = n.first; p < n.first + n.count; ++p) {
            ids.loc[items_[p].id] = static_cast<std::uint32_t>(items.size());
            items.push_back(items_[p]);
            items.back().leaf = to;
          }
          return Step::skip;
        }
        nodes[to].first = static_cast<std::uint32_t>(nodes.size());
        copy(n.first, to);
        copy(n.first + 1, to);
        return Step::open;
      },
      [&](int which, std::uint32_t to) { return nodes[to].first + std::uint32_t(which); });
  nodes_.swap(nodes);
  parent_.swap(parents);
  group_.swap(groups);
  items_.swap(items);
  root_ = 0;
  dead_items_ = dead_nodes_ = 0;
}

template <typename S>
std::size_t CubeTree<S>::bytes() const {
  return nodes_.capacity() * sizeof(Node) + parent_.capacity() * sizeof(std::uint32_t) +
         group_.capacity() * sizeof(Group) + items_.capacity() * sizeof(Item<S>);
}

// ---------------------------------------------------------------------------------------------
// Invariants

template <typename S>
bool CubeTree<S>::validate(const std::uint32_t* loc, const Group* group, std::string* why) const {
  std::ostringstream msg;
  auto fail = [&]() {
    if (why) *why = msg.str();
    return false;
  };
  auto contains = [](const Node& outer, const float lo[3], const float hi[3]) {
    for (int k = 0; k < 3; ++k)
      if (outer.lo[k] > lo[k] || outer.hi[k] < hi[k]) return false;
    return true;
  };
  if (parent_.size() != nodes_.size()) return msg << "parent array size differs", fail();
  if ((root_ == kNone) != (live_ == 0)) return msg << "root/live mismatch", fail();
  std::vector<char> seen_item(items_.size(), 0);
  std::vector<char> seen_node(nodes_.size(), 0);
  std::size_t reached_items = 0, reached_nodes = 0;
  double total_area = 0;
  if (root_ != kNone) {
    if (root_ >= nodes_.size() || parent_[root_] != kNone) return msg << "bad root", fail();
    // Each check that fails stops the walk with its message in `msg`.
    const bool failed = walkPreorder(
        nodes_, root_, 0u,
        [&](std::uint32_t i, std::uint32_t depth) {
          if (seen_node[i]) return msg << "cube " << i << " reached twice", Step::stop;
          seen_node[i] = 1;
          ++reached_nodes;
          const Node& n = nodes_[i];
          total_area += surfaceArea(n);
          if (config_.max_depth > 0 && depth > std::uint32_t(config_.max_depth))
            return msg << "cube " << i << " deeper than max_depth", Step::stop;
          if (n.isLeaf()) {
            if (n.first > items_.size() || n.count > items_.size() - n.first)
              return msg << "leaf " << i << " range out of bounds", Step::stop;
            if (n.count > std::uint32_t(config_.leaf_size) && canSplit(depth))
              return msg << "leaf " << i << " holds " << n.count << " > leaf_size objects",
                     Step::stop;
            for (std::uint32_t p = n.first; p < n.first + n.count; ++p) {
              const Item<S>& it = items_[p];
              if (!it.obj) return msg << "leaf " << i << " holds dead slot " << p, Step::stop;
              if (seen_item[p]) return msg << "object slot " << p << " in two leaves", Step::stop;
              seen_item[p] = 1;
              ++reached_items;
              if (it.leaf != i) return msg << "object " << p << " has wrong leaf", Step::stop;
              float lo[3], hi[3];
              roundOut(it.box, lo, hi);
              if (!contains(n, lo, hi))
                return msg << "leaf " << i << " misses object " << p, Step::stop;
              if (loc[it.id] != p) return msg << "location wrong for object slot " << p, Step::stop;
            }
            return Step::skip;
          }
          // Children after their parent, so that the walk cannot cycle.
          const std::uint32_t c = n.first;
          if (c == kNone || c + 1 >= nodes_.size() || c <= i)
            return msg << "cube " << i << " has bad children " << c, Step::stop;
          if (c % 2 != 1) return msg << "children of " << i << " not at an odd index", Step::stop;
          for (std::uint32_t ch : {c, c + 1}) {
            if (parent_[ch] != i) return msg << "parent of " << ch << " is not " << i, Step::stop;
            if (!contains(n, nodes_[ch].lo, nodes_[ch].hi))
              return msg << "cube " << i << " does not contain child " << ch, Step::stop;
          }
          return Step::open;
        },
        [](int, std::uint32_t depth) { return depth + 1; });
    if (failed) return fail();
  }
  if (reached_items != live_)
    return msg << "leaves hold " << reached_items << " objects, expected " << live_, fail();
  std::size_t dead_items = 0;
  for (std::size_t p = 0; p < items_.size(); ++p) {
    if (items_[p].obj == nullptr)
      ++dead_items;
    else if (!seen_item[p])
      return msg << "live object slot " << p << " in no leaf", fail();
  }
  if (dead_items != dead_items_) return msg << "dead slot count wrong", fail();
  if (nodes_.size() - reached_nodes != dead_nodes_) return msg << "dead cube count wrong", fail();
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (!seen_node[i] && !isDead(nodes_[i]))
      return msg << "unreachable cube " << i << " not marked dead", fail();
  // The running total carries the rounding of every change added to it: a few ulps of the
  // largest magnitudes it has seen since it was last summed afresh, not of its current value
  // (a far object's cubes removed leave the error of their large areas behind).
  const double scale = std::max({1e-300, total_area, area_churn_});
  if (std::fabs(total_area - area_) > (1e-9 + 4e-16 * double(area_steps_)) * scale)
    return msg << "tracked area " << area_ << " differs from " << total_area, fail();
  if (!group_.empty()) {
    if (group_.size() != nodes_.size() || group == nullptr)
      return msg << "cube groups without a group per cube or per id", fail();
    for (std::size_t i = 0; i < nodes_.size(); ++i) {
      const Node& n = nodes_[i];
      const Group g = group_[i];
      if (g == kMixedGroup || isDead(n)) continue;
      bool ok = true;
      if (n.isLeaf()) {
        for (std::uint32_t p = n.first; p < n.first + n.count; ++p)
          ok = ok && group[items_[p].id] == g;
      } else {
        ok = group_[n.first] == g && group_[n.first + 1] == g;
      }
      if (!ok) return msg << "cube " << i << " has group " << int(g) << " but holds others", fail();
    }
  }
  return true;
}

template class CubeTree<float>;
template class CubeTree<double>;

}  // namespace detail
}  // namespace cube
