// The collide stream (collide_stream.h), its pairs pushed one by one: answered at once on the
// calling thread while the query is small, then in chunks on the threads; the cache looked up and
// stored on the calling thread. A split walk's tasks and the blocks' cull:
// collide_stream_tasks.cpp.

#include "pipeline/collide_stream.h"

#include <algorithm>
#include <memory>
#include <utility>
#include <vector>

#include "core/parallel_for.h"
#include "pipeline/answers.h"
#include "pipeline/cache.h"
#include "pipeline/collide_stream_parts.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"

namespace cube {
namespace detail {

namespace {

// A collide stream answers pairs at once on the calling thread until it has seen kSerialWork of
// work (every candidate pair counts 1, an FCL call on a mesh or an octree kHeavyPairWork more),
// and that work is at least 1/kMinCallShare of its candidate pairs (provedLarge), then sizes its
// team (regionTeam, once) and, with more than one thread, gathers chunks of
// kFirstChunkWork, doubling up to kMaxChunkWork (thread_policy.h sets them). Queries below
// kSerialWork (most object queries, robot checks, small scenes of shapes) never open a region.
// Pairs culled on the object tables' records (about 20 ns a pair, on this thread) count only
// what their FCL call weighs beyond 1, read from the records' kinds (workOf(flags)): threads
// share FCL's calls only, so closed-form shape pairs stay on the calling thread.
// Pairs answered at once go in blocks too (answerSerialBlock) among this many objects or more,
// whose records, objects and geometries (about 500 bytes an object) outgrow a 1 MB L2: below
// that, all in cache, the blocks' bookkeeping costs a self-collide more than it saves.
constexpr std::size_t kBlockMinObjects = 4096;

// The cache, then the judge on the objects: kCached with the entry, or the judge's answer. On
// the calling thread (a lookup compares and updates the objects' poses).
template <typename S>
Answer classify(CollideCache<S>* cache, const PairJudge<S>& judge, fcl::CollisionObject<S>* a,
                ObjectId ia, fcl::CollisionObject<S>* b, ObjectId ib, PairVolumes<S>* kept,
                CollideEntry<S>*& cached) {
  cached = cache != nullptr ? cache->collide.find(*cache, a, b) : nullptr;
  if (cached != nullptr) return Answer::kCached;
  // The kept levels only now: a pair the cache answers builds none.
  FlyVolumes<S>*fa = nullptr, *fb = nullptr;
  if (kept != nullptr) kept->fly(a, ia, b, ib, fa, fb);
  return fa != nullptr ? judge.collide(*fa, *fb) : judge.collide(*a, *b);
}

}  // namespace

// Whether a pair's answer goes to the cache: not one the cheaper part of the cull gave, which it
// gives again next time for less than a lookup costs.
template <typename S>
bool CollideStream<S>::cacheable(const Slot& s) {
  return s.refined || !(s.judged && (s.kind == Answer::kApart || s.kind == Answer::kProved));
}

template <typename S>
CollideStream<S>::CollideStream(const fcl::CollisionRequest<S>& request,
                                const NarrowPhaseOptions<S>& options)
    : request_(request),
      stats_out_(options.stats),
      cache_(options.cache != nullptr && plainRequest(request) ? &options.cache->impl() : nullptr),
      threads_(resolveThreads(options.threads)),
      chunk_work_(kFirstChunkWork),
      scratch_(cache_ != nullptr ? std::make_unique<Slot>() : nullptr),
      all_(request, result_, options.colliding),
      judge_(request) {
  if (cache_ != nullptr) {
    ++cache_->stamp;
    cache_->collide.begin(*cache_, request);
  }
}

template <typename S>
CollideStream<S>::~CollideStream() = default;

template <typename S>
bool CollideStream<S>::push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  return pushJudged(a, b, nullptr, nullptr, false);
}

template <typename S>
bool CollideStream<S>::push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                            ObjectId ib) {
  if (all_.full()) return true;
  if (!judge_.culls()) return pushJudged(a, b, nullptr, nullptr, false);
  Volumes va, vb;
  if (!volumes_.of(a, ia, b, ib, va.sphere, va.shape, vb.sphere, vb.shape)) {
    // A pair answered at once is culled on the objects' kept levels; one for the chunk, on the
    // threads, on its objects.
    return pushJudged(a, b, nullptr, nullptr, false, ia, ib, serial_);
  }
  // Records of the tables stay put for the query; those built for an object of no table are
  // rebuilt for the next such object: only the former wait in a block.
  return pushJudged(a, b, &va, &vb, ia != kNone && ib != kNone);
}

