// The cube tree: build (top-down median split, the seed's rule), refit, incremental insertion
// and removal, compaction, and the invariant check.

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
#include "core/walk.h"

namespace cube {
namespace detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

void setEmpty(Node& n) {
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = kInf;
    n.hi[k] = -kInf;
  }
}

// Of an object box or a cube; sides in double, exact for float bounds.
template <class B>
int longestAxis(const B& b) {
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (double(b.hi[k]) - double(b.lo[k]) > double(b.hi[axis]) - double(b.lo[axis])) axis = k;
  return axis;
}

// Objects in the lower child of a cube of `count` objects: the median, rounded up to a multiple
// of the leaf size so that leaves come out full (a halving split of 10,000 objects with leaves
// of 4 would give leaves of 2.4 on average, and a third more cubes to store and visit).
std::uint32_t splitCount(std::uint32_t count, int leaf_size) {
  const std::uint32_t l = static_cast<std::uint32_t>(leaf_size);
  const std::uint32_t m = (count / 2 + l - 1) / l * l;
  return m < count ? m : count / 2;
}

// A leaf's bounds: the union of its objects' exact boxes, rounded out.
template <typename S>
void fitLeaf(Node& n, const Item<S>* items) {
  Box<S> box;
  unionOfItems(items, n.first, n.count, box);
  roundOut(box, n.lo, n.hi);
}

// An internal cube's bounds: the union of its two children's.
void fitParent(Node& n, const Node& a, const Node& b) {
  unionOfCubes(n, a, b);
}

bool isDead(const Node& n) {
  return n.count == 0 && n.first == kNone;
}

// Twice a record's centre along an axis (the sum of its bounds: only the order matters). A box
// reaching both infinities has no centre; it counts as 0, so that the order stays total.
inline float centre2(const BuildRecord& r, int axis) {
  const float c = r.lo[axis] + r.hi[axis];
  return c == c ? c : 0.0f;
}

// An unsigned integer in the order of the float x (not NaN); -0 and +0 give the same one.
inline std::uint32_t orderedBits(float x) {
  std::uint32_t u;
  const float y = x + 0.0f;  // -0 + 0 is +0
  std::memcpy(&u, &y, sizeof u);
  // Negative: all bits flipped; otherwise the sign bit set. Without a branch: the build's
  // centres fall on both sides of 0 at random, and a branch here mispredicted on those.
  const std::uint32_t neg = static_cast<std::uint32_t>(static_cast<std::int32_t>(u) >> 31);
  return u ^ (neg | 0x80000000u);
}

// The build's order as one integer: by centre along `axis`, ties by registration order (a strict
// total order, so the same objects always give the same tree); axis < 0: registration order.
inline std::uint64_t orderKey(const BuildRecord& r, int axis) {
  return (axis < 0 ? 0 : std::uint64_t(orderedBits(centre2(r, axis))) << 32) | r.seq;
}

inline bool before(const BuildRecord& x, const BuildRecord& y, int axis) {
  return orderKey(x, axis) < orderKey(y, axis);
}

// Runs this short are sorted by rank.
constexpr std::ptrdiff_t kRankMax = 16;

// Sorts [first, last) (at most kRankMax records) in the build's order along `axis`, or by
// registration order alone if axis < 0: each record goes to the place given by the number of
// records before it, counted without a branch. An insertion sort here mispredicted on about
// every other comparison, and builds happen in the middle of update().
void rankSort(BuildRecord* first, BuildRecord* last, int axis) {
  const std::ptrdiff_t c = last - first;
  BuildRecord tmp[kRankMax];
  std::uint64_t key[kRankMax];  // the order as one integer: one compare per pair
  for (std::ptrdiff_t i = 0; i < c; ++i) {
    tmp[i] = first[i];
    key[i] = orderKey(first[i], axis);
  }
  for (std::ptrdiff_t i = 0; i < c; ++i) {
    int rank = 0;
    for (std::ptrdiff_t j = 0; j < c; ++j) rank += key[j] < key[i];
    first[rank] = tmp[i];
  }
}

