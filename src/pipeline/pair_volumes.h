#pragma once

// Where the narrow-phase streams (collide_stream.h, distance_search.h) find the tight volumes of a
// pair's objects.

#include <cstdint>

#include "core/geometry.h"
#include "core/pair_gate.h"
#include "core/volume.h"
#include "cube_collision/narrow_phase.h"
#include "pipeline/cull.h"

namespace cube {
namespace detail {

/// Where a stream finds the volumes of a pair's objects: the object tables whose ids the walk
/// gives (side a, the first id; side b), and, for an object of no table (id kNone: the query
/// object, or the objects of another kind of manager, whose pairs come one object at a time),
/// volumes built during the query, the last one of each side kept.
template <typename S>
class PairVolumes {
 public:
  // User-provided, so that value-initialisation does not zero the two records of built_ or the
  // memo (about 8 KB, a `rep stos` on every query): each is written before it is read.
  PairVolumes() {}  // NOLINT(modernize-use-equals-default)
  /// The tables' records (ObjectTable::spheres(), shapes()); null: that table keeps none.
  /// `objects`: how many objects the tables hold together (a self query's once).
  void use(const VolumeSphere* spheres_a, const VolumeShape* shapes_a,
           const VolumeSphere* spheres_b, const VolumeShape* shapes_b, std::size_t objects) {
    spheres_[0] = spheres_a;
    shapes_[0] = shapes_a;
    spheres_[1] = spheres_b;
    shapes_[1] = shapes_b;
    objects_ = objects;
  }
  /// use()'s `objects` (0 before): whether the records and objects a query reads outgrow the
  /// caches, which makes fetching them ahead pay.
  std::size_t objects() const { return objects_; }
  /// The records of objects a (id ia) and b (id ib), into the four pointers; false if a table
  /// keeps none or a record is stale (an object that moved in a small table): the pair is culled
  /// from the objects.
  bool of(const fcl::CollisionObject<S>* a, ObjectId ia, const fcl::CollisionObject<S>* b,
          ObjectId ib, const VolumeSphere*& sa, const VolumeShape*& ha, const VolumeSphere*& sb,
          const VolumeShape*& hb) {
    return side(0, a, ia, sa, ha) && side(1, b, ib, sb, hb);
  }
  /// For a pair `of` gives no records: the two objects' records built on the fly (the sphere at
  /// once, the rest as a verdict reads it), kept in a small memo for the rest of the query (by id,
  /// else by address), so that an object met in several pairs is built once. Both null when the
  /// two would take the same place in the memo (then the judge builds them for the pair alone).
  /// The entries stay valid until the next call.
  void fly(const fcl::CollisionObject<S>* a, ObjectId ia, const fcl::CollisionObject<S>* b,
           ObjectId ib, FlyVolumes<S>*& fa, FlyVolumes<S>*& fb) {
    const std::size_t pa = flyPlace(a, ia), pb = flyPlace(b, ib);
    if (pa == pb) {
      fa = fb = nullptr;
      return;
    }
    if (!fly_ready_) {
      // Emptied on the query's first pair without records: queries that never have one pay
      // nothing, and the volumes need no clearing (an entry is built before it is read).
      for (auto& k : fly_.key) k = nullptr;
      fly_ready_ = true;
    }
    fa = &flyEntry(pa, a);
    fb = &flyEntry(pb, b);
  }
  /// The tables' records of ids ia and ib (neither kNone), as `of` gives them; false if a table
  /// keeps none. Reads only: any number of threads at once.
  bool ofTables(ObjectId ia, ObjectId ib, const VolumeSphere*& sa, const VolumeShape*& ha,
                const VolumeSphere*& sb, const VolumeShape*& hb) const {
    if (spheres_[0] == nullptr || spheres_[1] == nullptr) return false;
    sa = spheres_[0] + ia;
    ha = shapes_[0] + ia;
    sb = spheres_[1] + ib;
    hb = shapes_[1] + ib;
    return !isStale(*sa) && !isStale(*sb);
  }

 private:
  struct Built {
    const fcl::CollisionObject<S>* obj = nullptr;
    VolumeSphere sphere;
    VolumeShape shape;
  };
  bool side(int k, const fcl::CollisionObject<S>* o, ObjectId id, const VolumeSphere*& sphere,
            const VolumeShape*& shape) {
    if (id != kNone) {
      if (spheres_[k] == nullptr) return false;
      sphere = spheres_[k] + id;
      shape = shapes_[k] + id;
      return !isStale(*sphere);
    }
    Built& e = built_[k];
    if (e.obj != o) {
      buildVolume(*o, e.sphere, e.shape);
      e.obj = o;
    }
    sphere = &e.sphere;
    shape = &e.shape;
    return true;
  }

  // The memo of fly(): direct-mapped, an object's place its id (dense in small tables) or, for
  // an object of no table, its address, each modulo kFly.
  static constexpr std::size_t kFly = 64;
  struct FlyMemo {
    const fcl::CollisionObject<S>* key[kFly];
    FlyVolumes<S> volumes[kFly];
  };
  static std::size_t flyPlace(const fcl::CollisionObject<S>* o, ObjectId id) {
    return (id != kNone ? std::size_t(id) : hashKey(reinterpret_cast<std::uintptr_t>(o))) &
           (kFly - 1);
  }
  FlyVolumes<S>& flyEntry(std::size_t place, const fcl::CollisionObject<S>* o) {
    FlyVolumes<S>& v = fly_.volumes[place];
    if (fly_.key[place] != o) {
      v.start(*o);
      fly_.key[place] = o;
    }
    return v;
  }

  const VolumeSphere* spheres_[2] = {nullptr, nullptr};
  const VolumeShape* shapes_[2] = {nullptr, nullptr};
  std::size_t objects_ = 0;
  Built built_[2];
  // In place, not on the heap: a query of a small manager (one object against 32) is a few
  // microseconds, and an allocation per query was a large part of it.
  bool fly_ready_ = false;
  FlyMemo fly_;
};

}  // namespace detail
}  // namespace cube