template <typename S>
bool CollideStream<S>::pushJudged(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                  const Volumes* va, const Volumes* vb, bool kept, ObjectId ia,
                                  ObjectId ib, bool fly) {
  if (all_.full()) return true;
  ++stats_.candidate_pairs;
  // With volumes the judge runs here, before the cache (its cheaper part costs less than a
  // lookup). With a cache: the cheaper part, the lookup, and the rest only for a pair the cache
  // does not hold (then kept with the cache's answers: it costs more than a lookup). The whole
  // cull before each lookup slowed motion loops of clustered shapes.
  const auto cull = [&] { return judge_.collide(*va, *vb); };
  const auto loose = [&] { return judge_.collideLoose(*va, *vb); };
  const auto tight = [&] { return judge_.collideTight(*va, *vb); };
  if (serial_) {
    if (kept && cache_ == nullptr && volumes_.objects() >= kBlockMinObjects) {
      // Answered in blocks (answerSerialBlock): the walk goes on for up to kBlock - 1 pairs
      // before it learns that the result is full, and those are then dropped, uncounted.
      if (!serial_block_) serial_block_ = std::make_unique<TaskScratch>();
      serial_block_->block[serial_n_] = ObjectPair<S>(a, b);
      Slot& s = serial_block_->slots[serial_n_];
      s.kind = Answer::kComputed;
      s.judged = false;
      s.refined = false;
      s.deferred = true;
      s.va = *va;
      s.vb = *vb;
      if (++serial_n_ == kBlock) answerSerialBlock();
      return all_.full();
    }
    // What waits in the block goes first.
    if (serial_n_ != 0) {
      answerSerialBlock();
      if (all_.full()) {
        --stats_.candidate_pairs;
        return true;
      }
    }
    // Work that threads could share: with the cull on records it runs here, at about 20 ns a
    // pair, and only FCL's calls on meshes, octrees and GJK pairs weigh enough (kSerialWork).
    if (va == nullptr) ++serial_work_;
    CollideEntry<S>* cached = nullptr;
    Answer kind;
    bool refined = false;
    if (va == nullptr) {
      kind = classify(cache_, judge_, a, ia, b, ib, fly ? &volumes_ : nullptr, cached);
    } else if (cache_ == nullptr) {
      kind = cull();
    } else {
      kind = loose();
      if (kind == Answer::kComputed) {
        cached = cache_->collide.find(*cache_, a, b);
        if (cached != nullptr) {
          kind = Answer::kCached;
        } else {
          kind = tight();
          refined = kind != Answer::kComputed;
        }
      }
    }
    // What an FCL call weighs beyond the 1 above (one thread never leaves): from the records if
    // the pair has them (no geometry touched here), else from the objects (the cull from the
    // objects has read them).
    if (threads_ > 1 && kind == Answer::kComputed)
      serial_work_ += (va != nullptr ? workOf(va->shape->flags, vb->shape->flags)
                                     : workOf(ObjectPair<S>(a, b))) -
                      1;
    if (cache_ == nullptr) {
      answerNow(a, b, kind);
    } else {
      scratch_->kind = kind;
      scratch_->judged = va != nullptr;
      scratch_->refined = refined;
      scratch_->cached = cached;
      answerNow(ObjectPair<S>(a, b), *scratch_);
    }
    // A request that may stop at its first contact stays on this thread: a chunk would call FCL
    // for pairs after the stop. Others go to the threads once the query proves large.
    if (provedLarge()) leaveSerial();
    return all_.full();
  }
  // In chunks: the cache is looked up here (and the cull on volumes runs here: a pair it proves
  // apart takes no place in the chunk), the rest of the cull and FCL run in the chunk, on the
  // threads. (Culling in the chunk instead slowed clustered self-collides: every culled pair
  // then paid a slot and the merge.)
  Answer judged = va == nullptr ? Answer::kComputed : cache_ != nullptr ? loose() : cull();
  CollideEntry<S>* cached = cache_ != nullptr && judged == Answer::kComputed
                                ? cache_->collide.find(*cache_, a, b)
                                : nullptr;
  bool refined = false;
  if (va != nullptr && cache_ != nullptr && judged == Answer::kComputed && cached == nullptr) {
    judged = tight();
    refined = judged != Answer::kComputed;
    if (judged == Answer::kApart) storeAnswer(judged, ObjectPair<S>(a, b), cache_, empty_);
  }
  // Proved apart by the volumes: nothing to merge, nothing more to store, so no place in a chunk.
  if (judged == Answer::kApart) {
    count(stats_, judged);
    return all_.full();
  }
  const std::size_t i = chunk_.size();
  chunk_.emplace_back(a, b);
  if (slots_.size() <= i) slots_.resize(i + 1);
  Slot& s = slots_[i];
  s.judged = va != nullptr;
  s.refined = refined;
  s.deferred = false;
  s.kind = judged;
  s.cached = cached;
  if (s.cached != nullptr) s.kind = Answer::kCached;
  if (s.kind == Answer::kProved) {
    s.fresh.clear();
    s.fresh.addContact(provedContact(chunk_[i]));
  }
  if (s.kind == Answer::kComputed) {
    pending_.push_back(i);
    pending_work_ += va != nullptr ? workOf(va->shape->flags, vb->shape->flags) : workOf(chunk_[i]);
  }
  // A cached answer is merged at once while nothing waits before it, so that a full result
  // stops the walk where it would on one thread.
  if (pending_.empty() || pending_work_ >= chunk_work_) flush();
  return all_.full();
}

