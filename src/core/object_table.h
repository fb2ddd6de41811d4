#pragma once

// The object table: one stable ObjectId per registered object, the map from the user's pointer
// to it, and what the core keeps per object outside the walks (registration order, location).
// The object pointer itself lives only in its slot (Item::obj), found through the location: a
// second copy per id would cost 8 bytes an object that the walks never read.
// Ids are dense and reused through a free list (as Box2D's proxy ids): registering and
// unregistering are O(1), and nothing ever renumbers them, so the pair list and anything else
// keyed by id survives rebuilds and compactions of the cubes untouched.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry.h"
#include "core/pair_gate.h"
#include "core/volume.h"

namespace cube {
namespace detail {

/// Fewer objects than this do not rebuild an object's volumes when an update moves it: its record
/// is marked stale (isStale), the pipeline culls its pairs from the object, as for an object of
/// no table, and update() builds it again once it finds the object standing. A robot's links move
/// at every step, and rebuilding their records in each update() cost more than the cull saved (a
/// 30-link robot's update() grew more than its query shrank); a small world that stands keeps
/// its records, so that its queries read them.
inline constexpr std::size_t kVolumeRebuildMinObjects = 256;

/// Pointer maps of at least this many slots (a megabyte) are read ahead by a batch registration.
inline constexpr std::size_t kPrefetchMapSlots = std::size_t(1) << 18;

/// The map's hash of a pointer (a 64-bit finalizer: pointers differ mostly in middle bits).
inline std::size_t hashPointer(const void* p) {
  return hashKey(reinterpret_cast<std::uintptr_t>(p));
}

template <typename S>
class ObjectTable {
 public:
  using Object = fcl::CollisionObject<S>;

  /// The id of a registered object, or kNone. Never inserts.
  ObjectId find(const Object* obj) const;
  /// Registers `obj` (not registered yet): a fresh or recycled id, the next registration number.
  ObjectId add(Object* obj);
  /// Registers the entries of a batch (not null) that are neither registered nor repeated
  /// earlier in it, in batch order, the map sized once, and calls `added(i, id)` for each with
  /// its new id (nothing for the skipped ones). The caller places each id before the next
  /// operation on the table. A call that returns false undoes the batch: every id it registered
  /// is forgotten and 0 is returned. Otherwise returns the number registered. Inline, with the
  /// caller's `added` inlined too: a build of a few dozen objects is a few microseconds, and a
  /// call per entry or an array of ids handed back showed in it.
  template <class Added>
  std::size_t addBatch(Object* const* objs, std::size_t n, Added&& added);
  /// Forgets a registered id, `obj` its object; it will be handed out again.
  void remove(ObjectId id, const Object* obj);
  /// Forgets everything (keeps no memory).
  void clear();

  /// Registered objects.
  std::size_t size() const { return live_; }
  /// Names where the slots live that locations point into (the core's cubes and unbounded list):
  /// object() reads them. The arrays must outlive the table.
  void attach(const ItemArray<S>* cubes, const ItemArray<S>* unbounded) {
    cubes_ = cubes;
    unbounded_ = unbounded;
  }
  /// One past the largest id ever handed out since the last clear(): the length of per-id arrays.
  std::size_t idBound() const { return seq_.size(); }
  /// Whether an id below idBound() is registered.
  bool live(ObjectId id) const { return seq_[id] != kNone; }
  /// The object of a live, placed id, read from its slot.
  Object* object(ObjectId id) const { return slotOf(loc_[id]).obj; }
  /// Registration order: a later registration has a larger number.
  std::uint32_t seq(ObjectId id) const { return seq_[id]; }
  const std::uint32_t* seqs() const { return seq_.data(); }
  /// Where the object is: its slot in the cubes, or its place in the unbounded list or'ed with
  /// kUnboundedBit. Kept by the core as the cubes move their slots.
  std::uint32_t location(ObjectId id) const { return loc_[id]; }
  void setLocation(ObjectId id, std::uint32_t loc) { loc_[id] = loc; }
  std::uint32_t* locations() { return loc_.data(); }
  const std::uint32_t* locations() const { return loc_.data(); }

