#pragma once

// Batched checks for sampling planners: many states of one robot (a BodySet of links) against a
// static world held by a CubeCollisionManager, in one call, on several threads. Each state is
// given as the links' world poses, as forward kinematics produces them: no fcl::CollisionObject
// per state, no computeAABB() and no update() by the caller. Every contact is decided by FCL's
// narrow phase (fcl::collide, and fcl::distance for margins and clearance), after the broadphase
// of the world's cubes and the cull of the pipeline (callbacks.h): the answers are those of
// checking every link against every world object and every pair of links not excluded with FCL.
// States that lie close together (an edge's, a batch of neighbours) share one walk of the world:
// each link's candidates over the group, then each state's own boxes against those few.

#include <fcl/common/types.h>
#include <fcl/geometry/collision_geometry.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace cube {
namespace detail {
struct BodyAccess;
struct ScratchSlots;
struct ScratchAccess;
/// T as a parameter type that takes no part in deducing S (a lambda converts to it).
template <class T>
struct NoDeduce {
  using type = T;
};
}  // namespace detail

/// The caller's motion bounds of a continuous check, read in place: `size` values from `data`
/// (state-major, as the overloads that take them say), valid for the call. A std::vector
/// converts to it; other storage (a numpy array, a planner's buffer) gives its pointer and count.
template <typename S>
struct MotionBounds {
  const S* data = nullptr;
  std::size_t size = 0;
  MotionBounds() = default;
  /// The values of `v`, which must outlive the call.
  MotionBounds(const std::vector<S>& v) : data(v.data()), size(v.size()) {}  // NOLINT: implicit
  /// `count` values from `values` (null only with count 0).
  MotionBounds(const S* values, std::size_t count) : data(values), size(count) {}
};

/// "No such state, link or object".
inline constexpr std::size_t kNoIndex = std::numeric_limits<std::size_t>::max();

/// The moving bodies of the checks: a robot's links, or any group of objects that move together.
/// Built once per robot; per link it keeps the geometry and what every check needs from it (the
/// local box, the cull's volumes). Not changed by the checks: any number of threads may check
/// with one BodySet at once. Copying shares the geometries.
template <typename S>
class BodySet {
 public:
  BodySet();
  ~BodySet();
  BodySet(const BodySet& other);
  BodySet& operator=(const BodySet& other);
  BodySet(BodySet&&) noexcept;
  BodySet& operator=(BodySet&&) noexcept;

  /// Adds a link and returns its index (0, 1, ... in the order of the calls). `margin` (>= 0):
  /// the link counts as touching whatever lies within margin + that object's margin
  /// (CubeCollisionManager::setMargin; a link's for two links). `category` / `mask`: filter bits
  /// against the world's objects, as CubeCollisionManager::setFilter. Throws
  /// std::invalid_argument, adding nothing, for a null geometry, a plane or halfspace (a link
  /// must be bounded), a geometry whose local AABB is not finite (computeLocalAABB() is called
  /// here), or a negative or non-finite margin.
  std::size_t addLink(std::shared_ptr<fcl::CollisionGeometry<S>> geometry, S margin = 0,
                      std::uint64_t category = 1, std::uint64_t mask = ~std::uint64_t(0));
  /// Links i and j are never checked against each other (adjacent links, say). Throws
  /// std::invalid_argument, changing nothing, for an unknown index or i == j.
  void excludePair(std::size_t i, std::size_t j);
  /// The former name of excludePair (the pair is "allowed" to touch), kept for existing code.
  void allowPair(std::size_t i, std::size_t j) { excludePair(i, j); }
  /// Whether links i and j are checked against each other (i != j, both known).
  bool checked(std::size_t i, std::size_t j) const;
  /// The number of links.
  std::size_t size() const;
  /// Link i's geometry and margin (i < size()).
  const std::shared_ptr<fcl::CollisionGeometry<S>>& geometry(std::size_t i) const;
  S margin(std::size_t i) const;

  struct Links;  ///< the data, private to the library

 private:
  friend struct detail::BodyAccess;
  std::unique_ptr<Links> links_;
};

