// SplitWalk (core/traversal.h): a collect walk cut into tasks by the walk's own expansion step
// (childPairs), each task walked on its own by the walk a collect would run.

#include <memory>
#include <vector>

#include "core/query_walks.h"
#include "core/traversal.h"

namespace cube {
namespace detail {

template <typename S>
SplitWalk<S>::SplitWalk(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                        const PairGate<S>* gate, std::size_t min_tasks)
    : a_(a), b_(b), self_(self), gate_(gate) {
  // As descend and collectPairs begin.
  if (a.root == kNone || b.root == kNone) return;
  if (allPairsFit(a, b, self, all_pairs_limit)) {
    all_pairs_ = true;
    tasks_.push_back(Task{a.root, a.root});
    return;
  }
  if (!self && !overlap(a.nodes[a.root], b.nodes[b.root])) return;
  tasks_.push_back(Task{a.root, b.root});
  // One level of the walk per round: each task gives way to the child pairs walkPair would take
  // from it, in the order it would visit them; a pair of leaves (or a leaf with itself) stays.
  std::vector<Task> next;
  while (tasks_.size() < min_tasks) {
    next.clear();
    bool opened = false;
    for (const Task& t : tasks_) {
      const Node& na = a.nodes[t.a];
      const Node& nb = b.nodes[t.b];
      if ((self && t.a == t.b) ? na.isLeaf() : na.isLeaf() && nb.isLeaf()) {
        next.push_back(t);  // nothing to open: the task stays where it is
        continue;
      }
      // The walk's own step: the child pairs in its order, those whose cubes overlap (as the
      // collide policy's enter tests them), the children with themselves always.
      childPairs(na, nb, t.a, t.b, self, [&](const auto& pairs, int fixed, bool, bool) {
        for (int i = 0; i < int(pairs.size()); ++i)
          if (i < fixed || overlap(a.nodes[pairs[i].a], b.nodes[pairs[i].b]))
            next.push_back(Task{pairs[i].a, pairs[i].b});
      });
      opened = true;
    }
    tasks_.swap(next);
    if (!opened) break;
  }
  const PairKernels<S>* kernels = &pairKernels<S>();
  if (wantsColumns(a, self, kernels)) {
    store_ = std::make_unique<ColumnStore>(a.slots);
    fillColumns(
        a.items, [](std::uint32_t i) { return i; }, a.slots, store_->columns(), 0);
  }
  gatherSlotBits(a, self, gate, bits_);
}

template <typename S>
SplitWalk<S>::~SplitWalk() = default;

template <typename S>
void SplitWalk<S>::collect(std::size_t i, std::vector<std::uint64_t>& out) const {
  using Policy = CollidePolicy<S, NoCount, RecordIds<S>>;
  const Task t = tasks_[i];
  if (all_pairs_) {
    allPairs(a_, b_, self_,
             Policy{RecordIds<S>{&out}, NoCount{}, &pairKernels<S>(), nullptr, gate_});
    return;
  }
  Policy p{RecordIds<S>{&out}, NoCount{}, &pairKernels<S>(), store_ ? &store_->columns() : nullptr,
           gate_};
  if (!bits_.empty()) {
    p.slot_bits = bits_.data();
    p.slot_base = a_.items;
  }
  // As cubeWalk chooses: cubes that carry filter groups are tested for them.
  if (gate_ != nullptr && a_.groups != nullptr) {
    PairVisitor<S, Policy, true> v{a_, b_, p};
    walkPair(a_.nodes, b_.nodes, t.a, t.b, NoKey{}, self_, v);
  } else {
    PairVisitor<S, Policy, false> v{a_, b_, p};
    walkPair(a_.nodes, b_.nodes, t.a, t.b, NoKey{}, self_, v);
  }
}

template class SplitWalk<float>;
template class SplitWalk<double>;

}  // namespace detail
}  // namespace cube