// Ranges at least this long take their pivot from a sample instead of a median of three.
constexpr std::ptrdiff_t kSampleMin = 256;
constexpr std::ptrdiff_t kSampleMax = 128;

// The key of a pivot that leaves *nth on the smaller side of the partition when it can: from
// evenly spaced records, the one just beyond nth's estimated place (by two standard deviations
// of the estimate), or at that place when nth is near the middle, where either side is about
// half. The sample's smallest key is never the pivot, so both sides get at least one record.
std::uint64_t samplePivot(const BuildRecord* first, const BuildRecord* nth, const BuildRecord* last,
                          int axis) {
  const std::ptrdiff_t n = last - first;
  std::ptrdiff_t s = 1;
  while (s * s < 4 * n && s < kSampleMax) s *= 2;
  std::uint64_t key[kSampleMax];
  for (std::ptrdiff_t i = 0; i < s; ++i) key[i] = orderKey(first[(2 * i + 1) * n / (2 * s)], axis);
  const double q = (double(nth - first) + 0.5) / double(n);
  const double margin = 2.0 * std::sqrt(double(s) * q * (1.0 - q)) + 1.0;
  double r = q * double(s);
  if (std::min(q, 1.0 - q) * double(s) + margin < 0.5 * double(s)) r += q < 0.5 ? margin : -margin;
  const std::ptrdiff_t i =
      std::max<std::ptrdiff_t>(1, std::min<std::ptrdiff_t>(s - 1, std::ptrdiff_t(r)));
  std::nth_element(key, key + i, key + s);  // the sample's i-th key; the rest needs no order
  return key[i];
}

// Puts into *nth the record that a sort in the build's order along `axis` would put there,
// smaller ones before it and larger ones after (std::nth_element's contract). `scratch` is as
// long as [first, last). Quickselect whose partition writes each record to both ends of the
// other buffer and advances one of them: no branch on the comparison and no load that waits for
// it. Whether a record goes left is a coin toss, so std::nth_element's branches mispredicted on
// half the records, most of the build time. Long ranges pick the pivot from a sample, so that
// about one and a half passes find the median instead of about three. The passes alternate
// between the buffers; only what a pass into `scratch` leaves behind is copied back.
void selectNth(BuildRecord* first, BuildRecord* nth, BuildRecord* last, int axis,
               BuildRecord* scratch) {
  BuildRecord* const home = first;
  BuildRecord* src = first;
  std::ptrdiff_t lo_off = 0, hi_off = last - first, nth_off = nth - first;
  bool in_scratch = false;
  while (hi_off - lo_off > kRankMax) {
    const BuildRecord* f = src + lo_off;
    const BuildRecord* l = src + hi_off;
    std::uint64_t pivot_key;
    if (l - f >= kSampleMin) {
      pivot_key = samplePivot(f, src + nth_off, l, axis);
    } else {
      // Median of three distinct records: both sides get at least one, so every pass shrinks.
      const BuildRecord& x = *f;
      const BuildRecord& y = f[(l - f) / 2];
      const BuildRecord& z = *(l - 1);
      const BuildRecord pivot = before(x, y, axis)
                                    ? (before(y, z, axis) ? y : (before(x, z, axis) ? z : x))
                                    : (before(x, z, axis) ? x : (before(y, z, axis) ? z : y));
      pivot_key = orderKey(pivot, axis);
    }
    BuildRecord* const dst = in_scratch ? home : scratch;
    BuildRecord* lo = dst + lo_off;
    BuildRecord* hi = dst + hi_off;
    // One loop per axis, so that the centre is read at a fixed offset.
    const auto pass = [&](auto axis_constant) {
      constexpr int a = decltype(axis_constant)::value;
      for (const BuildRecord* p = f; p < l; ++p) {
        const BuildRecord r = *p;
        const bool left = orderKey(r, a) < pivot_key;
        *lo = r;
        *(hi - 1) = r;
        lo += left;
        hi -= !left;
      }
    };
    if (axis == 0)
      pass(std::integral_constant<int, 0>());
    else if (axis == 1)
      pass(std::integral_constant<int, 1>());
    else
      pass(std::integral_constant<int, 2>());
    const std::ptrdiff_t mid = lo - dst;
    // The side without nth is final; in scratch it goes home now.
    if (nth_off < mid) {
      if (!in_scratch) std::copy(dst + mid, dst + hi_off, home + mid);
      hi_off = mid;
    } else {
      if (!in_scratch) std::copy(dst + lo_off, dst + mid, home + lo_off);
      lo_off = mid;
    }
    src = dst;
    in_scratch = !in_scratch;
  }
  if (in_scratch) std::copy(src + lo_off, src + hi_off, home + lo_off);
  rankSort(home + lo_off, home + hi_off, axis);
}

