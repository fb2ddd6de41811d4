// The narrow-phase pipeline: cull, cache, run on threads, merge in pair order.

#include "cube_collision/narrow_phase.h"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <exception>
#include <iterator>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "cull.h"
#include "fcl_narrow.h"
#include "narrow_phase_stream.h"

namespace cube {

int hardwareThreads() {
  return std::max(1, omp_get_max_threads());
}

namespace {

int resolveThreads(int threads) {
  return threads > 0 ? threads : hardwareThreads();
}

// Below this many pairs a parallel region costs more than it saves.
constexpr std::size_t kParallelMinPairs = 4;

// Runs body(i) for every i in [0, n) on `threads` threads. An exception stops nothing: the
// first one by index is rethrown once every call has run.
template <class Body>
void parallelFor(std::size_t n, int threads, const Body& body) {
  std::vector<std::exception_ptr> errors;
  const auto guarded = [&](std::size_t i) {
    try {
      body(i);
    } catch (...) {
#pragma omp critical(cube_parallel_for_errors)
      {
        if (errors.empty()) errors.resize(n);
        errors[i] = std::current_exception();
      }
    }
  };
  if (threads <= 1 || n < kParallelMinPairs) {
    for (std::size_t i = 0; i < n; ++i) guarded(i);
  } else {
    // Dynamic chunks of 2: narrow-phase costs differ by orders of magnitude between pairs.
#pragma omp parallel for schedule(dynamic, 2) num_threads(threads)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
      guarded(static_cast<std::size_t>(i));
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

// A pair list from the caller: a null object would crash inside FCL, so it is refused first.
template <typename S>
void checkPairs(const std::vector<ObjectPair<S>>& pairs, const char* where) {
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (pairs[i].first == nullptr || pairs[i].second == nullptr)
      throw std::invalid_argument(std::string("cube::") + where + ": pair " + std::to_string(i) +
                                  " holds a null object");
}

void addStats(NarrowPhaseStats* out, const NarrowPhaseStats& s) {
  if (out == nullptr) return;
  out->candidate_pairs += s.candidate_pairs;
  out->culled += s.culled;
  out->cached += s.cached;
  out->narrow_calls += s.narrow_calls;
}

template <typename S>
bool sameRequest(const fcl::CollisionRequest<S>& a, const fcl::CollisionRequest<S>& b) {
  return a.num_max_contacts == b.num_max_contacts && a.enable_contact == b.enable_contact &&
         a.gjk_solver_type == b.gjk_solver_type && a.gjk_tolerance == b.gjk_tolerance;
}

template <typename S>
bool sameRequest(const fcl::DistanceRequest<S>& a, const fcl::DistanceRequest<S>& b) {
  return a.enable_nearest_points == b.enable_nearest_points &&
         a.enable_signed_distance == b.enable_signed_distance && a.rel_err == b.rel_err &&
         a.abs_err == b.abs_err && a.distance_tolerance == b.distance_tolerance &&
         a.gjk_solver_type == b.gjk_solver_type;
}

// Culling and caching leave requests with costs or a cached GJK guess alone: an octree's cost
// sources come from cells its box does not bound, and a guess is carried from pair to pair.
template <typename S>
bool plainRequest(const fcl::CollisionRequest<S>& request) {
  return !request.enable_cost && !request.enable_cached_gjk_guess;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The cache

template <typename S>
struct NarrowPhaseCache<S>::Impl {
  using Object = fcl::CollisionObject<S>;

  // What an answer depends on besides the request: where the object is and what it is.
  struct Pose {
    fcl::Transform3<S> tf;
    const fcl::CollisionGeometry<S>* geometry;
    fcl::AABB<S> local;

    explicit Pose(const Object& o)
        : tf(o.getTransform()),
          geometry(o.collisionGeometry().get()),
          local(geometry ? geometry->aabb_local : fcl::AABB<S>()) {}
    bool same(const Object& o) const {
      const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
      // Bit for bit: an answer is reused only for exactly the input it was computed from.
      return g == geometry &&
             std::memcmp(tf.matrix().data(), o.getTransform().matrix().data(), sizeof(S) * 16) ==
                 0 &&
             std::memcmp(local.min_.data(), g->aabb_local.min_.data(), sizeof(S) * 3) == 0 &&
             std::memcmp(local.max_.data(), g->aabb_local.max_.data(), sizeof(S) * 3) == 0;
    }
  };
  struct Key {
    const Object* a;
    const Object* b;
    bool operator==(const Key& o) const { return a == o.a && b == o.b; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      const auto x = reinterpret_cast<std::uintptr_t>(k.a);
      const auto y = reinterpret_cast<std::uintptr_t>(k.b);
      return std::hash<std::uintptr_t>()(x * 0x9E3779B97F4A7C15ull ^ (y + (x >> 7)));
    }
  };
  template <class Answer>
  struct Entry {
    Pose a, b;
    Answer answer;
    std::uint64_t stamp;
  };
  template <class Answer, class Request>
  struct Table {
    std::unordered_map<Key, Entry<Answer>, KeyHash> entries;
    Request request;
    bool has_request = false;

    // Starts a query: answers to another request are dropped.
    void begin(const Request& r) {
      if (has_request && sameRequest(request, r)) return;
      entries.clear();
      request = r;
      has_request = true;
    }
    // Reads only (the caller touches the entry later, on one thread): safe from several
    // threads while nothing is stored.
    Entry<Answer>* find(const Object* a, const Object* b) {
      const auto it = entries.find(Key{a, b});
      if (it == entries.end() || !it->second.a.same(*a) || !it->second.b.same(*b)) return nullptr;
      return &it->second;
    }
    void store(const Object* a, const Object* b, const Answer& answer, std::uint64_t stamp) {
      entries.insert_or_assign(Key{a, b}, Entry<Answer>{Pose(*a), Pose(*b), answer, stamp});
    }
    // Ends a query: what it did not use goes.
    void end(std::uint64_t stamp) {
      for (auto it = entries.begin(); it != entries.end();)
        it = it->second.stamp == stamp ? std::next(it) : entries.erase(it);
    }
    void forget(const Object* o) {
      for (auto it = entries.begin(); it != entries.end();)
        it = it->first.a == o || it->first.b == o ? entries.erase(it) : std::next(it);
    }
  };

  Table<std::vector<fcl::Contact<S>>, fcl::CollisionRequest<S>> collide;
  // The pair that gave the first contact of the last collide with contacts (last_hit_first).
  ObjectPair<S> last_hit{nullptr, nullptr};
  Table<fcl::DistanceResult<S>, fcl::DistanceRequest<S>> distance;
  std::uint64_t stamp = 0;
};

template <typename S>
NarrowPhaseCache<S>::NarrowPhaseCache() : impl_(std::make_unique<Impl>()) {}
template <typename S>
NarrowPhaseCache<S>::~NarrowPhaseCache() = default;
template <typename S>
NarrowPhaseCache<S>::NarrowPhaseCache(NarrowPhaseCache&&) noexcept = default;
template <typename S>
NarrowPhaseCache<S>& NarrowPhaseCache<S>::operator=(NarrowPhaseCache&&) noexcept = default;

template <typename S>
void NarrowPhaseCache<S>::clear() {
  impl_->collide.entries.clear();
  impl_->distance.entries.clear();
  impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
void NarrowPhaseCache<S>::forget(const fcl::CollisionObject<S>* obj) {
  impl_->collide.forget(obj);
  impl_->distance.forget(obj);
  if (impl_->last_hit.first == obj || impl_->last_hit.second == obj)
    impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
std::size_t NarrowPhaseCache<S>::size() const {
  return impl_->collide.entries.size() + impl_->distance.entries.size();
}

namespace detail {

// ---------------------------------------------------------------------------------------------
// Collision

namespace {

enum class Answer : std::uint8_t { kApart, kCached, kComputed };

template <typename S>
using CollideCache = typename NarrowPhaseCache<S>::Impl;
template <typename S>
using CollideEntry = typename CollideCache<S>::template Entry<std::vector<fcl::Contact<S>>>;
template <typename S>
using DistanceEntry = typename CollideCache<S>::template Entry<fcl::DistanceResult<S>>;

// One pair's answer, safe to run on several threads at once: proved apart, found in the cache
// (`cached` is its entry), or computed by fcl::collide into `fresh` (cleared first).
template <typename S>
Answer answerPair(const ObjectPair<S>& pair, const fcl::CollisionRequest<S>& request,
                  CollideCache<S>* cache, fcl::CollisionResult<S>& fresh,
                  CollideEntry<S>*& cached) {
  const auto [a, b] = pair;
  fresh.clear();
  if (plainRequest(request) && surelyApart(*a, *b, S(request.gjk_tolerance))) return Answer::kApart;
  if ((cached = cache ? cache->collide.find(a, b) : nullptr) != nullptr) return Answer::kCached;
  fclCollide(a, b, request, fresh);
  return Answer::kComputed;
}

// A pair's contacts, in the cache or in a fresh result (FCL gives no const view of its list).
template <typename S>
struct Contacts {
  const std::vector<fcl::Contact<S>>* cached;
  const fcl::CollisionResult<S>* fresh;

  std::size_t size() const { return cached ? cached->size() : fresh->numContacts(); }
  const fcl::Contact<S>& operator[](std::size_t k) const {
    return cached ? (*cached)[k] : fresh->getContact(k);
  }
};

// After answerPair, on one thread, in pair order: counts the answer, keeps it in the cache and
// returns the pair's contacts.
template <typename S>
Contacts<S> recordPair(Answer kind, const ObjectPair<S>& pair, CollideCache<S>* cache,
                       const fcl::CollisionResult<S>& fresh, CollideEntry<S>* cached,
                       NarrowPhaseStats& stats) {
  const auto [a, b] = pair;
  if (kind == Answer::kCached) {
    ++stats.cached;
    cached->stamp = cache->stamp;
    return {&cached->answer, nullptr};
  }
  ++stats.narrow_calls;
  if (cache != nullptr) {
    std::vector<fcl::Contact<S>> contacts(fresh.numContacts());
    for (std::size_t k = 0; k < contacts.size(); ++k) contacts[k] = fresh.getContact(k);
    cache->collide.store(a, b, contacts, cache->stamp);
  }
  return {nullptr, &fresh};
}

}  // namespace

template <typename S>
struct CollideStream<S>::Slot {
  Answer kind = Answer::kApart;
  CollideEntry<S>* cached = nullptr;
  fcl::CollisionResult<S> fresh;
};

template <typename S>
CollideStream<S>::CollideStream(const fcl::CollisionRequest<S>& request,
                                const NarrowPhaseOptions<S>& options)
    : request_(request),
      stats_out_(options.stats),
      cache_(options.cache != nullptr && plainRequest(request) ? &options.cache->impl() : nullptr),
      threads_(resolveThreads(options.threads)),
      // A one-contact request most often stops early: a small first chunk wastes little, and on
      // one thread (nothing to share out) a chunk of one wastes nothing.
      chunk_limit_(request.num_max_contacts > 1 ? 64 : threads_ == 1 ? 1 : 8) {
  if (cache_ != nullptr) {
    cache_->collide.begin(request);
    ++cache_->stamp;
  }
}

template <typename S>
CollideStream<S>::~CollideStream() = default;

template <typename S>
bool CollideStream<S>::push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (done_) return true;
  chunk_.emplace_back(a, b);
  if (chunk_.size() >= chunk_limit_) {
    flush();
    if (threads_ > 1 || request_.num_max_contacts > 1)
      chunk_limit_ = std::min<std::size_t>(chunk_limit_ * 2, 1024);
  }
  return done_;
}

template <typename S>
ObjectPair<S> CollideStream<S>::lastHit(NarrowPhaseCache<S>& cache) {
  return cache.impl().last_hit;
}

template <typename S>
bool CollideStream<S>::pushAlone(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (done_) return true;
  chunk_.emplace_back(a, b);
  flush();
  return done_;
}

template <typename S>
bool CollideStream<S>::callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                void* stream) {
  return static_cast<CollideStream*>(stream)->push(a, b);
}

template <typename S>
void CollideStream<S>::flush() {
  const std::size_t n = chunk_.size();
  if (n == 0 || done_) {
    chunk_.clear();
    return;
  }
  stats_.candidate_pairs += n;
  if (slots_.size() < n) slots_.resize(n);
  parallelFor(n, threads_, [&](std::size_t i) {
    slots_[i].kind = answerPair(chunk_[i], request_, cache_, slots_[i].fresh, slots_[i].cached);
  });
  // Merge in pair order. A pair's contacts come in FCL's order and FCL stops adding once the
  // result is full, so a pair that meets a partly full result gives the head of its own list.
  const std::size_t max_contacts = request_.num_max_contacts;
  for (std::size_t i = 0; i < n; ++i) {
    Slot& s = slots_[i];
    if (s.kind == Answer::kApart) {
      ++stats_.culled;
      continue;
    }
    const Contacts<S> contacts = recordPair(s.kind, chunk_[i], cache_, s.fresh, s.cached, stats_);
    if (done_) continue;  // computed in the same chunk: kept for the cache, not merged
    const std::size_t room = max_contacts - std::min(max_contacts, result_.numContacts());
    const std::size_t take = std::min(room, contacts.size());
    if (cache_ != nullptr && take > 0 && result_.numContacts() == 0) cache_->last_hit = chunk_[i];
    for (std::size_t k = 0; k < take; ++k) result_.addContact(contacts[k]);
    if (result_.isCollision() && result_.numContacts() >= max_contacts) done_ = true;
  }
  chunk_.clear();
}

template <typename S>
fcl::CollisionResult<S> CollideStream<S>::finish() {
  flush();
  if (cache_ != nullptr) cache_->collide.end(cache_->stamp);
  addStats(stats_out_, stats_);
  return std::move(result_);
}

// ---------------------------------------------------------------------------------------------
// Distance

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
      threads_(resolveThreads(options.threads)) {
  if (cache_ != nullptr) {
    cache_->distance.begin(request);
    ++cache_->stamp;
  }
}

template <typename S>
DistanceSearch<S>::~DistanceSearch() = default;

template <typename S>
bool DistanceSearch<S>::push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, S& dist) {
  ++stats_.candidate_pairs;
  if (result_.min_distance > 0) {
    // A pair whose tight volumes are farther apart than the best distance so far (by more than
    // the margin) would get a larger distance from FCL, which leaves the result as it is.
    const Separation<S> s =
        separation(*a, *b, S(request_.distance_tolerance), result_.min_distance);
    if (s.lower_bound - s.margin > result_.min_distance) {
      ++stats_.culled;
    } else if (threads_ == 1 && cache_ == nullptr) {
      // FCL's own way: one accumulating result, which a mesh pair's search is pruned by.
      ++stats_.narrow_calls;
      fclDistance(a, b, request_, result_);
    } else {
      batch_.emplace_back(a, b);
      if (batch_.size() >= static_cast<std::size_t>(threads_)) flush();
    }
  }
  dist = result_.min_distance;
  return dist <= 0;
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
  parallelFor(n, threads_, [&](std::size_t i) {
    Slot& s = slots_[i];
    const auto [a, b] = batch_[i];
    s.cached = cache_ ? cache_->distance.find(a, b) : nullptr;
    if (s.cached == nullptr) {
      // A fresh result per pair: its answer does not depend on the other pairs, so it can be
      // kept and merged in any batch.
      s.fresh = fcl::DistanceResult<S>();
      fclDistance(a, b, request_, s.fresh);
    }
  });
  for (std::size_t i = 0; i < n; ++i) {
    Slot& s = slots_[i];
    const auto [a, b] = batch_[i];
    if (s.cached != nullptr) {
      ++stats_.cached;
      s.cached->stamp = cache_->stamp;
      result_.update(s.cached->answer);
    } else {
      ++stats_.narrow_calls;
      if (cache_ != nullptr) cache_->distance.store(a, b, s.fresh, cache_->stamp);
      result_.update(s.fresh);
    }
  }
  batch_.clear();
}

template <typename S>
fcl::DistanceResult<S> DistanceSearch<S>::finish() {
  flush();
  if (cache_ != nullptr) cache_->distance.end(cache_->stamp);
  addStats(stats_out_, stats_);
  return result_;
}

template class CollideStream<double>;
template class CollideStream<float>;
template class DistanceSearch<double>;
template class DistanceSearch<float>;

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Pair-list entry points

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
    cache->collide.begin(request);
    ++cache->stamp;
  }
  std::vector<fcl::CollisionResult<S>> results(pairs.size());
  std::vector<detail::Answer> kind(pairs.size());
  std::vector<detail::CollideEntry<S>*> cached(pairs.size());
  parallelFor(pairs.size(), resolveThreads(options.threads), [&](std::size_t i) {
    kind[i] = detail::answerPair(pairs[i], request, cache, results[i], cached[i]);
  });
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (kind[i] == detail::Answer::kApart) {
      ++stats.culled;
      continue;
    }
    detail::recordPair(kind[i], pairs[i], cache, results[i], cached[i], stats);
    if (kind[i] == detail::Answer::kCached)
      for (const fcl::Contact<S>& c : cached[i]->answer) results[i].addContact(c);
  }
  if (cache != nullptr) cache->collide.end(cache->stamp);
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
    NarrowPhaseStats stats;
    stats.candidate_pairs = pairs.size();
    for (const auto& [a, b] : pairs) {
      ++stats.narrow_calls;
      detail::fclCollide(a, b, request, result);
      if (!request.enable_cost && result.isCollision() &&
          result.numContacts() >= request.num_max_contacts)
        break;
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
  parallelFor(pairs.size(), resolveThreads(threads),
              [&](std::size_t i) { fn(i, pairs[i].first, pairs[i].second); });
}

#define CUBE_INSTANTIATE_NARROW_PHASE(S)                                                           \
  template class NarrowPhaseCache<S>;                                                              \
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
