#pragma once

// FCL's narrow phase over a list of candidate pairs: culled by tight volumes, answered from a
// cache for pairs that did not move, and run on several threads (OpenMP). Results do not depend
// on the thread count: per-pair answers are merged in the order of the pairs. The one-call
// helpers of queries.h are built on this; docs/pipeline.md.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <cstddef>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace cube {

/// A pair of objects in the order the manager's callback received them.
template <typename S>
using ObjectPair = std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>;

/// The threads the narrow phase uses when asked for 0 (OpenMP's default: the hardware's
/// threads, or OMP_NUM_THREADS). At least 1.
int hardwareThreads();

/// What one call of the pipeline did, for benchmarks and tuning. Counts add up over calls.
struct NarrowPhaseStats {
  std::size_t candidate_pairs = 0;  ///< pairs the broadphase handed over
  std::size_t culled = 0;           ///< proved apart by the tight volumes, no narrow phase
  /// proved touching by volumes inside the shapes (balls inscribed in spheres, boxes, capsules,
  /// cylinders, cones and ellipsoids; on a manager's records, Config::tight_volumes, also
  /// capsules and boxes inside spheres, boxes, capsules and cylinders), no narrow phase: only
  /// for requests without enable_contact (the contact FCL gives them names the two geometries
  /// and nothing else) and without costs or a cached GJK guess
  std::size_t proved = 0;
  std::size_t cached = 0;        ///< answered from a NarrowPhaseCache
  std::size_t narrow_calls = 0;  ///< fcl::collide / fcl::distance calls made
};

/// Last narrow-phase answers per ordered pair (a, b): the contacts for a collision request (an
/// empty list for a pair the tight volumes proved apart), the distance and nearest points for a
/// distance request. A collide on a CubeCollisionManager keeps the answers FCL gave and those of
/// the costlier bounds of its objects' volumes (kept per object by the manager, rebuilt by
/// update(); the capsules and inner volumes of Config::tight_volumes, tried after the cache
/// missed); the pairs its spheres, boxes and inscribed balls prove apart or touching are proved
/// again each time, before the lookup, which costs more. A pair is answered from
/// it while both of its objects keep the same transform (bit for bit), the same geometry object and
/// the same local AABB, and the request is the same; each object is compared with its last pose
/// once per query, not once per pair. A query keeps the entries it did not use only while they are
/// fewer than those it used (plus 64), so the cache holds at most about twice one query's pairs.
/// Changing a geometry in place without changing its local AABB (e.g. a mesh's vertices after
/// computeLocalAABB() gave the same box) is not seen: call forget(object) or clear(). Owned by the
/// caller and passed to the queries; not shared between concurrent queries.
template <typename S>
class NarrowPhaseCache {
 public:
  NarrowPhaseCache();
  ~NarrowPhaseCache();
  NarrowPhaseCache(NarrowPhaseCache&&) noexcept;
  NarrowPhaseCache& operator=(NarrowPhaseCache&&) noexcept;
  NarrowPhaseCache(const NarrowPhaseCache&) = delete;
  NarrowPhaseCache& operator=(const NarrowPhaseCache&) = delete;

  /// Forgets every answer.
  void clear();
  /// Forgets the answers of every pair that involves `obj` (e.g. before deleting it, or after
  /// changing its geometry in place).
  void forget(const fcl::CollisionObject<S>* obj);
  /// Pairs held (collision and distance answers together).
  std::size_t size() const;

