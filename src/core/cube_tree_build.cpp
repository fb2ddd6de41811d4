// The cube tree's build: top-down, each cube whose object count exceeds the leaf size split
// along its longest side at the median object (core/split_rule.h), cubes of several filter
// groups first at a group boundary; the groups per cube.

#include <algorithm>
#include <cassert>
#include <vector>

#include "core/cube_tree.h"
#include "core/split_rule.h"
#include "core/walk.h"

namespace cube {
namespace detail {

template <typename S>
bool CubeTree<S>::canSplit(std::uint32_t depth) const {
  return config_.max_depth == 0 || depth < static_cast<std::uint32_t>(config_.max_depth);
}

template <typename S>
std::uint32_t CubeTree<S>::addChildren(std::uint32_t cube, std::uint32_t begin,
                                       std::uint32_t middle, std::uint32_t end) {
  const std::uint32_t c = static_cast<std::uint32_t>(nodes_.size());
  Node left{}, right{};
  setEmpty(left);
  setEmpty(right);
  left.first = begin;
  left.count = middle - begin;
  right.first = middle;
  right.count = end - middle;
  nodes_.push_back(left);
  nodes_.push_back(right);
  parent_.push_back(cube);
  parent_.push_back(cube);
  if (!group_.empty()) group_.resize(nodes_.size(), kMixedGroup);
  nodes_[cube].first = c;
  nodes_[cube].count = 0;
  return c;
}

// ---------------------------------------------------------------------------------------------
// Build

template <typename S>
void CubeTree<S>::permuteInPlace(std::vector<std::uint32_t>& order) {
  // items_[p] becomes the old items_[order[p]], cycle by cycle; order[p] = p marks p done. No
  // second array: a build's peak is the items once, and a new manager's first build touches no
  // fresh pages for a copy.
  const std::uint32_t n = static_cast<std::uint32_t>(order.size());
  for (std::uint32_t start = 0; start < n; ++start) {
    if (order[start] == start) continue;
    const Item<S> first = items_[start];
    std::uint32_t to = start;
    for (;;) {
      const std::uint32_t from = order[to];
      order[to] = to;
      if (from == start) {
        items_[to] = first;
        break;
      }
      items_[to] = items_[from];
      to = from;
    }
  }
}

template <typename S>
void CubeTree<S>::rebuild(IdArrays ids, ItemArray<S>&& extra) {
  // The live items and `extra` in one array, in that order, without dead slots: a first build
  // takes `extra`'s array as its own, so that the objects are held once.
  if (live_ == 0) {
    items_.swap(extra);
  } else {
    std::size_t n = 0;
    for (std::size_t p = 0; p < items_.size(); ++p)
      if (items_[p].obj != nullptr) items_[n++] = items_[p];
    items_.resize(n);
    items_.reserve(n + extra.size());
    items_.insert(items_.end(), extra.begin(), extra.end());
  }
  extra = {};
  live_ = items_.size();  // before the build, as after it: no dead slots
  dead_items_ = 0;
  rebuild(ids);
}

template <typename S>
void CubeTree<S>::rebuild(IdArrays ids) {
  // The records point at the live items where they are; the items are laid out in leaf order
  // once at the end.
  const std::uint32_t old_slots = static_cast<std::uint32_t>(items_.size());
  std::uint32_t n = 0;
  for (const Item<S>& it : items_) n += it.obj != nullptr;
  const auto itemAt = [&](std::uint32_t i) -> const Item<S>& { return items_[i]; };
  nodes_.clear();
  parent_.clear();
  group_.clear();
  dead_nodes_ = 0;
  root_ = kNone;
  area_ = 0;
  if (n > 0) {
    // The records and the selection's scratch space in one allocation.
    std::vector<BuildRecord> records(2 * std::size_t(n));
    BuildRecord* rec = records.data();
    BuildRecord* scratch = rec + n;
    std::uint32_t r = 0;
    for (std::uint32_t p = 0; p < old_slots; ++p) {
      const Item<S>& it = itemAt(p);
      if (it.obj == nullptr) continue;
      roundOut(it.box, rec[r].lo, rec[r].hi);
      rec[r].seq = ids.seq[it.id];
      rec[r].item = p;
      ++r;
    }
    // With groups: the records sorted by group (counting sort), rg[i] the group of rec[i]. The
    // median selections below permute only within one group, so rg stays true.
    std::vector<Group> rg;
    if (ids.group != nullptr) {
      std::uint32_t start[kMixedGroup + 2] = {};
      for (const BuildRecord* x = rec; x != rec + n; ++x)
        ++start[ids.group[itemAt(x->item).id] + 1];
      for (int g = 0; g <= kMixedGroup; ++g) start[g + 1] += start[g];
      rg.resize(n);
      for (const BuildRecord* x = rec; x != rec + n; ++x) {
        const Group g = ids.group[itemAt(x->item).id];
        rg[start[g]] = g;
        scratch[start[g]++] = *x;
      }
      std::swap(rec, scratch);
    }
    // Every lower child holds a multiple of leaf_size objects (splitCount), so the leaves are
    // full but one: at most 2 ceil(n / leaf_size) - 1 cubes, fewer under max_depth. Reserving
    // that leaves nothing for shrink_to_fit below to reallocate.
    const std::size_t leaf = static_cast<std::size_t>(std::max(1, config_.leaf_size));
    nodes_.reserve(2 * ((n + leaf - 1) / leaf) - 1);
    parent_.reserve(nodes_.capacity());
    Node root{};
    root.first = 0;
    root.count = n;
    nodes_.push_back(root);
    parent_.push_back(kNone);
    root_ = 0;
    // Top-down, preorder: a cube's children are appended as it is split, so that each pair of
    // siblings follows its parent's subtree order. The state is the depth.
    walkPreorder(
        nodes_, 0u, 0u,
        [&](std::uint32_t cube, std::uint32_t depth) {
          const std::uint32_t b = nodes_[cube].first;
          const std::uint32_t e = b + nodes_[cube].count;
          // The cube's sides: the union of its objects' rounded bounds, which is what refitting
          // makes of them (rounding out is monotonic), so no refit follows the build.
          unionOfRecords(rec + b, rec + e, nodes_[cube]);
          // Groups apart first, even in a small cube: a leaf of one group is one whose pairs
          // need no filter test.
          const bool mixed = !rg.empty() && rg[b] != rg[e - 1];
          if ((e - b <= static_cast<std::uint32_t>(config_.leaf_size) && !mixed) ||
              !canSplit(depth)) {
            sortLeaf(rec + b, rec + e);
            return Step::skip;
          }
          std::uint32_t m;
          if (mixed) {
            m = groupBoundary(rg.data(), b, e);
          } else {
            m = b + splitCount(e - b, config_.leaf_size);
            splitRecords(rec + b, rec + m, rec + e, nodes_[cube], scratch + b);
          }
          addChildren(cube, b, m, e);
          return Step::open;
        },
        [](int, std::uint32_t depth) { return depth + 1; });
    // The records go before the items are laid out: the build's peak is the items and the
    // records, or the items and the order.
    std::vector<std::uint32_t> order(n);
    for (std::uint32_t p = 0; p < n; ++p) order[p] = rec[p].item;
    std::vector<BuildRecord>().swap(records);
    std::vector<Group>().swap(rg);
    if (old_slots == n) {
      permuteInPlace(order);
    } else {
      // Dead slots among the old ones: a gather into a new array, from all over the old one.
      ItemArray<S> sorted(n);
      constexpr std::uint32_t kAhead = 8;
      for (std::uint32_t p = 0; p < n; ++p) {
        if (p + kAhead < n) __builtin_prefetch(&items_[order[p + kAhead]]);
        sorted[p] = itemAt(order[p]);
      }
      items_.swap(sorted);
    }
    order = {};
    double leaf_area = 0, object_area = 0;
    for (std::uint32_t i = 0; i < nodes_.size(); ++i) {
      const Node& node = nodes_[i];
      if (!node.isLeaf()) continue;
      leaf_area += surfaceArea(node);
      for (std::uint32_t p = node.first; p < node.first + node.count; ++p) {
        items_[p].leaf = i;
        ids.loc[items_[p].id] = p;
        object_area += surfaceArea(items_[p].box);
      }
    }
    built_room_ = object_area > 0 ? leaf_area / object_area : 1.0;
    for (const Node& node : nodes_) area_ += surfaceArea(node);
    if (ids.group != nullptr) setGroups(ids.group);
  } else {
    items_.clear();
    built_room_ = 1.0;
  }
  items_.shrink_to_fit();
  nodes_.shrink_to_fit();
  parent_.shrink_to_fit();
  live_ = n;
  dead_items_ = 0;
  area_churn_ = 0;
  area_steps_ = 0;
  built_area_ = area_;
  built_live_ = live_;
  changes_ = 0;
  ++builds_;
  built_ = true;
}

template <typename S>
Group CubeTree<S>::leafGroup(const Node& leaf, const Group* group) const {
  const Group g = group[items_[leaf.first].id];
  for (std::uint32_t p = leaf.first + 1; p < leaf.first + leaf.count; ++p)
    if (group[items_[p].id] != g) return kMixedGroup;
  return g;
}

template <typename S>
void CubeTree<S>::setGroups(const Group* group) {
  group_.assign(nodes_.size(), kMixedGroup);
  // Children always have larger indices than their parent: one backward pass is bottom-up.
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    const Node& n = nodes_[i];
    if (isDead(n)) continue;
    if (n.isLeaf())
      group_[i] = leafGroup(n, group);
    else if (group_[n.first] == group_[n.first + 1])
      group_[i] = group_[n.first];
  }
}

template <typename S>
double CubeTree<S>::quality() const {
  if (live_ == 0 || built_live_ == 0) return 1.0;
  if (built_area_ <= 0) return area_ > 0 ? std::numeric_limits<double>::infinity() : 1.0;
  return (area_ * double(built_live_)) / (built_area_ * double(live_));
}

template <typename S>
void CubeTree<S>::clear() {
  nodes_ = {};
  parent_ = {};
  group_ = {};
  items_ = {};
  root_ = kNone;
  live_ = dead_items_ = dead_nodes_ = 0;
  area_ = area_churn_ = built_area_ = 0;
  area_steps_ = 0;
  built_room_ = 1.0;
  built_live_ = 0;
  changes_ = 0;
  built_ = false;
}

template class CubeTree<float>;
template class CubeTree<double>;

}  // namespace detail
}  // namespace cube
