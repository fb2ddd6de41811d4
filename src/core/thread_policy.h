#pragma once

// When the library opens an OpenMP region: every threshold, each with the measurement that set
// it, and the one function that sizes a region's team. The rule, as README.md states it for
// users: a call runs on its calling thread unless its work is large and independent (a pair or a
// state whose answer does not stop the others) and clears the threshold below; then it takes the
// threads it asked for (BatchOptions::threads, NarrowPhaseOptions::threads; 0: the hardware's)
// less the other threads runnable on the machine at that moment, never fewer than one. Scans that
// may stop at their first hit (a one-contact collide, an edge) stay on the calling thread until
// the work done shows they will not stop soon. Answers never depend on the team.
//
// Figures: this machine, 2 cores; "loaded": two busy processes beside the benchmark
// (cube_bench --load=2, benchmarks/README.md has the tables).

#include <cstddef>

namespace cube {
namespace detail {

// ---- The narrow-phase pipeline: work in candidate pairs (answers.h's workOf: a pair counts 1,
// one that FCL answers with GJK kGjkPairWork, one with a mesh or an octree kHeavyPairWork).

// A region is opened only for this much work: 30-60 us. Opening a two-thread region costs about
// 1 us while the other core idles and tens of us (up to a scheduler slice, milliseconds) while it
// is busy; on a loaded machine regionTeam gives one thread anyway.
constexpr std::size_t kParallelMinWork = 128;

// A collide stream answers pairs at once on the calling thread until it has seen kSerialWork of
// work, then gathers chunks of kFirstChunkWork, doubling up to kMaxChunkWork. Chunks cost more per
// pair than answering at once: a self-collide of 1,000 uniform objects (800 pairs) took 137 us on
// one thread and 177 us on two when it left after 8 FCL calls. For closed-form shape pairs a
// chunk's bookkeeping cost more than the second thread saved (41 ms on one thread, 47 on two for
// 10,000 clustered boxes); GJK pairs and meshes pay (10,000 clustered boxes, spheres and
// cylinders: 0.76x the time of one thread).
constexpr std::size_t kSerialWork = 1024;
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

// ---- Batched checks (queries/batch.cpp): a state costs 1-10 us.

// checkStates opens a region from this many states (64-640 us of work). One state (a planner's
// StateValidityChecker) is always checked on the calling thread.
constexpr std::size_t kParallelMinStates = 64;
// A lone edge (checkMotion) checks this many states on the calling thread first (an edge stops at
// its first colliding state: most of a planner's edges collide within their first states, and
// what other threads started past that point is wasted) and hands the rest to the threads only if
// at least kMotionParallelMinStates states are still undecided. Several edges (checkMotions) are
// independent scans and go to the threads from kParallelMinStates undecided states: with the
// prefix too, 20 edges of 20-100 states on two threads took 1.0-1.4x the time idle. With two
// threads per call from the first state, the OMPL example planned in 2.5-3.1x less time than FCL's
// checker idle but 0.17-0.23x loaded (edges of 150 states). Under this rule its edges (20-150
// states) open no region, and it plans in 3.2-5.5x less time than FCL's checker idle and loaded.
constexpr std::size_t kMotionSerialStates = 64;
constexpr std::size_t kMotionParallelMinStates = 128;

// ---- The team.

// The team by load: with the machine busy, a worker shares a core with other work and the
// region's end waits for its scheduler slice (milliseconds). The OMPL example's edges of 644
// states, two threads each when forced, planned in 1,728 ms on the machine busy (load average
// about 6), in 209 ms with the team sized here (one thread). A probe costs 1.3 us.
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
