#pragma once

// The narrow-phase cache's tables (NarrowPhaseCache<S>::Impl): the pose tracker (one version per
// object) and the answers by ordered pair (an array read in query order, an open-addressed index
// for the rest); docs/architecture.md, "The narrow-phase cache". Used by the streams and the
// pair-list entry points on the calling thread; cache.cpp holds NarrowPhaseCache's own members.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cube_collision/narrow_phase.h"
#include "pipeline/answers.h"

namespace cube {
namespace detail {

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

}  // namespace detail

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
      if (has_request && detail::sameRequest(request, r)) return;
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

namespace detail {

template <typename S>
using CollideCache = typename NarrowPhaseCache<S>::Impl;
template <typename S>
using CollideEntry = typename CollideCache<S>::template Entry<std::vector<fcl::Contact<S>>>;
template <typename S>
using DistanceEntry = typename CollideCache<S>::template Entry<fcl::DistanceResult<S>>;

// Keeps a new answer in the cache, a pair proved apart too, which next time costs a lookup
// rather than the test. Only once every cached answer in hand has been read: a store can move
// the entries.
template <typename S>
void storeAnswer(Answer kind, const ObjectPair<S>& pair, CollideCache<S>* cache,
                 const fcl::CollisionResult<S>& fresh) {
  if (cache == nullptr || kind == Answer::kCached) return;
  std::vector<fcl::Contact<S>> contacts(fresh.numContacts());
  for (std::size_t k = 0; k < contacts.size(); ++k) contacts[k] = fresh.getContact(k);
  cache->collide.store(*cache, pair.first, pair.second, std::move(contacts));
}

}  // namespace detail
}  // namespace cube