// The pairs with records pushed on the calling thread without a cache, answered kBlock at a time
// as they came: the cull and the memory FCL reads first fetched for the whole block (cullBlock;
// the records', the objects' and the geometries' cache misses were a fifth of a self-collide of
// 10,000 primitives on one thread), then each pair answered at once, in order, until the result
// is full.
template <typename S>
void CollideStream<S>::answerSerialBlock() {
  const std::size_t n = serial_n_;
  if (n == 0) return;
  serial_n_ = 0;
  TaskScratch& b = *serial_block_;
  cullBlock(kInPlace.data(), n, b.block.data(), b.slots.data());
  for (std::size_t k = 0; k < n; ++k) {
    if (all_.full()) {
      stats_.candidate_pairs -= n - k;  // the walk would have stopped before these
      return;
    }
    const Slot& s = b.slots[k];
    if (threads_ > 1 && s.kind == Answer::kComputed)
      serial_work_ += workOf(s.va.shape->flags, s.vb.shape->flags) - 1;
    answerNow(b.block[k].first, b.block[k].second, s.kind);
  }
  // A request that may stop at its first contact stays on this thread (see pushJudged).
  if (provedLarge()) leaveSerial();
}

template <typename S>
bool CollideStream<S>::provedLarge() const {
  return threads_ > 1 && request_.num_max_contacts > 1 && serial_work_ >= kSerialWork &&
         serial_work_ * kMinCallShare >= stats_.candidate_pairs;
}

// The query proved large: chunks on the threads if the machine has room for them now, else the
// rest on this thread (threads_ 1 keeps it there).
template <typename S>
void CollideStream<S>::leaveSerial() {
  threads_ = regionTeam(threads_);
  serial_ = threads_ <= 1;
}

template <typename S>
ObjectPair<S> CollideStream<S>::lastHit(NarrowPhaseCache<S>& cache) {
  return cache.impl().last_hit;
}

template <typename S>
bool CollideStream<S>::pushAlone(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (all_.full()) return true;
  const bool was_serial = serial_;
  answerSerialBlock();
  flush();
  serial_ = true;
  push(a, b);
  serial_ = was_serial;
  return all_.full();
}

template <typename S>
bool CollideStream<S>::callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                void* stream) {
  return static_cast<CollideStream*>(stream)->push(a, b);
}

template <typename S>
bool CollideStream<S>::callbackWithIds(fcl::CollisionObject<S>* a, ObjectId ia,
                                       fcl::CollisionObject<S>* b, ObjectId ib, void* stream) {
  return static_cast<CollideStream*>(stream)->push(a, ia, b, ib);
}

