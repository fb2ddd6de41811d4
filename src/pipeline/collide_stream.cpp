// The collide stream (collide_stream.h): answered at once on the calling thread while the query
// is small, then in chunks on the threads; the cache looked up and stored on the calling thread.

#include "pipeline/collide_stream.h"

#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "core/parallel_for.h"
#include "pipeline/answers.h"
#include "pipeline/cache.h"
#include "pipeline/cull.h"
#include "pipeline/fcl_narrow.h"

namespace cube {
namespace detail {

namespace {

// A collide stream answers pairs at once on the calling thread until it has seen kSerialWork of
// work (every candidate pair counts 1, an FCL call on a mesh or an octree kHeavyPairWork more),
// then sizes its team (regionTeam, once) and, with more than one thread, gathers chunks of
// kFirstChunkWork, doubling up to kMaxChunkWork (thread_policy.h sets them). Queries below
// kSerialWork (most object queries, robot checks, small scenes of shapes) never open a region.
// Pairs culled on the object tables' records (about 20 ns a pair, on this thread) count only
// what their FCL call weighs beyond 1, read from the records' kinds (workOf(flags)): threads
// share FCL's calls only, so closed-form shape pairs stay on the calling thread.
// A chunk's pairs are answered in blocks of kBlock (CollideStream::cullBlock), reading the first
// kObjectLines cache lines of an object (its geometry pointer and pose: the first 160 of 224 bytes
// for double) and kGeometryLines of a geometry (120 bytes of base, then the shape's fields).
constexpr std::size_t kBlock = 16;
// Pairs answered at once go in blocks too (answerSerialBlock) among this many objects or more,
// whose records, objects and geometries (about 500 bytes an object) outgrow this machine's 1 MB
// L2: among 1,000 thin boxes, all in cache, the blocks' bookkeeping made a self-collide 1.15x
// slower.
constexpr std::size_t kBlockMinObjects = 4096;
constexpr std::size_t kObjectLines = 3;
constexpr std::size_t kGeometryLines = 3;

// The cache, then the tight volumes: kCached with the entry, or judge's verdict. On the calling
// thread (a lookup compares and updates the objects' poses).
template <typename S>
Answer classify(CollideCache<S>* cache, const fcl::CollisionRequest<S>& request,
                fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, CollideEntry<S>*& cached) {
  cached = cache != nullptr ? cache->collide.find(*cache, a, b) : nullptr;
  if (cached != nullptr) return Answer::kCached;
  return judge(request, a, b);
}

// A pair's contacts: the run [first, first + n) of a cached answer's list or of a result (a
// pair's own, or a task's for all its pairs; FCL gives no const view of a result's list).
template <typename S>
struct Contacts {
  const std::vector<fcl::Contact<S>>* list;
  const fcl::CollisionResult<S>* result;
  std::size_t first, n;

