#pragma once

// A body of objects that belong to no table (a planner's links, posed anew for every state) as a
// view the walks take: its items and a small tree of cubes over them, so that one walk of a
// world's cubes against the body replaces one object query per link. The tree's shape depends
// on the number of objects only: built once, its bounds refitted per state.

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/geometry.h"
#include "core/kernels/box_ops.h"
#include "core/kernels/pair_kernels.h"

namespace cube {
namespace detail {

/// Objects per leaf of a body's tree, chosen by instruction counts of a 30-link robot's states:
/// larger leaves span long boxes that meet many of the world's leaves (colliding states cost
/// more), smaller ones make free states walk more.
inline constexpr std::uint32_t kBodyLeaf = 4;

template <typename S>
class BodyView {
 public:
  /// n objects, ids 0 .. n-1: leaves of at most per_leaf (<= kMaskLeaf) consecutive ids
  /// (neighbours in a chain of links lie near one another), halved top-down into a binary tree.
  explicit BodyView(std::uint32_t n, std::uint32_t per_leaf = kBodyLeaf) {
    NodeArray nodes;
    std::vector<std::uint32_t> leaves;
    std::vector<Item<S>> items(n);
    if (n != 0) {
      const std::uint32_t leaf_count = (n + per_leaf - 1) / per_leaf;
      struct Open {
        std::uint32_t node, first_leaf, leaf_count;
      };
      nodes.push_back(Node{});
      std::vector<Open> open{{0, 0, leaf_count}};
      for (std::size_t k = 0; k < open.size(); ++k) {  // breadth first: children after parents
        const Open o = open[k];
        if (o.leaf_count == 1) {
          const std::uint32_t first = o.first_leaf * n / leaf_count;
          const std::uint32_t end = (o.first_leaf + 1) * n / leaf_count;
          leaves.push_back(o.node);
          nodes[o.node].first = first;
          nodes[o.node].count = end - first;
          for (std::uint32_t i = first; i < end; ++i)
            items[i] = Item<S>{Box<S>{}, nullptr, o.node, i};
          continue;
        }
        const std::uint32_t child = std::uint32_t(nodes.size());
        nodes[o.node].first = child;
        nodes[o.node].count = 0;
        nodes.push_back(Node{});
        nodes.push_back(Node{});
        const std::uint32_t half = o.leaf_count / 2;
        open.push_back({child, o.first_leaf, half});
        open.push_back({child + 1, o.first_leaf + half, o.leaf_count - half});
      }
      std::sort(leaves.begin(), leaves.end(),
                [&](std::uint32_t a, std::uint32_t b) { return nodes[a].first < nodes[b].first; });
    }
    layOut(std::uint32_t(nodes.size()), n, std::uint32_t(leaves.size()));
    std::uninitialized_copy(nodes.begin(), nodes.end(), nodes_);
    std::uninitialized_copy(items.begin(), items.end(), items_);
    std::uninitialized_copy(leaves.begin(), leaves.end(), leaves_);
    for (std::uint32_t k = 0; k < leaf_count_; ++k) {
      new (&leaf_alone_[k]) Node(nodes_[leaves_[k]]);
      leaf_alone_[k].first = 0;
    }
  }
  BodyView(const BodyView& other) {
    layOut(other.node_count_, other.item_count_, other.leaf_count_);
    if (other.block_) std::memcpy(block_.get(), other.block_.get(), bytes_);
  }
  BodyView& operator=(const BodyView& other) {
    if (this != &other) {
      BodyView copy(other);
      swap(copy);
    }
    return *this;
  }
  BodyView(BodyView&& other) noexcept { swap(other); }
  BodyView& operator=(BodyView&& other) noexcept {
    swap(other);
    return *this;
  }

