// The walk entry points of the core (core/traversal.h): which walk a pair of views takes
// (all pairs of small views, one object down a tree, or cube pairs), with what sink (the
// caller's function, or a record of ids), and the tests' direct ways to the kernels.

#include "core/traversal.h"

#include <stdexcept>
#include <type_traits>
#include <vector>

#include "core/query_walks.h"

namespace cube {
namespace detail {

namespace {

// One object down a tree, everything inlined: most queries are those, and short.
template <typename S, class Sink>
[[gnu::flatten, gnu::noinline]] bool oneObject(const View<S>& tree, const View<S>& q,
                                               const Sink& sink, QueryStats* stats) {
  return objectWalk(tree, q, sink, stats);
}

// The one choice of walk for a pair of views, whatever the sink: all pairs at once for small
// views, one object down a tree (without a gate: none of the set-up of cube pairs), or cube
// pairs.
template <typename S, class Sink>
inline bool walkViews(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                      const Sink& sink, QueryStats* stats, const PairGate<S>* gate) {
  if (allPairsFit(a, b, self, all_pairs_limit)) {
    const PairKernels<S>* k = &pairKernels<S>();
    if (stats)
      return allPairs(a, b, self,
                      CollidePolicy<S, Count, Sink>{sink, Count{stats}, k, nullptr, gate});
    return allPairs(a, b, self, CollidePolicy<S, NoCount, Sink>{sink, NoCount{}, k, nullptr, gate});
  }
  if (gate == nullptr && !self && b.root != kNone && b.nodes[b.root].count == 1)
    return oneObject(a, b, sink, stats);
  return cubeWalk(a, b, self, sink, stats, gate);
}

}  // namespace

template <typename S>
bool walkCubePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                   QueryStats* stats, const PairGate<S>* gate) {
  return cubeWalk(a, b, self, CallFn<S>{data, fn}, stats, gate);
}

template <typename S>
bool collideViews(const View<S>& a, const View<S>& b, CollideFnArg<S> fn, void* data, bool self,
                  std::size_t all_pairs_limit, QueryStats* stats, const PairGate<S>* gate) {
  return walkViews(a, b, self, all_pairs_limit, CallFn<S>{data, fn}, stats, gate);
}

// The object's view made here, from its storage: the walk then reads the object's box at a
// known place rather than through the view's pointers.
template <typename S>
[[gnu::flatten]] bool collideObject(const View<S>& tree, const SingleView<S>& object, void* data,
                                    CollideFnArg<S> fn, QueryStats* stats) {
  return objectWalk(tree, object.view(), CallFn<S>{data, fn}, stats);
}

template <typename S>
void collectPairs(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                  std::vector<std::uint64_t>& out, const PairGate<S>* gate) {
  walkViews(a, b, self, all_pairs_limit, RecordIds<S>{&out}, nullptr, gate);
}

template <typename S>
bool collideAllPairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                     QueryStats* stats, PairKernel kernel, const PairGate<S>* gate) {
  if (a.slots > kAllPairsMax || b.slots > kAllPairsMax)
    throw std::logic_error("collideAllPairs: view too large");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("collideAllPairs: kernel unavailable");
  const PairKernels<S>* k = &pairKernels<S>(kernel);
  if (stats)
    return allPairs(a, b, self,
                    CollidePolicy<S, Count>{{data, fn}, Count{stats}, k, nullptr, gate});
  return allPairs(a, b, self, CollidePolicy<S, NoCount>{{data, fn}, NoCount{}, k, nullptr, gate});
}

template <typename S>
std::uint64_t leafOverlapMask(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                              std::uint32_t ny, bool self, PairKernel kernel) {
  if (nx > kMaskLeaf || ny > kMaskLeaf || (self && (xs != ys || nx != ny)))
    throw std::logic_error("leafOverlapMask: runs too long, or not one run for self");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("leafOverlapMask: kernel unavailable");
  return pairKernels<S>(kernel).leafHits[self](xs, nx, ys, ny);
}

template <typename S>
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFnArg<S> fn,
                   S& best, QueryStats* stats, const PairGate<S>* gate) {
  if (stats)
    return distanceWalk(a, b, self, DistancePolicy<S, Count>{data, fn, best, Count{stats}, gate});
  return distanceWalk(a, b, self, DistancePolicy<S, NoCount>{data, fn, best, NoCount{}, gate});
}

template bool walkCubePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   CollideFn<float>, QueryStats*, const PairGate<float>*);
template bool walkCubePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    CollideFn<double>, QueryStats*, const PairGate<double>*);
template bool collideViews<float>(const View<float>&, const View<float>&, CollideFn<float>, void*,
                                  bool, std::size_t, QueryStats*, const PairGate<float>*);
template bool collideViews<double>(const View<double>&, const View<double>&, CollideFn<double>,
                                   void*, bool, std::size_t, QueryStats*, const PairGate<double>*);
template bool collideObject<float>(const View<float>&, const SingleView<float>&, void*,
                                   CollideFn<float>, QueryStats*);
template bool collideObject<double>(const View<double>&, const SingleView<double>&, void*,
                                    CollideFn<double>, QueryStats*);
template void collectPairs<float>(const View<float>&, const View<float>&, bool, std::size_t,
                                  std::vector<std::uint64_t>&, const PairGate<float>*);
template void collectPairs<double>(const View<double>&, const View<double>&, bool, std::size_t,
                                   std::vector<std::uint64_t>&, const PairGate<double>*);
template bool collideAllPairs<float>(const View<float>&, const View<float>&, bool, void*,
                                     CollideFn<float>, QueryStats*, PairKernel,
                                     const PairGate<float>*);
template bool collideAllPairs<double>(const View<double>&, const View<double>&, bool, void*,
                                      CollideFn<double>, QueryStats*, PairKernel,
                                      const PairGate<double>*);
template std::uint64_t leafOverlapMask<float>(const Item<float>*, std::uint32_t, const Item<float>*,
                                              std::uint32_t, bool, PairKernel);
template std::uint64_t leafOverlapMask<double>(const Item<double>*, std::uint32_t,
                                               const Item<double>*, std::uint32_t, bool,
                                               PairKernel);
template bool distancePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   DistanceFn<float>, float&, QueryStats*, const PairGate<float>*);
template bool distancePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    DistanceFn<double>, double&, QueryStats*,
                                    const PairGate<double>*);

}  // namespace detail
}  // namespace cube