  std::size_t size() const { return n; }
  const fcl::Contact<S>& operator[](std::size_t k) const {
    return list ? (*list)[first + k] : result->getContact(first + k);
  }
};

// 0, 1, ..., kBlock - 1: the index of a block answered in place.
constexpr std::array<std::size_t, kBlock> kInPlace = [] {
  std::array<std::size_t, kBlock> a{};
  for (std::size_t k = 0; k < kBlock; ++k) a[k] = k;
  return a;
}();

}  // namespace

// A split walk's task, answered on its thread: its counts, and the pairs that gave contacts with
// their contacts, in walk order, all in one result (FCL writes each pair's into it directly).
template <typename S>
struct CollideStream<S>::TaskAnswers {
  struct Hit {
    ObjectPair<S> pair;
    std::size_t first, count;  // in result
  };
  NarrowPhaseStats stats;
  std::vector<Hit> hits;
  fcl::CollisionResult<S> result;
};

template <typename S>
struct CollideStream<S>::Slot {
  Answer kind = Answer::kApart;
  bool judged = false;    // kind is the cull's already (pairs with volumes)
  bool refined = false;   // and from its tight part, after the cache missed: stored like FCL's
  bool deferred = false;  // the cull on va, vb runs in the block (a split walk's task)
  CollideEntry<S>* cached = nullptr;
  Volumes va, vb;
  fcl::CollisionResult<S> fresh;
};

// A worker's block of a task: its pairs and their slots, kept from task to task (a slot's result
// keeps its list's memory).
template <typename S>
struct CollideStream<S>::TaskScratch {
  std::array<ObjectPair<S>, kBlock> block;
  std::array<Slot, kBlock> slots;
};

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
      colliding_(options.colliding),
      cache_(options.cache != nullptr && plainRequest(request) ? &options.cache->impl() : nullptr),
      threads_(resolveThreads(options.threads)),
      chunk_work_(kFirstChunkWork),
      scratch_(cache_ != nullptr ? std::make_unique<Slot>() : nullptr),
      rate_(volumeMarginRate(S(request.gjk_tolerance))),
      plain_(plainRequest(request)),
      prove_(provable(request)) {
  if (cache_ != nullptr) {
    ++cache_->stamp;
    cache_->collide.begin(*cache_, request);
  }
  if (colliding_ != nullptr) colliding_->clear();
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
  if (done_) return true;
  if (!plain_) return pushJudged(a, b, nullptr, nullptr, false);
  Volumes va, vb;
  if (!volumes_.of(a, ia, b, ib, va.sphere, va.shape, vb.sphere, vb.shape))
    return pushJudged(a, b, nullptr, nullptr, false);
  // Records of the tables stay put for the query; those built for an object of no table are
  // rebuilt for the next such object: only the former wait in a block.
  return pushJudged(a, b, &va, &vb, ia != kNone && ib != kNone);
}

template <typename S>
bool CollideStream<S>::pushJudged(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                  const Volumes* va, const Volumes* vb, bool kept) {
  if (done_) return true;
  ++stats_.candidate_pairs;
  // With volumes the cull runs here, before the cache (its cheaper part costs less than a lookup).
  const auto cull = [&] {
    return answerOf(verdictOf(*va->sphere, *va->shape, *vb->sphere, *vb->shape, rate_, prove_));
  };
  // With a cache: the cheaper part of the cull, the lookup, and the rest only for a pair the cache
  // does not hold (then kept with the cache's answers: it costs more than a lookup). A motion loop
  // of 1,000 clustered shapes took 1.19x the time with the whole cull before each lookup.
  const auto loose = [&] {
    return answerOf(
        looseVerdictOf(*va->sphere, *va->shape, *vb->sphere, *vb->shape, rate_, prove_));
  };
  const auto tight = [&] {
    return answerOf(
        tightVerdictOf(*va->sphere, *va->shape, *vb->sphere, *vb->shape, rate_, prove_));
  };
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
      return done_;
    }
    // What waits in the block goes first.
    if (serial_n_ != 0) {
      answerSerialBlock();
      if (done_) {
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
      kind = classify(cache_, request_, a, b, cached);
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
    if (threads_ > 1 && request_.num_max_contacts > 1 && serial_work_ >= kSerialWork) leaveSerial();
    return done_;
  }
  // In chunks: the cache is looked up here (and the cull on volumes runs here: a pair it proves
  // apart takes no place in the chunk), the rest of the cull and FCL run in the chunk, on the
  // threads. (Culling in the chunk instead made a clustered self-collide of 1,000 shapes 1.07x
  // slower: every culled pair then paid a slot and the merge.)
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
    return done_;
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
  return done_;
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
    if (done_) {
      stats_.candidate_pairs -= n - k;  // the walk would have stopped before these
      return;
    }
    const Slot& s = b.slots[k];
    if (threads_ > 1 && s.kind == Answer::kComputed)
      serial_work_ += workOf(s.va.shape->flags, s.vb.shape->flags) - 1;
    answerNow(b.block[k].first, b.block[k].second, s.kind);
  }
  // A request that may stop at its first contact stays on this thread (see pushJudged).
  if (threads_ > 1 && request_.num_max_contacts > 1 && serial_work_ >= kSerialWork) leaveSerial();
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
  if (done_) return true;
  const bool was_serial = serial_;
  answerSerialBlock();
  flush();
  serial_ = true;
  push(a, b);
  serial_ = was_serial;
  return done_;
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
  if (kind == Answer::kProved) {
    // What FCL's shape collision adds: one contact if the result has room.
    if (result_.numContacts() < request_.num_max_contacts) {
      result_.addContact(provedContact(ObjectPair<S>(a, b)));
      if (colliding_ != nullptr) colliding_->emplace_back(a, b);
    }
    markDone();
    return;
  }
  // FCL's own way, one accumulating result: FCL decides which contacts fit.
  const std::size_t before = result_.numContacts();
  fclCollide(a, b, request_, result_);
  noteColliding(ObjectPair<S>(a, b), before);
  markDone();
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
  if (s.kind == Answer::kCached)
    mergeContacts(pair, Contacts<S>{&s.cached->answer, nullptr, 0, s.cached->answer.size()});
  else
    mergeContacts(pair, Contacts<S>{nullptr, &s.fresh, 0, s.fresh.numContacts()});
}

template <typename S>
template <class C>
void CollideStream<S>::mergeContacts(const ObjectPair<S>& pair, const C& contacts) {
  if (done_ || contacts.size() == 0) return;
  const std::size_t max_contacts = request_.num_max_contacts;
  const std::size_t room = max_contacts - std::min(max_contacts, result_.numContacts());
  if (cache_ != nullptr && result_.numContacts() == 0) cache_->last_hit = pair;
  const std::size_t before = result_.numContacts();
  if (contacts.size() > room) {
    // The budget runs out inside this pair. FCL's shape pairs then keep their deepest contacts,
    // not their first: its own call on the accumulating result decides, as on one thread.
    ++stats_.narrow_calls;
    fclCollide(pair.first, pair.second, request_, result_);
  } else {
    for (std::size_t k = 0; k < contacts.size(); ++k) result_.addContact(contacts[k]);
  }
  noteColliding(pair, before);
  markDone();
}

template <typename S>
void CollideStream<S>::markDone() {
  if (result_.isCollision() && result_.numContacts() >= request_.num_max_contacts) done_ = true;
}

// A block of pairs (pairs[index[k]], k < n): the cull, then the memory FCL reads first for the
// pairs it leaves. Each step first asks for the memory it reads for the whole block (the records;
// then the objects, then their geometries), so that the cache misses of a block overlap instead
// of each pair waiting on its own: the first touch of an object and of its geometry was a third of
// FCL's time in a large self-collide of shapes (10,000 objects, whose records and objects lie in
// registration order, not in the walk's).
template <typename S>
void CollideStream<S>::cullBlock(const std::size_t* index, std::size_t n,
                                 const ObjectPair<S>* pairs, Slot* slots) const {
  const auto fetch = [](const void* p, std::size_t lines) {
    for (std::size_t l = 0; l < lines; ++l)
      __builtin_prefetch(static_cast<const char*>(p) + 64 * l);
  };
  for (std::size_t k = 0; k < n; ++k) {
    const Slot& s = slots[index[k]];
    if (!s.deferred) continue;
    fetch(s.va.sphere, 1);
    fetch(s.va.shape, 1);
    fetch(s.vb.sphere, 1);
    fetch(s.vb.shape, 1);
  }
  for (std::size_t k = 0; k < n; ++k) {
    Slot& s = slots[index[k]];
    const ObjectPair<S>& pair = pairs[index[k]];
    if (s.deferred)
      s.kind =
          answerOf(verdictOf(*s.va.sphere, *s.va.shape, *s.vb.sphere, *s.vb.shape, rate_, prove_));
    else if (!s.judged)
      s.kind = judge(request_, pair.first, pair.second);
    if (s.kind == Answer::kComputed) {
      fetch(pair.first, kObjectLines);
      fetch(pair.second, kObjectLines);
    }
  }
  for (std::size_t k = 0; k < n; ++k)
    if (slots[index[k]].kind == Answer::kComputed) {
      const ObjectPair<S>& pair = pairs[index[k]];
      fetch(pair.first->collisionGeometry().get(), kGeometryLines);
      fetch(pair.second->collisionGeometry().get(), kGeometryLines);
    }
}

template <typename S>
void CollideStream<S>::flush() {
  const std::size_t n = chunk_.size();
  if (n == 0) return;
  if (!done_) {
    // Threads only for work that pays for waking them (thread_policy.h).
    const int threads = pending_work_ >= kParallelMinWork ? threads_ : 1;
    // Blocks of pending pairs, whose memory is fetched together (cullBlock), but at least 8
    // a thread: a chunk of 64 mesh pairs in 4 blocks of 16 left a thread idle (1,000 meshes on
    // two threads, 1.17x the time of pairs handed out one by one).
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
bool CollideStream<S>::takesTasks() const {
  return plain_ && cache_ == nullptr && threads_ > 1 && request_.num_max_contacts > 1 &&
         stats_.candidate_pairs == 0;
}

namespace {
constexpr std::size_t kRunning = std::numeric_limits<std::size_t>::max();
}  // namespace

template <typename S>
void CollideStream<S>::begin(std::size_t tasks, int workers) {
  tasks_.clear();
  tasks_.resize(tasks);
  if (workers_.size() < std::size_t(workers)) workers_.resize(std::size_t(workers));
  task_contacts_ = std::make_unique<std::atomic<std::size_t>[]>(tasks);
  for (std::size_t i = 0; i < tasks; ++i) task_contacts_[i].store(kRunning);
  task_found_.store(0);
  const std::size_t max_contacts = request_.num_max_contacts;
  task_budget_ = max_contacts - std::min(max_contacts, result_.numContacts());
}

template <typename S>
void CollideStream<S>::take(int worker, std::size_t task, const typename TaskSink<S>::Pair* pairs,
                            std::size_t n) {
  // Full before this task? Only once the tasks run so far hold the budget at all (a sum over
  // every task, one load), then over those before this one: the merge adds contacts in order
  // until the budget, so those before it fill the result whatever the others hold.
  const std::size_t budget = task_budget_;
  if (task_found_.load(std::memory_order_relaxed) >= budget) {
    std::size_t before = 0;
    for (std::size_t j = 0; j < task; ++j) {
      const std::size_t c = task_contacts_[j].load(std::memory_order_acquire);
      if (c != kRunning && (before += c) >= budget) return;
    }
  }
  TaskAnswers& out = tasks_[task];
  out.stats.candidate_pairs += n;
  std::array<ObjectPair<S>, kBlock>& block = workers_[std::size_t(worker)].block;
  std::array<Slot, kBlock>& slots = workers_[std::size_t(worker)].slots;
  fcl::CollisionRequest<S> request = request_;
  for (std::size_t first = 0; first < n; first += kBlock) {
    const std::size_t m = std::min(kBlock, n - first);
    for (std::size_t k = 0; k < m; ++k) {
      const typename TaskSink<S>::Pair& p = pairs[first + k];
      block[k] = ObjectPair<S>(p.a, p.b);
      Slot& s = slots[k];
      s.kind = Answer::kComputed;
      s.judged = false;
      s.refined = false;
      s.deferred = volumes_.ofTables(p.ia, p.ib, s.va.sphere, s.va.shape, s.vb.sphere, s.vb.shape);
    }
    cullBlock(kInPlace.data(), m, block.data(), slots.data());
    for (std::size_t k = 0; k < m; ++k) {
      const Slot& s = slots[k];
      const ObjectPair<S>& pair = block[k];
      count(out.stats, s.kind);
      if (s.kind == Answer::kApart) continue;
      // Into the task's result, with room for the pair's whole budget after what it holds, as
      // a fresh result of its own would have: the same contacts, copied once less.
      const std::size_t before = out.result.numContacts();
      if (s.kind == Answer::kProved) {
        out.result.addContact(provedContact(pair));
      } else {
        request.num_max_contacts =
            before + std::min(request_.num_max_contacts, kRunning - 1 - before);
        fclCollide(pair.first, pair.second, request, out.result);
      }
      const std::size_t added = out.result.numContacts() - before;
      if (added > 0) out.hits.push_back({pair, before, added});
    }
  }
  task_contacts_[task].store(out.result.numContacts(), std::memory_order_release);
  task_found_.fetch_add(out.result.numContacts(), std::memory_order_relaxed);
}

template <typename S>
bool CollideStream<S>::drain(std::size_t task) {
  TaskAnswers& t = tasks_[task];
  addStats(&stats_, t.stats);
  for (const typename TaskAnswers::Hit& h : t.hits)
    mergeContacts(h.pair, Contacts<S>{nullptr, &t.result, h.first, h.count});
  t = TaskAnswers{};
  return done_;
}

template <typename S>
fcl::CollisionResult<S> CollideStream<S>::finish() {
  answerSerialBlock();
  flush();
  if (cache_ != nullptr) cache_->collide.end(*cache_);
  addStats(stats_out_, stats_);
  return std::move(result_);
}

template class CollideStream<double>;
template class CollideStream<float>;

}  // namespace detail
}  // namespace cube
