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

#include "narrow_phase_stream.h"
#include "pipeline/cull.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/parallel_for.h"

namespace cube {

int hardwareThreads() {
  return std::max(1, omp_get_max_threads());
}

namespace {

using detail::resolveThreads;

// When threads pay. Work is counted in candidate pairs of shapes: the cull (about 0.1 us) and,
// for one pair in three or so, FCL's call (0.2-2 us): 0.25-0.5 us a pair here. A pair with a
// mesh or an octree counts kHeavyPairWork (its FCL call takes 10-100 us). Opening a two-thread
// region costs about 1 us while the other core idles and tens of us while it is busy, so a
// region is opened only for kParallelMinWork or more: 30-60 us of work.
constexpr std::size_t kHeavyPairWork = 64;
constexpr std::size_t kParallelMinWork = 128;
// A collide stream answers pairs at once on the calling thread until it has seen kSerialWork of
// work (every candidate pair counts 1, an FCL call on a mesh or an octree kHeavyPairWork more),
// then gathers chunks of kFirstChunkWork, doubling up to kMaxChunkWork. Chunks cost more per
// pair than answering at once (a result per pair, the contacts copied in the merge): a self-
// collide of 1,000 uniform objects (800 pairs) took 137 us on one thread and 177 us on two when
// it left after 8 FCL calls. Queries below kSerialWork (most object queries, robot checks, small
// scenes of shapes) never open a region. Pairs culled on the object tables' records (about 20
// ns a pair, on this thread) count only what an FCL call on a mesh or an octree weighs beyond
// 1: threads share FCL's calls only, and for shapes (0.2 us a call in the clustered
// 10,000-object scene) a chunk's bookkeeping cost more than the second thread saved (41 ms
// on one thread, 47 on two), so queries of shapes stay on the calling thread.
constexpr std::size_t kSerialWork = 1024;
constexpr std::size_t kFirstChunkWork = 256;
constexpr std::size_t kMaxChunkWork = 4096;
// forEachPair runs a caller's function of unknown cost: threads from this many pairs on.
constexpr std::size_t kParallelMinPairs = 4;

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
  out->proved += s.proved;
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
  // Per object: the pose of its cached answers, compared with the object once per query (not
  // once per pair: an object of a clustered scene is in ten pairs or more), and a version that
  // changes with it. Answers record the versions they were computed at. Nodes of an
  // unordered_map keep their address, so entries point at them.
  struct Seen {
    Pose pose;
    std::uint32_t version = 0;
    std::uint64_t checked = 0;  // the query that last compared the pose
    std::size_t users = 0;      // entries pointing here, in both tables
  };
  std::unordered_map<const Object*, Seen> seen;
  std::uint64_t stamp = 0;

  // Brings `s` up to date with `o`, comparing at most once per query.
  void check(Seen& s, const Object& o) {
    if (s.checked == stamp) return;
    s.checked = stamp;
    if (s.pose.same(o)) return;
    s.pose = Pose(o);
    ++s.version;
  }
  Seen& seenOf(const Object& o) {
    const auto it = seen.find(&o);
    if (it != seen.end()) {
      check(it->second, o);
      return it->second;
    }
    Seen& s = seen.emplace(&o, Seen{Pose(o)}).first->second;
    s.checked = stamp;
    return s;
  }
  void release(Seen* s, const Object* o) {
    if (--s->users == 0) seen.erase(o);
  }