  /// Filter bits of a live id (the default Filter from registration until set).
  Filter filter(ObjectId id) const { return filter_.empty() ? Filter{} : filter_[id]; }
  /// Sets an id's bits; returns whether its filter group changed. O(groups), at most 254. The
  /// first non-default bits since clear() allocate the per-id filters and groups.
  bool setFilter(ObjectId id, const Filter& f);
  /// Per id; null while every object has had the default bits since clear() (queries then skip
  /// the test).
  const Filter* filters() const { return filter_.empty() ? nullptr : filter_.data(); }
  /// Per id: its filter group (objects with equal bits share one; group 0 is the default bits),
  /// or kMixedGroup if all 254 groups were taken when it got its bits. Null with filters().
  const Group* groups() const { return group_.empty() ? nullptr : group_.data(); }
  /// Per group: its bits. Null with filters().
  const Filter* groupFilters() const {
    return group_filter_.empty() ? nullptr : group_filter_.data();
  }
  /// Whether the live objects' groups are worth separating in the cubes: at most `limit` groups
  /// are in use, none is kMixedGroup, and some two of them (or one with itself) cannot pair.
  bool separable(int limit) const;
  /// An object's own margin, or a negative value while it uses the manager-wide one.
  S ownMargin(ObjectId id) const { return margin_.empty() ? S(-1) : margin_[id]; }
  /// Sets it; the first call since clear() allocates the per-id margins.
  void setOwnMargin(ObjectId id, S margin);
  /// Excludes the pair of live ids a != b (on), or admits it again; returns whether it changed.
  /// O(1) on average; the first exclusion since none allocates the set and a count per id up to
  /// the larger of the two. A removed id's pairs are dropped with it (O(excluded pairs)).
  bool exclude(ObjectId a, ObjectId b, bool on);
  /// Whether a rule read by id when pairs are reported is set (filter bits, excluded pairs):
  /// queries build a gate only then.
  bool pairRules() const { return !filter_.empty() || excluded_ != 0; }
  /// The excluded pairs for the gate; null while none is (queries then skip the test).
  const ExcludedSet* exclusions() const { return excluded_ == 0 ? nullptr : &excluded_set_; }
  /// Whether the pair of ids a and b is excluded (false for kNone or a free id).
  bool excluded(ObjectId a, ObjectId b) const { return excluded_ != 0 && excluded_set_.has(a, b); }
  /// The excluded pairs, each (earlier registered, later registered), sorted by the
  /// registration numbers of the pair.
  void excludedPairs(std::vector<std::pair<ObjectId, ObjectId>>& out) const;