/// What a batched check sets up on the calling thread (the links' objects and records, the
/// walks' buffers, a motion check's order of states and runs), kept from one call to the next
/// (the motion checks' share sized for the most states a call took, under 128 bytes a state,
/// until release()): a planner that checks a state or a short edge
/// per call passes the same BatchScratch (BatchOptions::scratch) to each of its calls on a thread
/// and skips that set-up, a sizeable share of a call of a few states. Answers never depend on
/// it. A call whose world, body or scalar type differs from the last one's, or whose body
/// changed since (addLink, excludePair), sets up anew (and keeps that). Only the calling
/// thread's share of a call uses it; a call's other threads set up their own. One call at a
/// time: a call that finds it in use (another thread's call, or a call made from inside a call
/// that uses it) throws std::logic_error before any state is checked; it must not be moved or
/// destroyed while a call uses it. It holds no reference a caller must keep alive: a world or
/// body destroyed between calls is never read again through it.
class BatchScratch {
 public:
  BatchScratch();
  ~BatchScratch();
  BatchScratch(BatchScratch&& other) noexcept;
  BatchScratch& operator=(BatchScratch&& other) noexcept;
  BatchScratch(const BatchScratch&) = delete;
  BatchScratch& operator=(const BatchScratch&) = delete;
  /// Frees what it holds; the next call sets up anew. Throws std::logic_error while a call uses
  /// it.
  void release();

 private:
  friend struct detail::ScratchAccess;
  std::unique_ptr<detail::ScratchSlots> slots_;
};

/// What checkStates and checkMotion compute, beyond "colliding or not".
struct BatchOptions {
  /// Also check the links against each other (pairs not excluded by BodySet::excludePair).
  bool self_collision = false;
  /// Report each colliding state's first pair (StateResult): the pair whose lower link index is
  /// smallest; for that link, world objects (lowest registration number first) before links
  /// (lowest index first). Costs the narrow phase of every candidate that could come before
  /// the first contact found (pairs proved touching on the cull's volumes need none).
  bool first_pair = false;
  /// Report each free state's clearance (StateResult::clearance).
  bool clearance = false;
  /// Threads (OpenMP) across states; 0 or less: hardwareThreads() (narrow_phase.h). Answers do
  /// not depend on it. A ceiling: checkStates with fewer than 64 states runs on the calling
  /// thread; checkMotion checks an edge's first 64 states there and hands the rest to the threads
  /// only if 128 or more are left and none of those collided; checkMotions of several edges uses
  /// them from 64 states of undecided edges. A region then takes the count less the other threads
  /// runnable on the machine at that moment, at least one.
  int threads = 0;
  /// checkMotion(s) over a pose array: check the motion between consecutive states of an edge
  /// too, with each link's motion bounds computed from its two poses as for motion interpolated
  /// in SE(3) (see "Continuous edges" below). Ignored by checkStates; the overloads that take
  /// motion bounds check continuously whatever its value; checkMotion(s) with a PoseFunction and
  /// no bounds compute them from the poses it writes (PoseFunction: a checked state's neighbours
  /// are written too).
  bool continuous = false;
  /// Set-up kept between calls on the calling thread (see BatchScratch); null: made for the call
  /// and freed after it.
  BatchScratch* scratch = nullptr;
};

/// One state's answer.
template <typename S>
struct StateResult {
  bool colliding = false;
  /// With BatchOptions::first_pair and a colliding state: the pair's lower link, and its other
  /// side: a world object (`object`, with other_link == kNoIndex) or a link (`other_link`,
  /// with object == nullptr). Otherwise kNoIndex, nullptr, kNoIndex.
  std::size_t link = kNoIndex;
  fcl::CollisionObject<S>* object = nullptr;
  std::size_t other_link = kNoIndex;
  /// With BatchOptions::clearance: for a free state, the smallest fcl::distance(link, other)
  /// between a link and a world object it may meet (filter bits, the world's pair predicate) or
  /// between two checked links (with
  /// self_collision); a pair with a plane or halfspace, on which FCL 0.7's fcl::distance
  /// crashes, counts its exact distance in closed form (as minimumDistance, queries.h). Margins
  /// do not lower it. 0 for a colliding state; the
  /// largest value of S when nothing can be met. Without the option: the largest value of S.
  S clearance = std::numeric_limits<S>::max();
};

