#pragma once

// The narrow-phase pipeline as streams fed by a manager's walk, one pair per callback: pairs are
// gathered in chunks, each chunk runs on the threads, and the answers merge in pair order. A
// stream tells the walk to stop as soon as the merged answer is complete, so a request for one
// contact still stops near the first colliding pair.

#include <cstdint>
#include <memory>
#include <vector>

#include "core/geometry.h"
#include "core/volume.h"
#include "cube_collision/narrow_phase.h"

namespace cube {
namespace detail {

/// Where a stream finds the volumes of a pair's objects: the object tables whose ids the walk
/// gives (side a, the first id; side b), and, for an object of no table (id kNone: the query
/// object, or the objects of another kind of manager, whose pairs come one object at a time),
/// volumes built during the query, the last one of each side kept.
template <typename S>
class PairVolumes {
 public:
  /// The tables' records (ObjectTable::spheres(), shapes()); null: that table keeps none.
  void use(const VolumeSphere* spheres_a, const VolumeShape* shapes_a,
           const VolumeSphere* spheres_b, const VolumeShape* shapes_b) {
    spheres_[0] = spheres_a;
    shapes_[0] = shapes_a;
    spheres_[1] = spheres_b;
    shapes_[1] = shapes_b;
  }
  /// The records of objects a (id ia) and b (id ib), into the four pointers; false if a table
  /// keeps none (a manager below kVolumeMinObjects): the pair is culled from the objects.
  bool of(const fcl::CollisionObject<S>* a, ObjectId ia, const fcl::CollisionObject<S>* b,
          ObjectId ib, const VolumeSphere*& sa, const VolumeShape*& ha, const VolumeSphere*& sb,
          const VolumeShape*& hb) {
    return side(0, a, ia, sa, ha) && side(1, b, ib, sb, hb);
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
      return true;
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

  const VolumeSphere* spheres_[2] = {nullptr, nullptr};
  const VolumeShape* shapes_[2] = {nullptr, nullptr};
  Built built_[2];
};

/// How a pair was answered: proved apart or touching by the tight volumes (cull.h), found in
/// the cache, or by FCL.
enum class Answer : std::uint8_t { kApart, kProved, kCached, kComputed };

/// Accumulates fcl::collide answers exactly as one result passed to fcl::collide for each pair
/// in turn would (not for requests with costs or a cached GJK guess: callers keep those serial).
/// Pairs are answered at once on the calling thread at first (and always for a request of one
/// contact, and on one thread); once the query proves large, they are gathered into chunks (the
/// cache looked up on the calling thread) whose cull and FCL calls run on the threads when there
/// is enough work to pay for a parallel region.
template <typename S>
class CollideStream {
 public:
  CollideStream(const fcl::CollisionRequest<S>& request, const NarrowPhaseOptions<S>& options);
  ~CollideStream();
  CollideStream(const CollideStream&) = delete;
  CollideStream& operator=(const CollideStream&) = delete;

  /// Adds one candidate pair. True once the result is complete: the walk may stop.
  bool push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);
  /// Where push(a, ia, b, ib) finds the pair's volumes.
  PairVolumes<S>& volumes() { return volumes_; }
  /// push, with the objects' ids (kNone: an object of no table): the cull reads the tables'
  /// volumes instead of the objects, on this thread (about 20 ns a pair).
  bool push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b, ObjectId ib);
  /// The pair that gave the first contact of the last collide with contacts that used `cache`
  /// (nullptrs if none, or forgotten since).
  static ObjectPair<S> lastHit(NarrowPhaseCache<S>& cache);
  /// push, answering this pair before any other is pushed (what is pending goes first).
  bool pushAlone(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);
  /// Runs what is pending and returns the merged result. Call once, at the end.
  fcl::CollisionResult<S> finish();

  /// An fcl::CollisionCallBack feeding the CollideStream passed as cdata.
  static bool callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* stream);
  /// The same for walks that give ids (manager_walks.h).
  static bool callbackWithIds(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                              ObjectId ib, void* stream);