  /// Whether the table may keep the volumes below (Config::tight_volumes). Set before the
  /// first registration.
  void keepVolumes(bool on) { volumes_ = on; }
  /// Asks for the volumes below: from now until dropVolumes() or clear() they are kept (if
  /// keepVolumes), built here if they are not yet. The one const member that writes: the pipeline's
  /// queries, which take the manager as const, call it before they read spheres(); concurrent
  /// callers wait for the one that builds, and queries that never call it read nothing it writes.
  void wantVolumes() const;
  /// Stops keeping the volumes and frees them, until the next wantVolumes().
  void dropVolumes();
  /// Per id: the tight volumes of the object as of its registration or its last refresh
  /// (refreshVolume), or a stale record (isStale: the object moved in a table below
  /// kVolumeRebuildMinObjects), for the cull; null while not kept. Entries of free ids are no
  /// one's.
  const VolumeSphere* spheres() const {
    return keeping_.load(std::memory_order_acquire) ? sphere_.data() : nullptr;
  }
  const VolumeShape* shapes() const {
    return keeping_.load(std::memory_order_acquire) ? shape_.data() : nullptr;
  }
  /// A live id's object `obj` changed in a way the caller does not know (update(obj) names it):
  /// its volumes rebuilt from its geometry and transform, or marked stale (a small table).
  void rebuildVolume(ObjectId id, const Object& obj) {
    if (!keeping_.load(std::memory_order_relaxed)) return;
    if (rebuildsOnMotion())
      rebuildNow(id, obj);
    else
      markStale(id);
  }
  /// Its object `obj` moved: its volumes placed anew for the transform (its geometry read again
  /// only if its local AABB changed), or marked stale (a small table).
  void moveVolume(ObjectId id, const Object& obj) {
    if (keeping_.load(std::memory_order_relaxed)) moveKept(id, obj);
  }
  /// Whether some live id's records are stale: update() asks once, before its loop (records
  /// that go stale in the loop are of objects it has passed), and calls refreshStaleVolume
  /// instead of refreshVolume if so.
  bool anyStale() const { return stale_ != 0; }
  /// Its object's box stands (update() calls it for every such object): its volumes placed anew
  /// if its transform changed since (a rotation may leave FCL's box as it was). No record of the
  /// table is stale.
  void refreshVolume(ObjectId id, const Object& obj) {
    if (keeping_.load(std::memory_order_relaxed))
      detail::refreshVolume(obj, source_[id], sphere_[id], shape_[id]);
  }
  /// The same, and built again if they are stale.
  void refreshStaleVolume(ObjectId id, const Object& obj) {
    if (!keeping_.load(std::memory_order_relaxed)) return;
    if (isStale(sphere_[id]))
      rebuildStale(id, obj);
    else
      detail::refreshVolume(obj, source_[id], sphere_[id], shape_[id]);
  }

  /// Registered objects in registration order.
  void objects(std::vector<Object*>& out) const;
  /// Heap bytes owned.
  std::size_t bytes() const;
  /// Of which the pointer map's.
  std::size_t mapBytes() const { return index_.capacity() * sizeof(std::uint32_t); }
  /// Checks the map, the free list, the registration numbers, the filter groups and the
  /// excluded pairs (each of two live ids, found where it lies, counted per id); on failure says
  /// why.
  bool validate(std::string* why) const;

 private:
  std::uint32_t nextSeq() {
    if (__builtin_expect(next_seq_ == kNone, 0)) renumber();
    return next_seq_++;
  }
  void renumber();
  bool rebuildsOnMotion() const { return live_ >= kVolumeRebuildMinObjects; }
  void rebuildNow(ObjectId id, const Object& obj) {
    stale_ -= isStale(sphere_[id]) ? 1 : 0;
    detail::rebuildVolume(obj, source_[id], sphere_[id], shape_[id]);
  }
  // Out of line: update()'s loop stays as small as it was without stale records.
  void rebuildStale(ObjectId id, const Object& obj);
  void moveKept(ObjectId id, const Object& obj);
  const Item<S>& slotOf(std::uint32_t loc) const {
    return (loc & kUnboundedBit) ? (*unbounded_)[loc & ~kUnboundedBit] : (*cubes_)[loc];
  }
  void markStale(ObjectId id) {
    stale_ += isStale(sphere_[id]) ? 0 : 1;
    sphere_[id].r = kStaleRadius;
  }
  void startKeeping();          // allocates and builds the volumes of every live id
  void reserve(std::size_t n);  // room for n more ids: the map and the per-id arrays
  // A fresh or recycled id for obj, not yet in the map. Inline: addBatch calls it per entry.
  ObjectId take(Object* obj);
  void put(ObjectId id, const Object* obj);
  void release(ObjectId id);  // remove() but the map
  // Sizes the map for `objects` live ids and puts them all (each placed: read from its slot).
  void grow(std::size_t objects);
  // Takes id (its object `obj`) out of the map; `key(other)` is the object of another id in it.
  template <class Key>
  void unmap(ObjectId id, const Object* obj, Key&& key);
  void leaveGroup(ObjectId id);
  Group joinGroup(const Filter& f);  // the group of bits f, made if new; counts one user
  void dropExcluded(ObjectId id);    // forgets every excluded pair of id
  void eraseExcluded(std::uint64_t key);
  void placeExcluded(std::uint64_t key);  // into the set, which has room
  void viewExcluded();                    // excluded_set_ from the arrays
  bool validateExcluded(std::string* why) const;