/// Checks the states of `poses` for `body` against the objects of `world`: pose k * body.size() + l
/// is link l's world pose in state k (a contiguous array of states, each the links' poses in
/// link order). A state collides when FCL reports a contact between one of its links and a world
/// object whose filter bits and the world's pair predicate (setPairFilter, asked as
/// (world object, link object)) let them meet, or (self_collision) between two checked links,
/// margins included: fcl::collide(link, other) with FCL's default request, then, within a
/// margin, fcl::distance(link, other) <= the margin (to a plane or halfspace: its exact distance,
/// as minimumDistance in queries.h says). Where FCL 0.7's fcl::collide answers a pair wrongly, a
/// cylinder against a plane (its yes/no test projects the length lz where lz/2 belongs) or a
/// cone against a halfspace (one whose apex points into it is tested as if lying on its side),
/// the library answers from the geometry instead, whatever the link's box. Returns one
/// StateResult per state, in state order. `world` is only read: other threads may query it
/// meanwhile (not mutate it); a pair predicate that mutates it gets std::logic_error, as from its
/// other queries. The objects a predicate is given for a link share its geometry and hold the
/// state's pose, and their getAABB() is the link's box (the exact box of its local AABB posed).
/// Throws std::invalid_argument for an empty body set or a pose array whose size is not a multiple
/// of body.size() (before any work), or for a pose (rotation or translation) with a NaN or infinite
/// entry, naming the first one (each state's poses are read once, as its links are placed; the
/// call returns nothing then, and changes nothing).
template <typename S>
std::vector<StateResult<S>> checkStates(const CubeCollisionManager<S>& world,
                                        const BodySet<S>& body,
                                        const std::vector<fcl::Transform3<S>>& poses,
                                        const BatchOptions& options = BatchOptions());

/// The order in which checkMotion visits an edge's states.
enum class MotionOrder {
  /// State 0, 1, 2, ...: the answer is the first colliding state along the path.
  path,
  /// OMPL's DiscreteMotionValidator::checkMotion(s1, s2) order: the last state, then the middles
  /// of the intervals left, breadth first (as OMPL's queue takes them). Finds a collision after
  /// fewer checks on average when obstacles lie inside an edge rather than near its start (the
  /// common case for a planner's long edges); for an edge that starts inside an obstacle `path`
  /// finds it first. The answer is the first colliding state in this order.
  bisection,
};

/// Checks the states of edges: edge e holds states edge_starts[e] .. edge_starts[e + 1] - 1
/// (the last edge up to the last state) of `poses` (laid out as for checkStates). Returns, per
/// edge, the index within the edge of its first colliding state in `order`, or kNoIndex if all
/// are free: what checking the edge's states one by one in that order and stopping at the first
/// collision gives, whatever the thread count. An edge's states are read in runs of consecutive
/// places in the order, of 5, 8, 16 and then 32 states in path order, of 1, 4, 8, 16 and then
/// 32 in bisection order (states of a run that lie close together share one walk of the
/// world); once an edge's colliding state is known, no state after it in the order is started,
/// and no later run is read: on one thread, for an answer at place r of the order, at most
/// max(5, 2 r + 3) of the edge's states are read. Only
/// self_collision, threads and continuous of `options` apply (continuous: see "Continuous edges"
/// below; a state's check then also reads its neighbours' poses in the edge, and a NaN or
/// infinite one throws there). No poses and no edges: an empty answer. Throws
/// std::invalid_argument as checkStates, and for edge_starts that do not start at 0 or do not
/// increase strictly within the states, states with no edge_starts included (before any work);
/// a pose with a NaN or infinite entry throws if its state comes before its edge's first
/// colliding state in the order (where the serial scan would meet it). Validating every pose
/// first would read the whole batch, which for edges that collide early cost more than their
/// checks.
template <typename S>
std::vector<std::size_t> checkMotions(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                                      const std::vector<fcl::Transform3<S>>& poses,
                                      const std::vector<std::size_t>& edge_starts,
                                      MotionOrder order = MotionOrder::path,
                                      const BatchOptions& options = BatchOptions());

/// checkMotions for one edge made of all the states of `poses`.
template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        const std::vector<fcl::Transform3<S>>& poses,
                        MotionOrder order = MotionOrder::path,
                        const BatchOptions& options = BatchOptions());