 private:
  struct Slot;
  // The records of a pair, for pushJudged (null: cull from the objects).
  struct Volumes {
    const VolumeSphere* sphere;
    const VolumeShape* shape;
  };
  bool pushJudged(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, const Volumes* va,
                  const Volumes* vb);
  static bool kept(const Slot& s);
  void answerNow(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, Answer kind);
  void answerNow(const ObjectPair<S>& pair, Slot& slot);
  void merge(const ObjectPair<S>& pair, const Slot& slot);
  void markDone();
  void flush();

  const fcl::CollisionRequest<S>& request_;
  NarrowPhaseStats stats_;
  NarrowPhaseStats* stats_out_;
  typename NarrowPhaseCache<S>::Impl* cache_;
  int threads_;
  bool done_ = false;
  bool serial_ = true;           // answer each pair as it comes
  std::size_t serial_work_ = 0;  // work answered at once (narrow_phase.cpp, kSerialWork)
  std::size_t chunk_work_ = 0;   // flush once the pending work reaches this
  std::size_t pending_work_ = 0;
  std::vector<ObjectPair<S>> chunk_;
  std::vector<std::size_t> pending_;  // the chunk's pairs not in the cache
  std::vector<Slot> slots_;           // one per pair of the chunk
  std::unique_ptr<Slot> scratch_;     // a pair answered at once, with a cache
  fcl::CollisionResult<S> empty_;
  fcl::CollisionResult<S> result_;
  // The cull on volumes: the tables, the memo of objects without an id, the margin's rate.
  PairVolumes<S> volumes_;
  float rate_;
  bool plain_;  // a request the cull may answer (not with costs or a cached GJK guess)
  bool prove_;  // and whose touching pairs it may prove
};

/// The smallest fcl::distance over the pairs pushed, culled by tight-volume bounds. Without a
/// cache, FCL's own way on the calling thread: one accumulating result, whatever the thread
/// count (a branch and bound is sequential: batches gave the walk weaker bounds and cost more
/// than they saved). With a cache, each pair not in it gets a fresh result, `threads` pairs at a
/// time (a pair is held back until a batch of that many is complete, or finish(); the bound
/// returned to the walk is the one before the batch), on the threads only when the batch holds
/// meshes or octrees enough to pay for a parallel region. The minimum is the same for every
/// thread count; its nearest points are those of the first pair, in walk order, that reached it.
template <typename S>
class DistanceSearch {
 public:
  DistanceSearch(const fcl::DistanceRequest<S>& request, const NarrowPhaseOptions<S>& options);
  ~DistanceSearch();
  DistanceSearch(const DistanceSearch&) = delete;
  DistanceSearch& operator=(const DistanceSearch&) = delete;

  /// Adds one candidate pair; `dist` gets the best distance so far. True once objects touch.
  bool push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, S& dist);
  /// Where push(a, ia, b, ib, dist) finds the pair's volumes.
  PairVolumes<S>& volumes() { return volumes_; }
  /// push, with the objects' ids (kNone: an object of no table): the bound comes from the
  /// tables' volumes.
  bool push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b, ObjectId ib,
            S& dist);
  /// Runs what is pending and returns the result. Call once, at the end.
  fcl::DistanceResult<S> finish();

  /// An fcl::DistanceCallBack feeding the DistanceSearch passed as cdata.
  static bool callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* search,
                       S& dist);
  /// The same for walks that give ids (manager_walks.h).
  static bool callbackWithIds(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                              ObjectId ib, void* search, S& dist);

 private:
  struct Slot;
  void flush();
  // After the bound let the pair through: FCL, or the batch.
  void answer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);

  const fcl::DistanceRequest<S>& request_;
  NarrowPhaseStats stats_;
  NarrowPhaseStats* stats_out_;
  typename NarrowPhaseCache<S>::Impl* cache_;
  int threads_;
  std::vector<ObjectPair<S>> batch_;
  std::vector<Slot> slots_;
  fcl::DistanceResult<S> result_;
  PairVolumes<S> volumes_;
  float rate_;
};

extern template class CollideStream<double>;
extern template class CollideStream<float>;
extern template class DistanceSearch<double>;
extern template class DistanceSearch<float>;

}  // namespace detail
}  // namespace cube
