#pragma once

// When the library opens an OpenMP region: every threshold, each with the reason for it (the
// measurements behind them: docs/pipeline.md and benchmarks/README.md, "Threads"), and the one
// function that sizes a region's team. The rule, as README.md states it for
// users: a call runs on its calling thread unless its work is large and independent (a pair or a
// state whose answer does not stop the others) and clears the threshold below; then it takes the
// threads it asked for (BatchOptions::threads, NarrowPhaseOptions::threads; 0: the hardware's)
// less the other threads runnable on the machine at that moment, never fewer than one. Scans that
// may stop at their first hit (a one-contact collide, an edge) stay on the calling thread until
// the work done shows they will not stop soon. Answers never depend on the team.

#include <cstddef>

namespace cube {
namespace detail {

// ---- The narrow-phase pipeline: work in candidate pairs (answers.h's workOf: a pair counts 1,
// one that FCL answers with GJK kGjkPairWork, one with a mesh or an octree kHeavyPairWork).

// A region is opened only for this much work: opening one costs little while the other cores
// idle and up to a scheduler slice while they are busy; on a loaded machine regionTeam gives one
// thread anyway.
constexpr std::size_t kParallelMinWork = 128;

// A collide stream answers pairs at once on the calling thread until it has seen kSerialWork of
// work, then gathers chunks of kFirstChunkWork, doubling up to kMaxChunkWork. Chunks cost more per
// pair than answering at once (a result per pair, contacts copied in the merge), so small queries
// never leave the calling thread. For closed-form shape pairs a chunk's bookkeeping costs more than
// a second thread saves; GJK pairs and meshes pay for it (answers.h's workOf weighs them).
constexpr std::size_t kSerialWork = 1024;
// ... and only while that work is at least 1/kMinCallShare of its candidate pairs: the threads
// share FCL's calls only (the walk, the cull and the merge stay on the calling thread) and a
// chunk costs each pair it holds more than an answer at once, so a query whose pairs the records
// mostly settle (a clustered scene of shapes: many pairs, few FCL calls) stays on one thread.
constexpr std::size_t kMinCallShare = 2;
constexpr std::size_t kFirstChunkWork = 256;
constexpr std::size_t kMaxChunkWork = 4096;

// forEachPair runs a caller's function of unknown cost: a region from this many pairs on.
constexpr std::size_t kParallelMinPairs = 4;

// ---- The split walk (Broadphase::collideSelfSplit / collideSelfTasks).

// Objects in the cubes from which a self walk is split: below, the walk takes less time than a
// wave's threads take to start.
constexpr std::size_t kSplitMinObjects = 4096;
// Tasks a split self walk is cut into (at least; fewer in a tree of fewer leaves).
constexpr std::size_t kSplitWalkTasks = 64;
// The same for a walk whose tasks carry the narrow phase (a TaskSink): a clustered scene's tasks
// differ by orders of magnitude, so finer tasks balance the threads.
constexpr std::size_t kSinkWalkTasks = 256;

// ---- Batched checks (queries/batch.cpp): a state costs about as much as a few pairs.

// checkStates opens a region from this many states. One state (a planner's
// StateValidityChecker) is always checked on the calling thread.
constexpr std::size_t kParallelMinStates = 64;
// A lone edge (checkMotion) checks this many states on the calling thread first (an edge stops at
// its first colliding state: most of a planner's edges collide within their first states, and
// what other threads started past that point is wasted) and hands the rest to the threads only if
// at least kMotionParallelMinStates states are still undecided. Several edges (checkMotions) are
// independent scans and go to the threads from kParallelMinStates undecided states (the prefix
// made batches of short edges slower on two threads). Threads from an edge's first state made a
// planner's checks far slower on a loaded machine; under this rule a planner's usual edges open no
// region.
constexpr std::size_t kMotionSerialStates = 64;
constexpr std::size_t kMotionParallelMinStates = 128;

// ---- The team.

// The team by load: with the machine busy, a worker shares a core with other work and the
// region's end waits for its scheduler slice, which costs more than the second thread saves. A
// probe of the load is one small file read.
// A region's threads may still be spinning (libgomp's active wait) this long after it closed: the
// runnable threads counted then include them.
constexpr long long kRecentRegionNs = 20'000'000;

/// The threads a region about to open takes: `requested` less the threads of other work runnable
/// on the machine now (each holds a core a worker would share), at least 1; 1 for requested <= 1.
/// Reads the system's count of runnable threads (Linux: /proc/loadavg), a few microseconds: call it
/// once per call, only for work above a threshold above. With the environment variable
/// CUBE_THREADS_IGNORE_LOAD set (the tests set it, so that their thread counts run as asked on a
/// busy machine): `requested`.
int regionTeam(int requested);

/// Tells regionTeam that a region of `team` threads has just closed (its workers may spin).
void regionClosed(int team);

}  // namespace detail
}  // namespace cube
