#pragma once

// The distance search: the narrow-phase pipeline's smallest distance, fed by a manager's distance
// walk one pair per callback, with the best distance so far handed back as the walk's bound.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <vector>

#include "core/geometry.h"
#include "cube_collision/narrow_phase.h"
#include "pipeline/collectors.h"
#include "pipeline/pair_judge.h"
#include "pipeline/pair_volumes.h"

namespace cube {
namespace detail {

/// The smallest fcl::distance over the pairs pushed, those that cannot beat the best so far
/// (its collector's bound, Closest in collectors.h) left out by the pair judge. Without a cache,
/// FCL's own way on the calling thread: one accumulating result, whatever the thread count (a
/// branch and bound is sequential: batches gave the walk weaker bounds and cost more than they
/// saved). With a cache, each pair not in it gets a fresh result, `threads` pairs at a time (a pair
/// is held back until a batch of that many is complete, or finish(); the bound returned to the walk
/// is the one before the batch), on the threads only when the batch holds meshes or octrees enough
/// to pay for a parallel region. The minimum is the same for every thread count; its nearest points
/// are those of the first pair, in walk order, that reached it.
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
  // The one path of both pushes: `may_beat(bound)` the judge on whatever the pair has (records,
  // kept levels, the objects), asked only while the bound is positive.
  template <class MayBeat>
  bool offer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, S& dist, MayBeat&& may_beat);
  void flush();
  // After the bound let the pair through: FCL, or the batch.
  void answer(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);

  const fcl::DistanceRequest<S>& request_;
  NarrowPhaseStats stats_;
  NarrowPhaseStats* stats_out_;
  typename NarrowPhaseCache<S>::Impl* cache_;
  int threads_;
  int team_ = 0;  // threads of its regions, sized at the first that pays (0: not yet)
  std::vector<ObjectPair<S>> batch_;
  std::vector<Slot> slots_;
  fcl::DistanceResult<S> result_;
  Closest<S> closest_;  // keeps result_
  PairVolumes<S> volumes_;
  PairJudge<S> judge_;
};

extern template class DistanceSearch<double>;
extern template class DistanceSearch<float>;

}  // namespace detail
}  // namespace cube