  struct Impl;
  /// The library's access to the entries; not for users.
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// How the helpers run the narrow phase.
template <typename S>
struct NarrowPhaseOptions {
  /// Threads for the narrow phase: 0 (or less) = hardwareThreads(), 1 = this thread only.
  /// Results are the same for every count. A count is a ceiling: a parallel region is opened
  /// only for work large enough to pay for it (thresholds in docs/pipeline.md#threads), and then
  /// with the count less the other threads runnable on the machine at that moment, at least one.
  /// The cache is always looked up on the calling thread. A collide that stops at its first
  /// contact (num_max_contacts == 1, FCL's default) calls FCL one pair at a time on any count,
  /// never more often than on one thread; minimumDistance without a cache runs on the calling
  /// thread (queries.h says why).
  /// A large self-collide (collideAll(manager) of a CubeCollisionManager with per-object
  /// volumes, on more than one thread, for a request that may take more than one contact,
  /// without a cache, a pair predicate or Config::canonical_pairs) runs on the threads from its
  /// first pair: its walk is cut into tasks, each task's pairs answered on the thread that
  /// walked it, and the calling thread merges the tasks in the serial walk's order, so the
  /// contacts and colliding pairs are the same. A task is skipped when its predecessors that
  /// have run hold num_max_contacts contacts. So a request that fills its budget early may call
  /// FCL for pairs after its stop (those of tasks started before the budget was seen full), and
  /// `stats` counts the pairs of every task that ran.
  int threads = 0;
  /// Answers pairs whose objects did not move from their last answer; nullptr: no cache.
  NarrowPhaseCache<S>* cache = nullptr;
  /// If set, the query's counts are added to it.
  NarrowPhaseStats* stats = nullptr;
  /// collideAll only, with a cache: test first the pair that gave the first contact of the
  /// last collide that used this cache, if it is a candidate pair of this query (for "is this
  /// state valid?" loops over nearby states, where it most often still collides and answers in
  /// one narrow-phase call). Whether anything collides is the same; which contacts a request
  /// that stops early reports is not (that pair's come first), hence the opt-in. Trade-off: the
  /// candidate pairs are gathered first (the whole broadphase walk, without the early stop), so
  /// it pays where narrow-phase calls dominate (meshes, a robot against a world), not for large
  /// scenes of simple shapes.
  bool last_hit_first = false;
  /// collideAll (self-collide) only: a large CubeCollisionManager (docs/pipeline.md#threads)
  /// splits its broadphase walk too, into subwalks taken by the threads; the candidate pairs
  /// are handed over on this thread in the serial walk's order, so the results are the same.
  /// Trade-off: the walk is a small part of a collideAll with the narrow phase, and handing
  /// every pair over costs about what a split walk saves on few cores; for machines with many
  /// idle cores and very large scenes (benchmarks/README.md measures it). A self-collide that the
  /// threads answer task by task (see `threads`) splits its walk whatever this says.
  bool split_walk = false;
  /// collideAll and collideMerged only: if set, it is cleared and then given every pair that
  /// put at least one contact into the returned result, once, in the order of its first contact
  /// there, as the walk handed the pair over (first, second). A pair whose contacts the budget
  /// (num_max_contacts) left out entirely is not listed. "Which pairs collide?" without a lookup
  /// from contacts' geometries back to objects: a request with num_max_contacts at its largest
  /// lists every colliding pair (a shape pair gives one contact without enable_contact; a mesh
  /// pair gives every touching triangle pair, so prefer collidePairs with one contact per pair
  /// there). Not touched by the other calls.
  std::vector<ObjectPair<S>>* colliding = nullptr;
};

/// fcl::collide on each pair (a fresh result per pair), culled and cached as the options say, on
/// options.threads threads when the calls left after the cull pay for them (as
/// NarrowPhaseOptions::threads says). result[i] belongs to pairs[i]; a culled pair gets an empty
/// result.
/// With request.enable_cost or enable_cached_gjk_guess nothing is culled or cached. A null object
/// in `pairs` throws std::invalid_argument before any pair runs (here and in collideMerged and
/// forEachPair). A convex polytope against a plane is answered as collideAll (queries.h) says.
/// Where FCL 0.7's fcl::collide answers a pair wrongly, a cylinder against a plane (its yes/no
/// test projects the length lz where lz/2 belongs) or a cone against a halfspace (one whose apex
/// points into it is tested as if lying on its side), the library answers from the geometry
/// instead, with the contact FCL's correct tests would give.
template <typename S>
std::vector<fcl::CollisionResult<S>> collidePairs(const std::vector<ObjectPair<S>>& pairs,
                                                  const fcl::CollisionRequest<S>& request,
                                                  const NarrowPhaseOptions<S>& options = {});

/// The contacts of the pairs, merged in pair order into one result exactly as fcl::collide
/// called on each pair in turn with one accumulating result would give them (stopping once it
/// holds request.num_max_contacts contacts, costs aside), with collidePairs' exceptions to
/// fcl::collide. What collideAll runs.
template <typename S>
fcl::CollisionResult<S> collideMerged(const std::vector<ObjectPair<S>>& pairs,
                                      const fcl::CollisionRequest<S>& request,
                                      const NarrowPhaseOptions<S>& options = {});

/// Calls fn(i, pairs[i].first, pairs[i].second) for every i on `threads` threads (fewer than 4
/// pairs: on the calling thread): for callers who run their own narrow phase. fn must be
/// safe to call concurrently; write results by index to keep them independent of the threads.
/// An exception thrown by fn stops nothing: fn is still called for every other index, and once
/// all calls have returned the exception is rethrown here (the first one in pair order, if
/// several threw). An empty fn throws std::invalid_argument.
template <typename S>
void forEachPair(
    const std::vector<ObjectPair<S>>& pairs,
    const std::function<void(std::size_t, fcl::CollisionObject<S>*, fcl::CollisionObject<S>*)>& fn,
    int threads = 0);

}  // namespace cube