/// Writes the links' poses of state `state` (0 <= state < the motion's states) to
/// poses[0 .. body.size() - 1], every one of them (the buffer may hold another state's poses).
/// Called only for the states a check reads, at most once per state, possibly from several
/// threads at once (BatchOptions::threads): it must be safe to call concurrently. With
/// BatchOptions::continuous and no motion bounds, the SE(3) bounds of a checked state read its
/// neighbours in its edge too: those are written as well. In path order on one thread each state
/// is written at most once (the neighbour after a run is the next run's first state, kept for
/// it); otherwise a state may be written more than once (in bisection order as a neighbour of
/// several states, or with `threads` > 1 when the run after is another thread's).
template <typename S>
using PoseFunction = std::function<void(std::size_t state, fcl::Transform3<S>* poses)>;

/// checkMotion for one edge of `states` states whose poses `pose_of` writes on demand, for a
/// planner that interpolates an edge and runs its kinematics per state: pose_of is called for the
/// states of a run (checkMotions) before any of them is checked, and no later run is computed
/// once the answer is known: on one thread, for an answer at place r of `order`, at most
/// max(5, 2 r + 3) states are checked, and only those are computed but for the neighbours
/// BatchOptions::continuous reads (with `threads` > 1, a few more may be, and their answers
/// dropped). The same answer as checkMotion over all the poses, whatever the thread count. No
/// pose array is made: the call's memory is the visiting order, about 40 bytes a state (kept in
/// BatchOptions::scratch for the next call if one is given), and room for the poses of one run
/// (32 states, 35 with BatchOptions::continuous) per thread. With BatchOptions::continuous, the
/// SE(3) bounds as checkMotion over all the poses computes them, each checked state's neighbours
/// written too (PoseFunction). Throws std::invalid_argument for an empty body set or a null
/// function (before any work), and as checkMotion for a NaN or infinite pose; an exception from
/// pose_of is passed on (possibly one from a state after the answer in its run, or with `threads` >
/// 1 in a later one).
template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        std::size_t states,
                        const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
                        MotionOrder order = MotionOrder::path,
                        const BatchOptions& options = BatchOptions());

/// checkStates over `states` states whose poses `pose_of` writes on demand (each state's once,
/// into one thread's room for a few consecutive states: no pose array is made, and a caller
/// whose poses are in another layout converts them on the checking threads). The same answers
/// as checkStates over all the poses, whatever the thread count. Throws std::invalid_argument
/// for an empty body set or a null function (before any work), and as checkStates for a NaN or
/// infinite pose; an exception from pose_of is passed on, the lowest state's if several threw.
template <typename S>
std::vector<StateResult<S>> checkStates(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
    const BatchOptions& options = BatchOptions());

/// checkMotions over `states` states whose poses `pose_of` writes on demand: only the states a
/// check reads are written, as checkMotion with a pose function says (with `threads` > 1, a few
/// after an edge's answer may be, and their answers dropped). The same answers as checkMotions
/// over all the poses, whatever the thread count (with BatchOptions::continuous too, the SE(3)
/// bounds computed from the poses pose_of writes, as checkMotion with a pose function says).
/// Throws std::invalid_argument as checkMotions and for a null function (before any work); an
/// exception from pose_of is passed on (with `threads` > 1, possibly one from a state after its
/// edge's answer): a caller that wants the array form's rule for a bad pose writes a NaN entry into
/// it instead of throwing.
template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
    MotionOrder order = MotionOrder::path, const BatchOptions& options = BatchOptions());