  struct Key {
    const Object* a = nullptr;  // null: an empty cell
    const Object* b = nullptr;
    bool operator==(const Key& o) const { return a == o.a && b == o.b; }
    std::size_t hash() const {  // splitmix64's finalizer: pointers' low bits are all zero
      std::uint64_t h = reinterpret_cast<std::uintptr_t>(a) * 0x9E3779B97F4A7C15ull ^
                        reinterpret_cast<std::uintptr_t>(b);
      h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
      h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
      return static_cast<std::size_t>(h ^ (h >> 31));
    }
  };
  template <class Answer>
  struct Entry {
    Seen* a = nullptr;
    Seen* b = nullptr;
    std::uint32_t version_a = 0, version_b = 0;
    Answer answer{};
    std::uint64_t stamp = 0;
  };
  // Answers by ordered pair. The entries sit in one array in the order the last query that
  // reordered them met them, and a lookup first tries the entry after the last one found: a
  // world that barely changed meets its pairs in the same order, so the entries are read in
  // sequence rather than at random (a large scene's entries are far beyond the caches). Other
  // lookups go through an open-addressed index (linear probing, at most half full). Entries
  // move when the array grows or is reordered: callers read what find() returned before they
  // store.
  template <class Answer, class Request>
  struct Table {
    struct Item {
      Key key;
      Entry<Answer> entry;
      std::uint32_t seq = 0;  // when this query met it (valid if entry.stamp is this query's)
    };
    static constexpr std::uint32_t kFree = ~std::uint32_t(0);
    std::vector<Item> items;
    std::vector<std::uint32_t> index;  // item numbers; empty, or a power of two long
    std::size_t cursor = 0;            // the item the next lookup tries first
    Key last_key;                      // the last pair looked up through the index, and where
    std::size_t last = kFree;          // it was (kFree: absent)
    std::size_t used = 0;              // entries this query found or stored
    std::size_t jumps = 0;             // lookups this query that did not find the pair at cursor
    Request request;
    bool has_request = false;

    std::size_t size() const { return items.size(); }
    // Starts a query: answers to another request are dropped.
    void begin(Impl& c, const Request& r) {
      used = jumps = cursor = 0;
      if (has_request && sameRequest(request, r)) return;
      dropIf(c, [](const Key&, const Entry<Answer>&) { return true; });
      request = r;
      has_request = true;
    }
    // On the calling thread only (it compares and updates the objects' poses).
    Entry<Answer>* find(Impl& c, const Object* a, const Object* b) {
      const std::size_t i = lookup(Key{a, b});
      if (i == kFree) return nullptr;
      Item& item = items[i];
      Entry<Answer>& e = item.entry;
      c.check(*e.a, *a);
      c.check(*e.b, *b);
      if (e.a->version != e.version_a || e.b->version != e.version_b) return nullptr;
      meet(c, item);
      return &e;
    }
    void store(Impl& c, const Object* a, const Object* b, Answer answer) {
      Seen& sa = c.seenOf(*a);
      Seen& sb = c.seenOf(*b);
      const Key k{a, b};
      std::size_t i = lookup(k);
      last_key = Key{};
      if (i == kFree) {
        i = items.size();
        items.push_back(Item{k, {}, 0});
        if (2 * items.size() > index.size())
          reindex(std::max<std::size_t>(64, 2 * index.size()));
        else
          place(i);
        ++sa.users;
        ++sb.users;
      }
      Item& item = items[i];
      item.entry =
          Entry<Answer>{&sa, &sb, sa.version, sb.version, std::move(answer), item.entry.stamp};
      meet(c, item);
    }
    // Ends a query. Entries it did not use stay (a pair apart for a step is often back the next)
    // until they outnumber those it used: the cache holds at most about twice one query's pairs.
    // When many lookups missed the cursor, the entries are put in this query's order.
    void end(Impl& c) {
      const std::uint64_t now = c.stamp;
      if (items.size() > 2 * used + 64)
        dropIf(c, [now](const Key&, const Entry<Answer>& e) { return e.stamp != now; });
      if (jumps <= used / 8 + 16) return;
      std::vector<Item> ordered(items.size());
      std::size_t rest = used;  // entries this query did not meet go after those it did
      for (Item& item : items)
        ordered[item.entry.stamp == now ? item.seq : rest++] = std::move(item);
      items = std::move(ordered);
      reindex(index.size());
    }
    template <class Drop>
    void dropIf(Impl& c, const Drop& drop) {
      std::size_t kept = 0;
      for (Item& item : items) {
        if (drop(item.key, item.entry)) {
          c.release(item.entry.a, item.key.a);
          c.release(item.entry.b, item.key.b);
          continue;
        }
        if (&items[kept] != &item) items[kept] = std::move(item);
        ++kept;
      }
      items.resize(kept);
      std::size_t cap = 64;
      while (cap < 2 * kept) cap *= 2;
      reindex(kept == 0 ? 0 : cap);
    }
    void clear() {
      items.clear();
      index.clear();
      cursor = 0;
      last_key = Key{};
    }