  /// Object i, kept from state to state.
  void setObject(std::uint32_t i, fcl::CollisionObject<S>* obj) { items_[i].obj = obj; }
  /// The box the walks test for object i (grown by whatever margin it has), written in place.
  Box<S>& box(std::uint32_t i) { return items_[i].box; }
  /// The cubes' bounds from the boxes set: call after the last set() of a state.
  void refit() {
    for (std::size_t k = node_count_; k-- > 0;) {
      Node& node = nodes_[k];
      if (node.isLeaf()) {
        leafBounds(node.first, node.count, node);
      } else {
        const Node& x = nodes_[node.first];
        const Node& y = nodes_[node.first + 1];
        node.lo[0] = std::min(x.lo[0], y.lo[0]);
        node.lo[1] = std::min(x.lo[1], y.lo[1]);
        node.lo[2] = std::min(x.lo[2], y.lo[2]);
        node.hi[0] = std::max(x.hi[0], y.hi[0]);
        node.hi[1] = std::max(x.hi[1], y.hi[1]);
        node.hi[2] = std::max(x.hi[2], y.hi[2]);
      }
    }
    for (std::size_t k = 0; k < leaf_count_; ++k) {
      const Node& leaf = nodes_[leaves_[k]];
      std::copy(leaf.lo, leaf.lo + 3, leaf_alone_[k].lo);
      std::copy(leaf.hi, leaf.hi + 3, leaf_alone_[k].hi);
    }
  }
  /// Every leaf's bounds as leafView walks them (refitLeaf of each): for a state whose walks
  /// take the leaves one by one, view() is stale until the next refit().
  void refitLeaves() {
    for (std::size_t k = 0; k < leaf_count_; ++k) refitLeaf(k);
  }
  /// Leaf k's bounds as leafView(k) walks them, from its objects' boxes alone: the rest of the
  /// tree keeps its bounds (view() is stale until the next refit()).
  void refitLeaf(std::size_t k) {
    const Node& leaf = nodes_[leaves_[k]];
    leafBounds(leaf.first, leaf.count, leaf_alone_[k]);
  }
  /// Leaf k's ids: leafFirst(k) .. leafFirst(k) + leafSize(k) - 1.
  std::uint32_t leafFirst(std::size_t k) const { return nodes_[leaves_[k]].first; }
  std::uint32_t leafSize(std::size_t k) const { return nodes_[leaves_[k]].count; }
  View<S> view() const {
    return View<S>{nodes_, items_, node_count_ == 0 ? kNone : 0u, item_count_};
  }
  /// The leaves in the order of their ids (leaf k holds the lowest ids after leaf k - 1's).
  std::size_t leafCount() const { return leaf_count_; }
  /// Leaf k alone as a view: its objects only, whichever walk takes it (the all-pairs test reads
  /// every slot of a view), with their ids as in view().
  View<S> leafView(std::size_t k) const {
    const Node& leaf = nodes_[leaves_[k]];
    return View<S>{&leaf_alone_[k], items_ + leaf.first, 0, leaf.count};
  }

 private:
  // The union of items first .. first + count - 1's boxes, rounded out, into node's bounds.
  void leafBounds(std::uint32_t first, std::uint32_t count, Node& node) const {
    Box<S> u = items_[first].box;
    for (std::uint32_t i = first + 1; i < first + count; ++i) {
      const Box<S>& b = items_[i].box;
      u.lo[0] = std::min(u.lo[0], b.lo[0]);
      u.lo[1] = std::min(u.lo[1], b.lo[1]);
      u.lo[2] = std::min(u.lo[2], b.lo[2]);
      u.hi[0] = std::max(u.hi[0], b.hi[0]);
      u.hi[1] = std::max(u.hi[1], b.hi[1]);
      u.hi[2] = std::max(u.hi[2], b.hi[2]);
    }
    roundOut(u, node.lo, node.hi);
  }

  // One block for the arrays below, so that a checker's copy of the view is one allocation:
  // the cubes from byte 32 of a line (two siblings per line, as the world's), each leaf alone,
  // the items from a line, the leaves.
  struct alignas(64) Line {
    unsigned char bytes[64];
  };
  static std::size_t roundUp(std::size_t at, std::size_t to) { return (at + to - 1) / to * to; }
  void layOut(std::uint32_t nodes, std::uint32_t items, std::uint32_t leaves) {
    node_count_ = nodes;
    item_count_ = items;
    leaf_count_ = leaves;
    const std::size_t alone_at = 32 + sizeof(Node) * nodes;
    const std::size_t item_at = roundUp(alone_at + sizeof(Node) * leaves, 64);
    const std::size_t leaf_at = roundUp(item_at + sizeof(Item<S>) * items, alignof(std::uint32_t));
    bytes_ = roundUp(leaf_at + sizeof(std::uint32_t) * leaves, 64);
    block_.reset(new Line[bytes_ / 64]);
    unsigned char* base = block_[0].bytes;
    nodes_ = reinterpret_cast<Node*>(base + 32);
    leaf_alone_ = reinterpret_cast<Node*>(base + alone_at);
    items_ = reinterpret_cast<Item<S>*>(base + item_at);
    leaves_ = reinterpret_cast<std::uint32_t*>(base + leaf_at);
  }
  void swap(BodyView& other) noexcept {
    std::swap(block_, other.block_);
    std::swap(bytes_, other.bytes_);
    std::swap(nodes_, other.nodes_);
    std::swap(leaf_alone_, other.leaf_alone_);
    std::swap(items_, other.items_);
    std::swap(leaves_, other.leaves_);
    std::swap(node_count_, other.node_count_);
    std::swap(item_count_, other.item_count_);
    std::swap(leaf_count_, other.leaf_count_);
  }

  static_assert(std::is_trivially_copyable<Node>::value &&
                    std::is_trivially_copyable<Item<S>>::value,
                "a copy of the block copies its arrays");
  std::unique_ptr<Line[]> block_;
  std::size_t bytes_ = 0;
  Node* nodes_ = nullptr;
  Node* leaf_alone_ = nullptr;  // per leaf: a copy of its cube, its range from 0
  Item<S>* items_ = nullptr;
  std::uint32_t* leaves_ = nullptr;  // leaf nodes in id order
  std::uint32_t node_count_ = 0, item_count_ = 0, leaf_count_ = 0;
};

}  // namespace detail
}  // namespace cube