// Continuous edges. A discrete edge check can step over an obstacle thinner than the motion
// between two states. With continuous checking, an edge is reported free only if no link can
// touch a world object (or, with self_collision, another checked link) anywhere between
// consecutive states, given a bound on each link's motion per interval:
//  - motion bound b of link l over the interval from state k to k + 1 of an edge: an upper bound
//    on the length of the path of every point of link l between the two states. A point that
//    has moved a length L1 since state k has L2 <= b - L1 left to state k + 1, so it lies within
//    b / 2 of its place at state k or at state k + 1; two links' points at one instant, within
//    (b_i + b_j) / 2 of each other's at one of the two states (L1_i + L1_j + L2_i + L2_j <=
//    b_i + b_j).
//  - so each state k of the edge is checked as checkMotions checks it, with link l's margin
//    raised by max(b of interval k - 1, b of interval k) / 2 (the intervals of the edge that
//    state k ends and starts; an edge's first and last states have one, a lone state none):
//    a state fails when fcl::collide reports a contact, or fcl::distance is at most the raised
//    margins (link margin + raise + the object's margin; for two links both margins and both
//    raises). A contact anywhere inside an interval makes at least one of its two states fail,
//    and so does a link within its margins of an object anywhere inside an interval: exactly,
//    up to the accuracy of FCL's own fcl::collide and fcl::distance on the states. (A mesh
//    against a box, sphere, capsule or cylinder may be found apart by fcl::collide against that
//    primitive grown by more than an eighth beyond the margins: the same answer within that
//    accuracy.)
//  - it is conservative: a state may fail though nothing is touched on the motion (the check
//    sees each link grown by half its larger bound in every direction).
// The answer per edge is the index within the edge of its first state, in the visiting order,
// whose raised check fails (kNoIndex: the whole edge is free, the motion between its states
// included); the thread count does not change it. Nothing is said of the motion before the
// edge's first state or after its last.
// Bounds computed for motion interpolated in SE(3) (BatchOptions::continuous): each link's
// translation linear and its rotation along the geodesic between its two orientations, b =
// |t1 - t0| + theta * rho, theta the rotation angle of R0^T R1 (computed never below it: at most
// 2e-14 rad above it in double, then rounded up in float) and rho the largest distance from the
// link frame's origin to a corner of the link's local AABB. They hold only if the caller's links
// move that way between states; a robot interpolated in joint space needs bounds from its
// kinematics (the overloads that take them). Cost: runs of an edge's states share the world's walk
// as in checkMotions, each state with its own raised margins; a state's check with raised margins
// meets more candidate pairs, and a pair within the raised margins but apart costs FCL calls the
// records do not settle (on meshes, walks of their BVH): per state, from about the discrete check's
// cost where the raises are small against the gaps between links and objects, to many times it
// where they are not; computing SE(3) bounds reads the neighbours' poses.

/// checkMotions with continuous checking (see above) and the caller's bounds: motion_bounds[k *
/// body.size() + l] bounds link l's motion from state k to state k + 1 of the same edge, one
/// value per pose of `poses` (those of each edge's last state are not used), read in place (see
/// MotionBounds). Throws std::invalid_argument as checkMotions, and for motion bounds whose size
/// is not poses.size(), with a null pointer, or with a negative, NaN or infinite value (naming
/// the first), before any work.
template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body,
    const std::vector<fcl::Transform3<S>>& poses, const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
    MotionOrder order = MotionOrder::path, const BatchOptions& options = BatchOptions());

/// checkMotions with the caller's motion bounds for one edge made of all the states of `poses`.
template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        const std::vector<fcl::Transform3<S>>& poses,
                        const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
                        MotionOrder order = MotionOrder::path,
                        const BatchOptions& options = BatchOptions());

/// checkMotions over a PoseFunction with continuous checking and the caller's motion bounds:
/// motion_bounds[k * body.size() + l] for link l from state k to k + 1 of the same edge,
/// states * body.size() values (those of each edge's last state not used). Only the states a
/// check reads are written, as checkMotions over a PoseFunction says; the same answers as
/// checkMotions over all the poses with these bounds, whatever the thread count. Throws
/// std::invalid_argument as that overload (but checks continuously whatever
/// BatchOptions::continuous says), and for bounds of another size, with a null pointer or with a
/// negative, NaN or infinite value, naming the first, before any work.
template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
    const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
    MotionOrder order = MotionOrder::path, const BatchOptions& options = BatchOptions());

/// checkMotion over a PoseFunction with continuous checking and the caller's motion bounds:
/// motion_bounds[k * body.size() + l] for link l from state k to k + 1, states * body.size()
/// values (the last state's not used). Throws std::invalid_argument as the overload without
/// bounds, and for bounds of another size, with a null pointer or with a negative, NaN or infinite
/// value, naming the first, before any work.
template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        std::size_t states,
                        const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
                        const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
                        MotionOrder order = MotionOrder::path,
                        const BatchOptions& options = BatchOptions());

}  // namespace cube