   private:
    std::size_t mask() const { return index.size() - 1; }
    void meet(Impl& c, Item& item) {
      if (item.entry.stamp == c.stamp) return;
      item.entry.stamp = c.stamp;
      item.seq = static_cast<std::uint32_t>(used++);
    }
    std::size_t lookup(const Key& k) {
      // The pair at the cursor, or the one after it (the pair at the cursor left the query).
      for (std::size_t at = cursor; at < items.size() && at < cursor + 2; ++at)
        if (items[at].key == k) {
          cursor = at + 1;
          return at;
        }
      if (last_key == k) return last;  // store() after find() of a pair not in cache
      last_key = k;
      last = probe(k);
      return last;
    }
    std::size_t probe(const Key& k) {
      if (index.empty()) return kFree;
      ++jumps;
      for (std::size_t i = k.hash() & mask();; i = (i + 1) & mask()) {
        const std::uint32_t at = index[i];
        if (at == kFree) return kFree;
        if (items[at].key == k) {
          cursor = std::size_t(at) + 1;
          return at;
        }
      }
    }
    void place(std::size_t item) {
      std::size_t i = items[item].key.hash() & mask();
      while (index[i] != kFree) i = (i + 1) & mask();
      index[i] = static_cast<std::uint32_t>(item);
    }
    void reindex(std::size_t cap) {
      last_key = Key{};
      index.assign(cap, kFree);
      for (std::size_t i = 0; i < items.size(); ++i) place(i);
    }
  };

  Table<std::vector<fcl::Contact<S>>, fcl::CollisionRequest<S>> collide;
  // The pair that gave the first contact of the last collide with contacts (last_hit_first).
  ObjectPair<S> last_hit{nullptr, nullptr};
  Table<fcl::DistanceResult<S>, fcl::DistanceRequest<S>> distance;