  const ItemArray<S>* cubes_ = nullptr;      // the slots locations point into (attach)
  const ItemArray<S>* unbounded_ = nullptr;  // those of locations with kUnboundedBit
  std::vector<std::uint32_t> seq_;           // per id: registration number; kNone: free
  std::vector<std::uint32_t> loc_;           // per id: location (see location())
  std::vector<VolumeSphere> sphere_;         // per id: the cull's volumes (see spheres())
  std::vector<VolumeShape> shape_;
  std::vector<VolumeSource> source_;  // per id: what its volumes were built from
  bool volumes_ = true;               // Config::tight_volumes
  // The three above are kept (else empty) from a query's wantVolumes() to the next drop, only
  // while volumes_. Atomic: wantVolumes() publishes them to concurrent queries.
  std::atomic<bool> keeping_{false};
  mutable std::mutex volume_build_;  // one wantVolumes() builds, the others wait
  std::size_t stale_ = 0;            // live ids whose records are stale (isStale)
  // The properties most managers never set are allocated by their first use (then kept until
  // clear()): 25 bytes per id that registration and memory would otherwise pay for nothing.
  std::vector<Filter> filter_;              // per id: filter bits; empty: all default
  std::vector<Group> group_;                // per id: filter group; empty with filter_
  std::vector<Filter> group_filter_;        // per group: its bits; empty with filter_
  std::vector<std::uint32_t> group_users_;  // per group: live ids in it (0: free, but group 0)
  std::size_t mixed_users_ = 0;             // live ids without a group
  std::vector<S> margin_;  // per id: own margin, < 0 for the manager-wide one; empty: all < 0
  // Excluded pairs, kept only while there are some: per id below its length, the pairs it is
  // in (ids beyond it are in none, so registration never touches it); the pairs' keys (pairKey)
  // in open addressing at most half full, kNoPair empty; their number; the gate's view of them.
  std::vector<std::uint32_t> excluded_count_;
  std::vector<std::uint64_t> excluded_keys_;
  std::size_t excluded_ = 0;
  ExcludedSet excluded_set_;
  std::vector<ObjectId> free_;  // ids to hand out again, last freed first
  // Open addressing with linear probing: 0 empty, else id + 1 (key: the id's object). Any length (a
  // pointer's first place is its hash scaled to the length, homeOf), so that a batch sizes it
  // to its load limit of 3/4 exactly: 5.3 bytes an object rather than up to twice that.
  std::vector<std::uint32_t> index_;
  std::size_t homeOf(const void* p) const {
    return std::size_t((unsigned __int128)hashPointer(p) * index_.size() >> 64);
  }
  std::size_t nextOf(std::size_t i) const { return i + 1 == index_.size() ? 0 : i + 1; }
  std::size_t live_ = 0;
  std::uint32_t next_seq_ = 0;
};

template <typename S>
inline ObjectId ObjectTable<S>::take(Object* obj) {
  const std::uint32_t seq = nextSeq();  // before obj is in: a renumbering counts live ids only
  ObjectId id;
  if (free_.empty()) {
    id = static_cast<ObjectId>(seq_.size());
    seq_.push_back(seq);
    loc_.push_back(kNone);
    if (keeping_.load(std::memory_order_relaxed)) {
      sphere_.emplace_back();
      shape_.emplace_back();
      source_.emplace_back();
    }
    if (!filter_.empty()) {
      filter_.emplace_back();
      group_.push_back(0);
    }
    if (!margin_.empty()) margin_.push_back(S(-1));
  } else {
    id = free_.back();
    free_.pop_back();
    seq_[id] = seq;
    loc_[id] = kNone;
    if (!filter_.empty()) {
      filter_[id] = Filter{};  // a recycled id keeps nothing of its last object
      group_[id] = 0;
    }
    if (!margin_.empty()) margin_[id] = S(-1);
  }
  if (!filter_.empty()) ++group_users_[0];
  ++live_;
  // Built whatever the table's size: a registration happens once, motion at every step.
  if (keeping_.load(std::memory_order_relaxed))
    detail::rebuildVolume(*obj, source_[id], sphere_[id], shape_[id]);
  return id;
}

template <typename S>
template <class Key>
void ObjectTable<S>::unmap(ObjectId id, const Object* obj, Key&& key) {
  // Backward-shift deletion keeps probe chains unbroken without tombstones.
  std::size_t hole = homeOf(obj);
  while (index_[hole] != id + 1) hole = nextOf(hole);
  for (std::size_t j = nextOf(hole); index_[j] != 0; j = nextOf(j)) {
    const std::size_t home = homeOf(key(index_[j] - 1));
    // The entry at j may fill the hole unless its home lies cyclically in (hole, j].
    const bool stays = hole <= j ? (home > hole && home <= j) : (home > hole || home <= j);
    if (!stays) {
      index_[hole] = index_[j];
      hole = j;
    }
  }
  index_[hole] = 0;
}

template <typename S>
template <class Added>
inline std::size_t ObjectTable<S>::addBatch(Object* const* objs, std::size_t n, Added&& added) {
  // Sized once for the whole batch; each pointer is then looked up and put with one probe
  // sequence, which also finds the batch's own repeats.
  reserve(n);
  // The batch's ids are not placed until it ends: their objects are read from `taken`, in the
  // order taken. The first `recycled` ids come from the free list (told by registration number,
  // first_seq and on: reserve() renumbered if the numbers would run out within the batch), the
  // rest are fresh, fresh_from and on (told by the id alone: a build's only kind).
  const std::uint32_t first_seq = next_seq_;
  const ObjectId fresh_from = ObjectId(seq_.size());
  const std::size_t recycled = std::min(free_.size(), n);
  // On the stack for small batches (one object at a time is common: Python's add_object).
  constexpr std::size_t kSmall = 16;
  Object* small[kSmall];
  ObjectId small_ids[kSmall];
  // Not value-initialised: every entry is written before it is read.
  const std::unique_ptr<Object*[]> large(n > kSmall ? new Object*[n] : nullptr);
  const std::unique_ptr<ObjectId[]> large_ids(recycled > kSmall ? new ObjectId[recycled] : nullptr);
  Object** const taken = n > kSmall ? large.get() : small;
  ObjectId* const recycled_ids = recycled > kSmall ? large_ids.get() : small_ids;
  std::size_t count = 0;
  // By value: the probe loop keeps them in registers across the stores of take().
  const auto key = [this, taken, fresh_from, recycled, first_seq](ObjectId id) -> const Object* {
    if (id >= fresh_from) return taken[recycled + (id - fresh_from)];
    const std::uint32_t s = seq_[id];
    return s >= first_seq ? taken[s - first_seq] : object(id);
  };
  // A pointer's first place is anywhere in the map: in a map larger than the caches, a miss per
  // object unless asked for a few objects ahead.
  constexpr std::size_t kAhead = 16;
  const std::size_t ahead = index_.size() >= kPrefetchMapSlots ? kAhead : 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i + ahead < n && ahead != 0) __builtin_prefetch(&index_[homeOf(objs[i + ahead])]);
    std::size_t h = homeOf(objs[i]);
    while (index_[h] != 0 && key(index_[h] - 1) != objs[i]) h = nextOf(h);
    if (index_[h] != 0) continue;  // registered already, or earlier in the batch
    const ObjectId id = take(objs[i]);
    if (count < recycled) recycled_ids[count] = id;
    taken[count++] = objs[i];
    index_[h] = id + 1;
    if (!added(i, id)) {
      // Last taken first: the ones left in the map are still found by `key`.
      while (count != 0) {
        --count;
        const ObjectId t = count < recycled ? recycled_ids[count] : fresh_from + (count - recycled);
        unmap(t, taken[count], key);
        release(t);
      }
      return 0;
    }
  }
  return count;
}

extern template class ObjectTable<float>;
extern template class ObjectTable<double>;

}  // namespace detail
}  // namespace cube