template <typename S>
void CollideStream<S>::answerNow(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                 Answer kind) {
  count(stats_, kind);
  if (kind == Answer::kApart) return;
  // FCL's own way, one accumulating result: FCL decides which contacts fit.
  if (kind == Answer::kProved)
    all_.addProved(ObjectPair<S>(a, b));
  else
    all_.collide(ObjectPair<S>(a, b));
}

template <typename S>
void CollideStream<S>::answerNow(const ObjectPair<S>& pair, Slot& s) {
  count(stats_, s.kind);
  switch (s.kind) {
    case Answer::kCached:
      merge(pair, s);
      return;
    case Answer::kApart:
      if (cacheable(s)) storeAnswer(s.kind, pair, cache_, empty_);
      return;
    case Answer::kProved:
      s.fresh.clear();
      s.fresh.addContact(provedContact(pair));
      merge(pair, s);
      if (cacheable(s)) storeAnswer(s.kind, pair, cache_, s.fresh);
      return;
    case Answer::kComputed:
      s.fresh.clear();
      fclCollide(pair.first, pair.second, request_, s.fresh);
      merge(pair, s);
      storeAnswer(s.kind, pair, cache_, s.fresh);
      return;
  }
}

template <typename S>
void CollideStream<S>::merge(const ObjectPair<S>& pair, const Slot& s) {
  // Where the budget runs out inside the pair, the collector calls FCL on the merged result.
  const bool called =
      s.kind == Answer::kCached
          ? all_.add(pair, ContactRun<S>{&s.cached->answer, nullptr, 0, s.cached->answer.size()})
          : all_.add(pair, ContactRun<S>{nullptr, &s.fresh, 0, s.fresh.numContacts()});
  if (called) ++stats_.narrow_calls;
}

template <typename S>
void CollideStream<S>::flush() {
  const std::size_t n = chunk_.size();
  if (n == 0) return;
  if (!all_.full()) {
    // Threads only for work that pays for waking them (thread_policy.h).
    const int threads = pending_work_ >= kParallelMinWork ? threads_ : 1;
    // Blocks of pending pairs, whose memory is fetched together (cullBlock), but at least 8
    // a thread: a chunk of 64 mesh pairs in 4 blocks of 16 left a thread idle, slower than
    // pairs handed out one by one.
    const std::size_t n_pending = pending_.size();
    const std::size_t block =
        std::clamp<std::size_t>(n_pending / (8 * std::size_t(threads)), 1, kBlock);
    detail::parallelFor((n_pending + block - 1) / block, threads, [&](std::size_t k) {
      const std::size_t* index = pending_.data() + k * block;
      const std::size_t m = std::min(block, n_pending - k * block);
      cullBlock(index, m, chunk_.data(), slots_.data());
      for (std::size_t j = 0; j < m; ++j) {
        Slot& s = slots_[index[j]];
        const ObjectPair<S>& pair = chunk_[index[j]];
        if (s.kind == Answer::kApart) continue;
        s.fresh.clear();
        if (s.kind == Answer::kProved) s.fresh.addContact(provedContact(pair));
        if (s.kind == Answer::kComputed) fclCollide(pair.first, pair.second, request_, s.fresh);
      }
    });
    for (std::size_t i = 0; i < n; ++i) {
      Slot& s = slots_[i];
      count(stats_, s.kind);
      if (s.kind != Answer::kApart) merge(chunk_[i], s);
    }
    if (cache_ != nullptr)
      for (std::size_t i = 0; i < n; ++i)
        if (cacheable(slots_[i]))
          storeAnswer(slots_[i].kind, chunk_[i], cache_,
                      slots_[i].kind == Answer::kApart ? empty_ : slots_[i].fresh);
    if (!pending_.empty()) chunk_work_ = std::min(chunk_work_ * 2, kMaxChunkWork);
  }
  chunk_.clear();
  pending_.clear();
  pending_work_ = 0;
}

template <typename S>
fcl::CollisionResult<S> CollideStream<S>::finish() {
  answerSerialBlock();
  flush();
  if (cache_ != nullptr) {
    cache_->collide.end(*cache_);
    if (all_.firstHit().first != nullptr) cache_->last_hit = all_.firstHit();
  }
  addStats(stats_out_, stats_);
  return std::move(result_);
}

template class CollideStream<double>;
template class CollideStream<float>;

}  // namespace detail
}  // namespace cube