  void forget(const Object* o) {
    const auto involves = [o](const Key& k, const auto&) { return k.a == o || k.b == o; };
    collide.dropIf(*this, involves);
    distance.dropIf(*this, involves);
  }
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
  impl_->collide.clear();
  impl_->distance.clear();
  impl_->seen.clear();
  impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
void NarrowPhaseCache<S>::forget(const fcl::CollisionObject<S>* obj) {
  impl_->forget(obj);
  if (impl_->last_hit.first == obj || impl_->last_hit.second == obj)
    impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
std::size_t NarrowPhaseCache<S>::size() const {
  return impl_->collide.size() + impl_->distance.size();
}

namespace detail {

// ---------------------------------------------------------------------------------------------
// Collision

namespace {

template <typename S>
using CollideCache = typename NarrowPhaseCache<S>::Impl;
template <typename S>
using CollideEntry = typename CollideCache<S>::template Entry<std::vector<fcl::Contact<S>>>;
template <typename S>
using DistanceEntry = typename CollideCache<S>::template Entry<fcl::DistanceResult<S>>;

// A verdict of the tight volumes as an answer: kComputed for a pair FCL must answer.
inline Answer answerOf(Verdict v) {
  switch (v) {
    case Verdict::kApart:
      return Answer::kApart;
    case Verdict::kTouching:
      return Answer::kProved;
    case Verdict::kUnknown:
      break;
  }
  return Answer::kComputed;
}

// The tight volumes' verdict from the two objects. Safe on several threads at once.
template <typename S>
Answer judge(const fcl::CollisionRequest<S>& request, const fcl::CollisionObject<S>* a,
             const fcl::CollisionObject<S>* b) {
  if (!plainRequest(request)) return Answer::kComputed;
  return answerOf(verdict(*a, *b, S(request.gjk_tolerance), provable(request)));
}

// The cache, then the tight volumes: kCached with the entry, or judge's verdict. On the calling
// thread (a lookup compares and updates the objects' poses).
template <typename S>
Answer classify(CollideCache<S>* cache, const fcl::CollisionRequest<S>& request,
                fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, CollideEntry<S>*& cached) {
  cached = cache != nullptr ? cache->collide.find(*cache, a, b) : nullptr;
  if (cached != nullptr) return Answer::kCached;
  return judge(request, a, b);
}

// The one contact FCL's shape collision gives a touching pair when the request asks for no
// contact geometry (position, normal and depth left as FCL leaves them: unset).
template <typename S>
fcl::Contact<S> provedContact(const ObjectPair<S>& pair) {
  return fcl::Contact<S>(pair.first->collisionGeometry().get(),
                         pair.second->collisionGeometry().get(), fcl::Contact<S>::NONE,
                         fcl::Contact<S>::NONE);
}

// Counts one answer of a kind.
inline void count(NarrowPhaseStats& stats, Answer kind) {
  switch (kind) {
    case Answer::kApart:
      ++stats.culled;
      return;
    case Answer::kProved:
      ++stats.proved;
      return;
    case Answer::kCached:
      ++stats.cached;
      return;
    case Answer::kComputed:
      ++stats.narrow_calls;
      return;
  }
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

// Keeps a new answer in the cache, a pair proved apart too, which next time costs a lookup
// rather than the test. Only once every cached answer in hand has been read: a store can move
// the entries.
template <typename S>
void keepPair(Answer kind, const ObjectPair<S>& pair, CollideCache<S>* cache,
              const fcl::CollisionResult<S>& fresh) {
  if (cache == nullptr || kind == Answer::kCached) return;
  std::vector<fcl::Contact<S>> contacts(fresh.numContacts());
  for (std::size_t k = 0; k < contacts.size(); ++k) contacts[k] = fresh.getContact(k);
  cache->collide.store(*cache, pair.first, pair.second, std::move(contacts));
}

// What a pair handed to the threads costs, in kParallelMinWork's unit (a candidate pair of
// shapes): a pair with a mesh or an octree counts kHeavyPairWork.
template <typename S>
std::size_t workOf(const ObjectPair<S>& pair) {
  const auto heavy = [](const fcl::CollisionObject<S>* o) {
    const fcl::OBJECT_TYPE t = o->getObjectType();
    return t == fcl::OT_BVH || t == fcl::OT_OCTREE;
  };
  return heavy(pair.first) || heavy(pair.second) ? kHeavyPairWork : 1;
}

}  // namespace

template <typename S>
struct CollideStream<S>::Slot {
  Answer kind = Answer::kApart;
  bool judged = false;  // kind is the cull's already (pairs with volumes)
  CollideEntry<S>* cached = nullptr;
  fcl::CollisionResult<S> fresh;
};

// Whether a pair's answer goes to the cache: not one the volumes gave, which they give again
// next time for less than a lookup costs.
template <typename S>
bool CollideStream<S>::kept(const Slot& s) {
  return !(s.judged && (s.kind == Answer::kApart || s.kind == Answer::kProved));
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
      rate_(volumeMarginRate(S(request.gjk_tolerance))),
      plain_(plainRequest(request)),
      prove_(provable(request)) {
  if (cache_ != nullptr) {
    ++cache_->stamp;
    cache_->collide.begin(*cache_, request);
  }
}

template <typename S>
CollideStream<S>::~CollideStream() = default;

template <typename S>
bool CollideStream<S>::push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  return pushJudged(a, b, nullptr, nullptr);
}

template <typename S>
bool CollideStream<S>::push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                            ObjectId ib) {
  if (done_) return true;
  if (!plain_) return pushJudged(a, b, nullptr, nullptr);
  Volumes va, vb;
  if (!volumes_.of(a, ia, b, ib, va.sphere, va.shape, vb.sphere, vb.shape))
    return pushJudged(a, b, nullptr, nullptr);
  return pushJudged(a, b, &va, &vb);
}

template <typename S>
bool CollideStream<S>::pushJudged(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b,
                                  const Volumes* va, const Volumes* vb) {
  if (done_) return true;
  ++stats_.candidate_pairs;
  // With volumes the cull runs here, before the cache (it costs less than a lookup).
  const auto cull = [&] {
    return answerOf(verdictOf(*va->sphere, *va->shape, *vb->sphere, *vb->shape, rate_, prove_));
  };
  if (serial_) {
    // Work that threads could share: with the cull on records it runs here, at about 20 ns a
    // pair, and only FCL's calls on meshes or octrees weigh enough (see kSerialWork).
    if (va == nullptr) ++serial_work_;
    CollideEntry<S>* cached = nullptr;
    Answer kind;
    if (va == nullptr) {
      kind = classify(cache_, request_, a, b, cached);
    } else {
      kind = cull();
      if (kind == Answer::kComputed && cache_ != nullptr) {
        cached = cache_->collide.find(*cache_, a, b);
        if (cached != nullptr) kind = Answer::kCached;
      }
    }
    if (cache_ == nullptr) {
      answerNow(a, b, kind);
    } else {
      scratch_->kind = kind;
      scratch_->judged = va != nullptr;
      scratch_->cached = cached;
      answerNow(ObjectPair<S>(a, b), *scratch_);
    }
    // A request that may stop at its first contact stays on this thread: a chunk would call FCL
    // for pairs after the stop. Others go to the threads once the query proves large.
    if (threads_ > 1 && request_.num_max_contacts > 1 && serial_work_ >= kSerialWork)
      serial_ = false;
    return done_;
  }
  // In chunks: the cache is looked up here (and the cull on volumes runs here), the rest of the
  // cull and FCL run in the chunk, on the threads.
  const Answer judged = va != nullptr ? cull() : Answer::kComputed;
  // Proved apart by the volumes: nothing to merge, nothing to store, so no place in a chunk.
  if (judged == Answer::kApart) {
    count(stats_, judged);
    return done_;
  }
  const std::size_t i = chunk_.size();
  chunk_.emplace_back(a, b);
  if (slots_.size() <= i) slots_.resize(i + 1);
  Slot& s = slots_[i];
  s.judged = va != nullptr;
  s.kind = judged;
  s.cached = cache_ != nullptr && s.kind == Answer::kComputed ? cache_->collide.find(*cache_, a, b)
                                                              : nullptr;
  if (s.cached != nullptr) s.kind = Answer::kCached;
  if (s.kind == Answer::kProved) {
    s.fresh.clear();
    s.fresh.addContact(provedContact(chunk_[i]));
  }
  if (s.kind == Answer::kComputed) {
    pending_.push_back(i);
    pending_work_ += workOf(chunk_[i]);
  }
  // A cached answer is merged at once while nothing waits before it, so that a full result
  // stops the walk where it would on one thread.
  if (pending_.empty() || pending_work_ >= chunk_work_) flush();
  return done_;
}

template <typename S>
ObjectPair<S> CollideStream<S>::lastHit(NarrowPhaseCache<S>& cache) {
  return cache.impl().last_hit;
}

template <typename S>
bool CollideStream<S>::pushAlone(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (done_) return true;
  const bool was_serial = serial_;
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
    if (result_.numContacts() < request_.num_max_contacts)
      result_.addContact(provedContact(ObjectPair<S>(a, b)));
    markDone();
    return;
  }
  // FCL's own way, one accumulating result: FCL decides which contacts fit.
  fclCollide(a, b, request_, result_);
  markDone();
  if (threads_ > 1) serial_work_ += workOf(ObjectPair<S>(a, b)) - 1;  // one thread never leaves
}

template <typename S>
void CollideStream<S>::answerNow(const ObjectPair<S>& pair, Slot& s) {
  count(stats_, s.kind);
  switch (s.kind) {
    case Answer::kCached:
      merge(pair, s);
      return;
    case Answer::kApart:
      if (kept(s)) keepPair(s.kind, pair, cache_, empty_);
      return;
    case Answer::kProved:
      s.fresh.clear();
      s.fresh.addContact(provedContact(pair));
      merge(pair, s);
      if (kept(s)) keepPair(s.kind, pair, cache_, s.fresh);
      return;
    case Answer::kComputed:
      s.fresh.clear();
      fclCollide(pair.first, pair.second, request_, s.fresh);
      merge(pair, s);
      keepPair(s.kind, pair, cache_, s.fresh);
      if (threads_ > 1) serial_work_ += workOf(pair) - 1;
      return;
  }
}

template <typename S>
void CollideStream<S>::merge(const ObjectPair<S>& pair, const Slot& s) {
  const Contacts<S> contacts = s.kind == Answer::kCached ? Contacts<S>{&s.cached->answer, nullptr}
                                                         : Contacts<S>{nullptr, &s.fresh};
  if (done_ || contacts.size() == 0) return;
  const std::size_t max_contacts = request_.num_max_contacts;
  const std::size_t room = max_contacts - std::min(max_contacts, result_.numContacts());
  if (cache_ != nullptr && result_.numContacts() == 0) cache_->last_hit = pair;
  if (contacts.size() > room) {
    // The budget runs out inside this pair. FCL's shape pairs then keep their deepest contacts,
    // not their first: its own call on the accumulating result decides, as on one thread.
    ++stats_.narrow_calls;
    fclCollide(pair.first, pair.second, request_, result_);
  } else {
    for (std::size_t k = 0; k < contacts.size(); ++k) result_.addContact(contacts[k]);
  }
  markDone();
}

template <typename S>
void CollideStream<S>::markDone() {
  if (result_.isCollision() && result_.numContacts() >= request_.num_max_contacts) done_ = true;
}

template <typename S>
void CollideStream<S>::flush() {
  const std::size_t n = chunk_.size();
  if (n == 0) return;
  if (!done_) {
    const auto run = [&](std::size_t k) {
      Slot& s = slots_[pending_[k]];
      const ObjectPair<S>& pair = chunk_[pending_[k]];
      if (!s.judged) s.kind = judge(request_, pair.first, pair.second);
      s.fresh.clear();
      if (s.kind == Answer::kProved) s.fresh.addContact(provedContact(pair));
      if (s.kind == Answer::kComputed) fclCollide(pair.first, pair.second, request_, s.fresh);
    };
    // Threads only for work that pays for waking them (a region costs about 1 us here when
    // the other core is idle, tens of us when it is busy).
    detail::parallelFor(pending_.size(), pending_work_ >= kParallelMinWork ? threads_ : 1, run);
    for (std::size_t i = 0; i < n; ++i) {
      Slot& s = slots_[i];
      count(stats_, s.kind);
      if (s.kind != Answer::kApart) merge(chunk_[i], s);
    }
    if (cache_ != nullptr)
      for (std::size_t i = 0; i < n; ++i)
        if (kept(slots_[i]))
          keepPair(slots_[i].kind, chunk_[i], cache_,
                   slots_[i].kind == Answer::kApart ? empty_ : slots_[i].fresh);
    if (!pending_.empty()) chunk_work_ = std::min(chunk_work_ * 2, kMaxChunkWork);
  }
  chunk_.clear();
  pending_.clear();
  pending_work_ = 0;
}

template <typename S>
fcl::CollisionResult<S> CollideStream<S>::finish() {
  flush();
  if (cache_ != nullptr) cache_->collide.end(*cache_);
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
      threads_(resolveThreads(options.threads)),
      rate_(volumeMarginRate(S(request.distance_tolerance))) {
  if (cache_ != nullptr) {
    ++cache_->stamp;
    cache_->distance.begin(*cache_, request);
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
    if (s.lower_bound - s.margin > result_.min_distance)
      ++stats_.culled;
    else
      answer(a, b);
  }
  dist = result_.min_distance;
  return dist <= 0;
}

template <typename S>
bool DistanceSearch<S>::push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                             ObjectId ib, S& dist) {
  const VolumeSphere *sa, *sb;
  const VolumeShape *ha, *hb;
  if (!volumes_.of(a, ia, b, ib, sa, ha, sb, hb)) return push(a, b, dist);
  ++stats_.candidate_pairs;
  if (result_.min_distance > 0) {
    const double best = double(result_.min_distance);
    const float enough =
        best >= double(FLT_MAX) ? std::numeric_limits<float>::infinity() : float(best);
    const VolumeGap g = separationOf(*sa, *ha, *sb, *hb, rate_, enough);
    if (double(g.lower_bound) - double(g.margin) > best)
      ++stats_.culled;
    else
      answer(a, b);
  }
  dist = result_.min_distance;
  return dist <= 0;
}

template <typename S>
void DistanceSearch<S>::answer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  if (cache_ == nullptr) {
    // FCL's own way, on this thread whatever the thread count: one accumulating result,
    // which a mesh pair's search is pruned by, and which lowers the walk's bound at once.
    // Batches on two threads made 100 distance queries among 1,000 meshes take 1.5-2x as long
    // (68% more FCL calls and 39% more candidate pairs, from the bounds a batch holds back).
    ++stats_.narrow_calls;
    fclDistance(a, b, request_, result_);
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
  detail::parallelFor(n, work >= kParallelMinWork ? threads_ : 1, [&](std::size_t i) {
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
      result_.update(s.cached->answer);
    } else {
      ++stats_.narrow_calls;
      result_.update(s.fresh);
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
  const int threads = work >= kParallelMinWork ? resolveThreads(options.threads) : 1;
  detail::parallelFor(rest.size(), threads, [&](std::size_t k) {
    const std::size_t i = rest[k];
    kind[i] = detail::judge(request, pairs[i].first, pairs[i].second);
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
    detail::keepPair(kind[i], pairs[i], cache, results[i]);
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
  detail::parallelFor(pairs.size(), pairs.size() >= kParallelMinPairs ? resolveThreads(threads) : 1,
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