// The seed's split rule, written once for the build and for a leaf that overflows: along the
// longest side of `bounds` (the union of the records), the records ordered by centre (ties by
// registration order), the first `mid - first` of them for the lower child.
void splitRecords(BuildRecord* first, BuildRecord* mid, BuildRecord* last, const Node& bounds,
                  BuildRecord* scratch) {
  selectNth(first, mid, last, longestAxis(bounds), scratch);
}

// Where a cube whose records are sorted by filter group (rg, per record) and hold more than
// one group splits: at the group boundary nearest its median, so that both children get some.
std::uint32_t groupBoundary(const Group* rg, std::uint32_t b, std::uint32_t e) {
  const std::uint32_t mid = b + (e - b) / 2;
  const auto lo = std::uint32_t(std::lower_bound(rg + b, rg + e, rg[mid]) - rg);
  const auto hi = std::uint32_t(std::upper_bound(rg + b, rg + e, rg[mid]) - rg);
  if (lo == b) return hi;
  if (hi == e) return lo;
  return mid - lo <= hi - mid ? lo : hi;
}

// Within a leaf, registration order: the callback order does not depend on history.
void sortLeaf(BuildRecord* first, BuildRecord* last) {
  if (last - first <= kRankMax)
    rankSort(first, last, -1);
  else
    std::sort(first, last,
              [](const BuildRecord& x, const BuildRecord& y) { return x.seq < y.seq; });
}

}  // namespace

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
void CubeTree<S>::rebuild(IdArrays ids, const std::vector<Item<S>>& extra) {
  // The records point at the live items where they are (extra ones past the end); the items are
  // laid out in leaf order once at the end.
  const std::uint32_t old_slots = static_cast<std::uint32_t>(items_.size());
  std::uint32_t n = static_cast<std::uint32_t>(extra.size());
  for (const Item<S>& it : items_) n += it.obj != nullptr;
  const auto itemAt = [&](std::uint32_t i) -> const Item<S>& {
    return i < old_slots ? items_[i] : extra[i - old_slots];
  };
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
    for (std::uint32_t p = 0; p < old_slots + extra.size(); ++p) {
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
    ItemArray<S> sorted(n);
    // A gather from all over the old array: fetch a few records ahead.
    constexpr std::uint32_t kAhead = 8;
    for (std::uint32_t p = 0; p < n; ++p) {
      if (p + kAhead < n && rec[p + kAhead].item < old_slots)
        __builtin_prefetch(&items_[rec[p + kAhead].item]);
      sorted[p] = itemAt(rec[p].item);
    }
    items_.swap(sorted);
    for (std::uint32_t i = 0; i < nodes_.size(); ++i) {
      const Node& node = nodes_[i];
      if (node.isLeaf())
        for (std::uint32_t p = node.first; p < node.first + node.count; ++p) {
          items_[p].leaf = i;
          ids.loc[items_[p].id] = p;
        }
    }
    for (const Node& node : nodes_) area_ += surfaceArea(node);
    if (ids.group != nullptr) setGroups(ids.group);
  } else {
    items_.clear();
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
  built_live_ = 0;
  changes_ = 0;
  built_ = false;
}

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
