// The narrow-phase pipeline's entry points (include/cube_collision/narrow_phase.h): pair lists
// answered through the cache, the pair judge and FCL (collidePairs, collideMerged), a caller's
// function over a pair list (forEachPair), the thread count. The streams fed by walks are in
// collide_stream.cpp and distance_search.cpp, the cache in cache.h and cache.cpp.

#include "cube_collision/narrow_phase.h"

#include <algorithm>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/parallel_for.h"
#include "pipeline/answers.h"
#include "pipeline/cache.h"
#include "pipeline/collectors.h"
#include "pipeline/collide_stream.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"

namespace cube {

int hardwareThreads() {
  return detail::resolveThreads(0);
}

namespace {

using detail::addStats;
using detail::kParallelMinPairs;
using detail::kParallelMinWork;
using detail::plainRequest;
using detail::regionTeam;
using detail::resolveThreads;

// A pair list from the caller: a null object would crash inside FCL, so it is refused first.
template <typename S>
void checkPairs(const std::vector<ObjectPair<S>>& pairs, const char* where) {
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (pairs[i].first == nullptr || pairs[i].second == nullptr)
      throw std::invalid_argument(std::string("cube::") + where + ": pair " + std::to_string(i) +
                                  " holds a null object");
}

}  // namespace

template <typename S>
std::vector<fcl::CollisionResult<S>> collidePairs(const std::vector<ObjectPair<S>>& pairs,
                                                  const fcl::CollisionRequest<S>& request,
                                                  const NarrowPhaseOptions<S>& options) {
  checkPairs(pairs, "collidePairs");
  NarrowPhaseStats stats;
  stats.candidate_pairs = pairs.size();
  auto* cache =
      options.cache != nullptr && plainRequest(request) ? &options.cache->impl() : nullptr;
  if (cache != nullptr) {
    ++cache->stamp;
    cache->collide.begin(*cache, request);
  }
  std::vector<fcl::CollisionResult<S>> results(pairs.size());
  std::vector<detail::Answer> kind(pairs.size());
  std::vector<detail::CollideEntry<S>*> cached(pairs.size());
  // The cache on this thread; the cull and FCL's calls on the threads if they pay.
  std::vector<std::size_t> rest;
  std::size_t work = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    cached[i] =
        cache != nullptr ? cache->collide.find(*cache, pairs[i].first, pairs[i].second) : nullptr;
    if (cached[i] != nullptr) {
      kind[i] = detail::Answer::kCached;
      continue;
    }
    rest.push_back(i);
    work += detail::workOf(pairs[i]);
  }
  const int threads = work >= kParallelMinWork ? regionTeam(resolveThreads(options.threads)) : 1;
  const detail::PairJudge<S> judge(request);
  detail::parallelFor(rest.size(), threads, [&](std::size_t k) {
    const std::size_t i = rest[k];
    kind[i] = judge.collide(*pairs[i].first, *pairs[i].second);
    if (kind[i] == detail::Answer::kComputed)
      detail::fclCollide(pairs[i].first, pairs[i].second, request, results[i]);
  });
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    detail::count(stats, kind[i]);
    if (kind[i] == detail::Answer::kCached)
      for (const fcl::Contact<S>& c : cached[i]->answer) results[i].addContact(c);
    if (kind[i] == detail::Answer::kProved) results[i].addContact(detail::provedContact(pairs[i]));
  }
  for (std::size_t i = 0; i < pairs.size(); ++i)
    detail::storeAnswer(kind[i], pairs[i], cache, results[i]);
  if (cache != nullptr) cache->collide.end(*cache);
  addStats(options.stats, stats);
  return results;
}

template <typename S>
fcl::CollisionResult<S> collideMerged(const std::vector<ObjectPair<S>>& pairs,
                                      const fcl::CollisionRequest<S>& request,
                                      const NarrowPhaseOptions<S>& options) {
  checkPairs(pairs, "collideMerged");
  if (!plainRequest(request)) {
    // Costs and the GJK guess travel from pair to pair through the one result: in turn.
    fcl::CollisionResult<S> result;
    detail::AllContacts<S> all(request, result, options.colliding);
    NarrowPhaseStats stats;
    stats.candidate_pairs = pairs.size();
    for (const ObjectPair<S>& pair : pairs) {
      ++stats.narrow_calls;
      all.collide(pair);
      if (all.full()) break;
    }
    addStats(options.stats, stats);
    return result;
  }
  detail::CollideStream<S> stream(request, options);
  for (const auto& [a, b] : pairs)
    if (stream.push(a, b)) break;
  return stream.finish();
}

template <typename S>
void forEachPair(
    const std::vector<ObjectPair<S>>& pairs,
    const std::function<void(std::size_t, fcl::CollisionObject<S>*, fcl::CollisionObject<S>*)>& fn,
    int threads) {
  checkPairs(pairs, "forEachPair");
  if (!fn) throw std::invalid_argument("cube::forEachPair: empty function");
  detail::parallelFor(pairs.size(),
                      pairs.size() >= kParallelMinPairs ? regionTeam(resolveThreads(threads)) : 1,
                      [&](std::size_t i) { fn(i, pairs[i].first, pairs[i].second); });
}

#define CUBE_INSTANTIATE_NARROW_PHASE(S)                                                           \
  template std::vector<fcl::CollisionResult<S>> collidePairs(const std::vector<ObjectPair<S>>&,    \
                                                             const fcl::CollisionRequest<S>&,      \
                                                             const NarrowPhaseOptions<S>&);        \
  template fcl::CollisionResult<S> collideMerged(const std::vector<ObjectPair<S>>&,                \
                                                 const fcl::CollisionRequest<S>&,                  \
                                                 const NarrowPhaseOptions<S>&);                    \
  template void forEachPair(                                                                       \
      const std::vector<ObjectPair<S>>&,                                                           \
      const std::function<void(std::size_t, fcl::CollisionObject<S>*, fcl::CollisionObject<S>*)>&, \
      int);

CUBE_INSTANTIATE_NARROW_PHASE(double)
CUBE_INSTANTIATE_NARROW_PHASE(float)
#undef CUBE_INSTANTIATE_NARROW_PHASE

}  // namespace cube
