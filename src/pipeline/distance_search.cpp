// The distance search (distance_search.h): FCL's own accumulating way without a cache; with one,
// batches of `threads` pairs not in it, on the threads when they pay.

#include "pipeline/distance_search.h"

#include <vector>

#include "core/parallel_for.h"
#include "pipeline/answers.h"
#include "pipeline/cache.h"
#include "pipeline/fcl_narrow.h"

namespace cube {
namespace detail {

template <typename S>
struct DistanceSearch<S>::Slot {
  DistanceEntry<S>* cached = nullptr;
  fcl::DistanceResult<S> fresh;
};

template <typename S>
DistanceSearch<S>::DistanceSearch(const fcl::DistanceRequest<S>& request,
                                  const NarrowPhaseOptions<S>& options)
    : request_(request),
      stats_out_(options.stats),
      cache_(options.cache != nullptr ? &options.cache->impl() : nullptr),
      threads_(resolveThreads(options.threads)),
      closest_(result_),
      judge_(request) {
  if (cache_ != nullptr) {
    ++cache_->stamp;
    cache_->distance.begin(*cache_, request);
  }
}

template <typename S>
DistanceSearch<S>::~DistanceSearch() = default;

template <typename S>
template <class MayBeat>
bool DistanceSearch<S>::offer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, S& dist,
                              MayBeat&& may_beat) {
  ++stats_.candidate_pairs;
  // A pair that cannot beat the best distance so far would leave the result as it is.
  if (closest_.bound() > 0) {
    if (may_beat(closest_.bound()))
      answer(a, b);
    else
      ++stats_.culled;
  }
  dist = closest_.bound();  // read once: dist may alias it
  return dist <= 0;
}

template <typename S>
bool DistanceSearch<S>::push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, S& dist) {
  return offer(a, b, dist, [&](S bound) { return judge_.mayBeat(*a, *b, bound); });
}

template <typename S>
bool DistanceSearch<S>::push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                             ObjectId ib, S& dist) {
  Records ra, rb;
  if (volumes_.of(a, ia, b, ib, ra.sphere, ra.shape, rb.sphere, rb.shape))
    return offer(a, b, dist, [&](S bound) { return judge_.mayBeat(ra, rb, bound); });
  // Without records: the objects' levels, kept for the pairs still to come, and built only for
  // a pair the search still judges.
  return offer(a, b, dist, [&](S bound) {
    FlyVolumes<S>*fa, *fb;
    volumes_.fly(a, ia, b, ib, fa, fb);
    return fa != nullptr ? judge_.mayBeat(*fa, *fb, bound) : judge_.mayBeat(*a, *b, bound);
  });
}

template <typename S>
void DistanceSearch<S>::answer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (cache_ == nullptr) {
    // FCL's own way, on this thread whatever the thread count: one accumulating result,
    // which a mesh pair's search is pruned by, and which lowers the walk's bound at once.
    // Batches on threads hold back the bound that prunes the walk and the meshes' searches:
    // more FCL calls and more candidate pairs, and more time in all.
    ++stats_.narrow_calls;
    closest_.collide(a, b, request_);
  } else {
    batch_.emplace_back(a, b);
    if (batch_.size() >= static_cast<std::size_t>(threads_)) flush();
  }
}

template <typename S>
bool DistanceSearch<S>::callbackWithIds(fcl::CollisionObject<S>* a, ObjectId ia,
                                        fcl::CollisionObject<S>* b, ObjectId ib, void* search,
                                        S& dist) {
  return static_cast<DistanceSearch*>(search)->push(a, ia, b, ib, dist);
}

template <typename S>
bool DistanceSearch<S>::callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                 void* search, S& dist) {
  return static_cast<DistanceSearch*>(search)->push(a, b, dist);
}

template <typename S>
void DistanceSearch<S>::flush() {
  const std::size_t n = batch_.size();
  if (n == 0) return;
  if (slots_.size() < n) slots_.resize(n);
  std::size_t work = 0;
  for (std::size_t i = 0; i < n; ++i) {  // on this thread: it compares and updates poses
    slots_[i].cached =
        cache_ ? cache_->distance.find(*cache_, batch_[i].first, batch_[i].second) : nullptr;
    if (slots_[i].cached == nullptr) work += workOf(batch_[i]);
  }
  // The team is sized at the first batch that pays for threads, once for the search.
  if (work >= kParallelMinWork && team_ == 0) team_ = regionTeam(threads_);
  detail::parallelFor(n, work >= kParallelMinWork ? team_ : 1, [&](std::size_t i) {
    Slot& s = slots_[i];
    const auto [a, b] = batch_[i];
    if (s.cached == nullptr) {
      // A fresh result per pair: its answer does not depend on the other pairs, so it can be
      // kept and merged in any batch.
      s.fresh = fcl::DistanceResult<S>();
      fclDistance(a, b, request_, s.fresh);
    }
  });
  for (std::size_t i = 0; i < n; ++i) {
    Slot& s = slots_[i];
    if (s.cached != nullptr) {
      ++stats_.cached;
      closest_.add(s.cached->answer);
    } else {
      ++stats_.narrow_calls;
      closest_.add(s.fresh);
    }
  }
  // After every cached answer was read: a store can move the entries.
  if (cache_ != nullptr)
    for (std::size_t i = 0; i < n; ++i)
      if (slots_[i].cached == nullptr)
        cache_->distance.store(*cache_, batch_[i].first, batch_[i].second, slots_[i].fresh);
  batch_.clear();
}

template <typename S>
fcl::DistanceResult<S> DistanceSearch<S>::finish() {
  flush();
  if (cache_ != nullptr) cache_->distance.end(*cache_);
  addStats(stats_out_, stats_);
  return result_;
}

template class DistanceSearch<double>;
template class DistanceSearch<float>;

}  // namespace detail
}  // namespace cube
