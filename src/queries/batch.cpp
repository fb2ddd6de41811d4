// Batched state and motion checks (include/cube_collision/batch.h): states on OpenMP threads,
// each thread with its StateChecker (queries/state_checker.h); motions keep per edge the first
// colliding state in the visiting order.

#include "cube_collision/batch.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <exception>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/parallel_for.h"
#include "cube_collision/narrow_phase.h"
#include "queries/motion_bounds.h"
#include "queries/state_checker.h"

namespace cube {

using detail::batchError;

namespace detail {
namespace {

// The threads of a call over `states` independent states (thread_policy.h): a region only from
// kParallelMinStates states, its team sized by regionTeam.
int batchThreads(std::size_t states, int threads) {
  return states < kParallelMinStates ? 1 : regionTeam(resolveThreads(threads));
}

// The number of states in `poses`, after checking it as the header says.
template <typename S>
std::size_t checkedStates(const Links<S>& links, const std::vector<fcl::Transform3<S>>& poses,
                          const char* where) {
  if (links.size() == 0) batchError(where, "the body set has no link");
  if (poses.size() % links.size() != 0)
    batchError(where, "the pose array's size (" + std::to_string(poses.size()) +
                          ") is not a multiple of the number of links (" +
                          std::to_string(links.size()) + ")");
  return poses.size() / links.size();
}

[[noreturn]] void badPose(const char* where, std::size_t index) {
  batchError(where, "pose " + std::to_string(index) + " has a NaN or infinite entry");
}

// The states of an edge of n states in `order`: rank r visits state visit[r].
void visitOrder(std::size_t n, MotionOrder order, std::vector<std::size_t>& visit,
                std::vector<std::pair<std::size_t, std::size_t>>& open) {
  visit.clear();
  if (order == MotionOrder::path || n < 2) {
    for (std::size_t i = 0; i < n; ++i) visit.push_back(i);
    return;
  }
  visit.push_back(n - 1);
  // The closed intervals left, breadth first: each is taken once, so a list with a head serves
  // as the queue.
  open.clear();
  open.emplace_back(0, n - 2);
  for (std::size_t head = 0; head < open.size(); ++head) {
    const auto [lo, hi] = open[head];
    const std::size_t mid = lo + (hi - lo) / 2;
    visit.push_back(mid);
    if (mid > lo) open.emplace_back(lo, mid - 1);
    if (mid < hi) open.emplace_back(mid + 1, hi);
  }
}

}  // namespace
}  // namespace detail

namespace detail {

// One thread's scratch of a batched check: the checker and, for poses written on demand, room
// for the states of one run; for a continuous check, room for a state's margin raises.
template <typename S>
struct MotionScratch {
  StateChecker<S> checker;
  std::vector<fcl::Transform3<S>> poses;  // reserved for a run; states made as they are written
  std::vector<S> raise;
  RaiseMemo<S> memo;
  // The neighbour a continuous check wrote past its run on demand (the state after the run's
  // last) and its room, one of the two rooms past a run's and its neighbour before: the next run
  // in path order starts at that state and reads it there rather than asking for it again (a
  // pose function may run a robot's kinematics). SIZE_MAX: none.
  std::size_t ahead = SIZE_MAX;
  std::size_t ahead_room = 0;
  // `run_states`: the most states of a run (0: poses are not written here); `continuous`: room
  // for the raises of a run.
  MotionScratch(const Broadphase<S>& world, const Links<S>& links, std::size_t run_states,
                bool continuous)
      : checker(world, links) {
    prepare(run_states, continuous, links.size());
  }
  // Ready for a call with these needs; nothing an earlier call wrote is read again (no memo; the
  // rooms an earlier call made stay, as each pose is written before it is read).
  void prepare(std::size_t run_states, bool continuous, std::size_t n) {
    if (poses.capacity() < run_states * n) poses.reserve(run_states * n);
    if (continuous && raise.size() < StateChecker<S>::kGroupStates * n)
      raise.resize(StateChecker<S>::kGroupStates * n);
    memo.after.resize(continuous ? n : 0);
    memo.before.resize(continuous ? n : 0);
    memo.interval = SIZE_MAX;
    ahead = SIZE_MAX;
  }
  // Room for the links' poses of the j-th state of a run (j < run_states). Made on first use: an
  // edge that collides early reads a few of its states, and making a run's room at once wrote
  // every pose of it.
  fcl::Transform3<S>* room(std::size_t j, std::size_t links) {
    assert((j + 1) * links <= poses.capacity());  // no reallocation: earlier rooms stay put
    if (poses.size() < (j + 1) * links) poses.resize((j + 1) * links);
    return poses.data() + j * links;
  }
};

// A BatchScratch's kept scratch and the world and links it was made for.
template <typename S>
struct ScratchSlot {
  std::unique_ptr<MotionScratch<S>> scratch;
  const Broadphase<S>* world = nullptr;
  const Links<S>* links = nullptr;
  std::uint64_t generation = 0;
};

// The bookkeeping of a motion check (firstCollisions), kept by a BatchScratch from call to call:
// a planner checks its edges one call each, and making these for each call cost about a tenth of
// a short edge's check.
struct EdgePlan {
  // A state of an edge at its rank in the edge's visiting order.
  struct Item {
    std::uint32_t edge;
    std::uint32_t rank;
    std::size_t state;
  };
  // Items placed together (StateChecker::placeGroup).
  struct Run {
    std::size_t first;  // item
    std::size_t count;
  };
  std::vector<Item> items;
  std::vector<Run> runs;
  // visitOrder of an edge of visit_states states in visit_order (a planner's edges often have
  // the same number of states, the planner's range over its resolution).
  std::vector<std::size_t> visit;
  std::size_t visit_states = SIZE_MAX;
  MotionOrder visit_order = MotionOrder::path;
  std::vector<std::pair<std::size_t, std::size_t>> open;  // visitOrder's queue
  std::vector<std::atomic<std::size_t>> best;             // per edge
  // `edges` entries in best, each kNoIndex.
  void resetBest(std::size_t edges) {
    if (best.size() != edges) std::vector<std::atomic<std::size_t>>(edges).swap(best);
    for (auto& b : best) b.store(kNoIndex, std::memory_order_relaxed);
  }
};

struct ScratchSlots {
  std::atomic<bool> busy{false};
  EdgePlan plan;
  ScratchSlot<float> for_float;
  ScratchSlot<double> for_double;
  template <typename S>
  ScratchSlot<S>& slot() {
    if constexpr (std::is_same<S, float>::value)
      return for_float;
    else
      return for_double;
  }
};

struct ScratchAccess {
  static ScratchSlots& slots(BatchScratch& s) {
    if (s.slots_ == nullptr) s.slots_ = std::make_unique<ScratchSlots>();  // made on first use
    return *s.slots_;
  }
};

// A thread's scratch in a call: its own, or the calling thread's (owned by CallerScratch).
template <typename S>
struct ScratchHandle {
  std::unique_ptr<MotionScratch<S>> own;
  MotionScratch<S>* at = nullptr;
  MotionScratch<S>& operator*() const { return *at; }
  MotionScratch<S>* operator->() const { return at; }
};

// The calling thread's scratch for one call: the one BatchOptions::scratch kept, where it was
// made for this world and these links (rebound to the world as it is now), else made; given back
// to it when the call returns (not when it throws: its state is then not trusted).
template <typename S>
class CallerScratch {
 public:
  CallerScratch(const BatchOptions& options, const Broadphase<S>& world, const Links<S>& links,
                std::size_t run_states, bool continuous, const char* where)
      : world_(world),
        links_(links),
        run_states_(run_states),
        continuous_(continuous),
        thread_(std::this_thread::get_id()) {
    if (options.scratch == nullptr) return;
    ScratchSlots& slots = ScratchAccess::slots(*options.scratch);
    if (slots.busy.exchange(true, std::memory_order_acquire))
      throw std::logic_error(std::string("cube::") + where +
                             ": its BatchScratch is in use by another call");
    slots_ = &slots;
    plan_ = &slots.plan;
    ScratchSlot<S>& kept = slots.slot<S>();
    if (kept.scratch != nullptr && kept.world == &world && kept.links == &links &&
        kept.generation == links.generation) {
      held_ = std::move(kept.scratch);
      held_->checker.rebind();
      held_->checker.openScope();
      held_->prepare(run_states, continuous, links.size());
    }
    kept.scratch.reset();  // one made for another world or body: freed now
  }
  ~CallerScratch() {
    if (slots_ == nullptr) return;
    if (held_ != nullptr && std::uncaught_exceptions() == exceptions_) {
      held_->checker.closeScope();
      ScratchSlot<S>& kept = slots_->slot<S>();
      kept.scratch = std::move(held_);
      kept.world = &world_;
      kept.links = &links_;
      kept.generation = links_.generation;
    }
    held_.reset();
    slots_->busy.store(false, std::memory_order_release);
  }
  CallerScratch(const CallerScratch&) = delete;
  CallerScratch& operator=(const CallerScratch&) = delete;

  // The motion check's bookkeeping: the kept scratch's, else this call's.
  EdgePlan& plan() {
    if (plan_ == nullptr) plan_ = &own_plan_.emplace();
    return *plan_;
  }
  // The calling thread's scratch (made on first use); another thread's own, made for it.
  ScratchHandle<S> forThisThread() {
    ScratchHandle<S> h;
    if (std::this_thread::get_id() != thread_) {
      h.own = make();
      h.at = h.own.get();
      return h;
    }
    if (held_ == nullptr) held_ = make();
    h.at = held_.get();
    return h;
  }

 private:
  std::unique_ptr<MotionScratch<S>> make() const {
    return std::make_unique<MotionScratch<S>>(world_, links_, run_states_, continuous_);
  }
  const Broadphase<S>& world_;
  const Links<S>& links_;
  const std::size_t run_states_;
  const bool continuous_;
  const std::thread::id thread_;
  const int exceptions_ = std::uncaught_exceptions();
  ScratchSlots* slots_ = nullptr;
  std::unique_ptr<MotionScratch<S>> held_;
  std::optional<EdgePlan> own_plan_;  // made only by a motion check without a kept scratch
  EdgePlan* plan_ = nullptr;
};

namespace {

// checkStates over `states` states whose poses pose_at(scratch, state, j) gives (the j-th state
// of a run), into `out`: runs of consecutive states, placed together where they lie close
// (StateChecker::placeGroup), on the threads; `run_states`: the thread's room for poses.
template <typename S, class PoseAt>
void checkStateRuns(const Broadphase<S>& core, const Links<S>& links, std::size_t states,
                    const BatchOptions& options, std::size_t run_states,
                    std::vector<StateResult<S>>& out, const PoseAt& pose_at) {
  constexpr std::size_t kRun = StateChecker<S>::kGroupStates;
  const std::size_t n = links.size();
  const auto check_run = [&](auto& scratch, std::size_t run) {
    const std::size_t first = run * kRun;
    const std::size_t count = std::min(kRun, states - first);
    const fcl::Transform3<S>* at[kRun];
    for (std::size_t j = 0; j < count; ++j) at[j] = pose_at(*scratch, first + j, j);
    StateChecker<S>& checker = scratch->checker;
    for (std::size_t done = 0; done < count;) {
      const std::size_t took = checker.placeGroup(at + done, count - done, options.self_collision);
      for (std::size_t j = 0; j < took; ++j) {
        const std::size_t k = first + done + j;
        const int answer = checker.checkPlaced(j, options.self_collision, options.first_pair,
                                               options.clearance, &out[k]);
        if (answer == StateChecker<S>::kBadPose) badPose("checkStates", k * n + checker.badLink());
        out[k].colliding = answer != 0;
        if (out[k].colliding && options.clearance) out[k].clearance = S(0);
      }
      done += took;
    }
  };
  CallerScratch<S> caller(options, core, links, run_states, false, "checkStates");
  parallelForWith((states + kRun - 1) / kRun, batchThreads(states, options.threads), 1,
                  [&] { return caller.forThisThread(); }, check_run);
}

// A discrete check: no state's margins raised.
struct NoRaise {};

// checkMotions over `states` states whose poses pose_at(scratch, state, j) gives (a pointer to
// the links' poses, the j-th state of a run placed together; j = kGroupStates and the next for
// a neighbour of a state that its run does not hold), `edges` edges starting at edge_starts[0 ..
// edges) (checked by the caller), each edge's first colliding state (kNoIndex: none) into
// first[0 .. edges). A continuous check: raise_at(state, edge begin, edge end, raise, bad,
// poses_of) writes the links' margin raises of a state to raise[0 .. links), or sets `bad` to
// the index of a pose it read with a NaN or infinite entry; poses_of(k) gives the poses of the
// state or of a neighbour in its edge.
template <typename S, class PoseAt, class RaiseAt = NoRaise>
void firstCollisions(const Broadphase<S>& core, const Links<S>& links, std::size_t states,
                     const std::size_t* edge_starts, std::size_t edges, MotionOrder order,
                     const BatchOptions& options, bool on_demand, const PoseAt& pose_at,
                     std::size_t* first, const RaiseAt& raise_at = RaiseAt()) {
  constexpr bool continuous = !std::is_same<RaiseAt, NoRaise>::value;
  std::fill(first, first + edges, kNoIndex);
  if (edges == 0) return;
  core.table().wantVolumes();
  const auto edge_end = [&](std::size_t e) { return e + 1 < edges ? edge_starts[e + 1] : states; };
  constexpr std::size_t kRun = StateChecker<S>::kGroupStates;
  std::size_t longest = 0;  // the most states of an edge
  for (std::size_t e = 0; e < edges; ++e) longest = std::max(longest, edge_end(e) - edge_starts[e]);
  // Room for a run's states, and with raises from the poses, for its neighbour before and two
  // rooms in turn for the one after (MotionScratch::ahead).
  const std::size_t run_states = !on_demand   ? 0
                                 : continuous ? kRun + 3
                                              : std::min(longest, StateChecker<S>::kGroupStates);
  CallerScratch<S> caller(options, core, links, run_states, continuous, "checkMotions");
  EdgePlan& plan = caller.plan();
  // Items in edge order, each edge's states in visiting order: edge e's take the places of
  // its states, edge_starts[e] ...
  using Item = EdgePlan::Item;
  std::vector<Item>& items = plan.items;
  items.resize(states);
  for (std::size_t e = 0, item = 0; e < edges; ++e) {
    const std::size_t begin = edge_starts[e];
    if (edge_end(e) - begin != plan.visit_states || order != plan.visit_order) {
      visitOrder(edge_end(e) - begin, order, plan.visit, plan.open);
      plan.visit_states = edge_end(e) - begin;
      plan.visit_order = order;
    }
    for (std::size_t r = 0; r < plan.visit.size(); ++r, ++item)
      items[item] = Item{std::uint32_t(e), std::uint32_t(r), begin + plan.visit[r]};
  }
  // Runs of items placed together (StateChecker::placeGroup): per edge runs of consecutive ranks
  // of 5, 8, 16 states and then kGroupStates in path order (states consecutive along an edge lie
  // close together and share a walk); in bisection order the first state alone, then 4, 8, 16,
  // kGroupStates (its first ranks lie far apart: the first answers an edge whose end collides,
  // without reading more). A run's states are read before any is checked: a run starting at
  // rank s holds at most s + 3 states (5 from the first), so an answer at rank r reads at most
  // max(5, 2 r + 3) states.
  using Run = EdgePlan::Run;
  std::vector<Run>& runs = plan.runs;
  runs.clear();
  for (std::size_t e = 0; e < edges; ++e) {
    const std::size_t begin = edge_starts[e];
    const std::size_t end = edge_end(e);
    const std::size_t size0 = order == MotionOrder::path ? 5 : 1;
    for (std::size_t i = begin, size = size0; i < end;) {
      runs.push_back(Run{i, std::min(size, end - i)});
      i += size;
      size = size == 1 ? 4 : size == 5 ? 8 : std::min(kRun, 2 * size);
    }
  }
  // Per edge: the lowest rank known to collide (or to hold a bad pose).
  plan.resetBest(edges);
  std::vector<std::atomic<std::size_t>>& best = plan.best;
  std::vector<std::pair<std::size_t, std::size_t>> bad;  // (item, pose index): rare
  const std::size_t n = links.size();
  // The states of run r in rank order, up to the edge's first collision; the number checked.
  const auto check = [&](auto& scratch, std::size_t r) -> std::size_t {
    const Run& run = runs[r];
    std::atomic<std::size_t>& b = best[items[run.first].edge];
    const std::size_t seen = b.load(std::memory_order_relaxed);
    std::size_t count = 0;  // an earlier rank collides: the states after it are not read
    while (count < run.count && items[run.first + count].rank <= seen) ++count;
    if (count == 0) return 0;
    const fcl::Transform3<S>* at[kRun];
    std::size_t j0 = 0;
    if constexpr (continuous) {
      if (on_demand && items[run.first].state == scratch->ahead) {
        at[0] = scratch->room(scratch->ahead_room, n);  // written by the run before
        j0 = 1;
      }
    }
    for (std::size_t j = j0; j < count; ++j)
      at[j] = pose_at(*scratch, items[run.first + j].state, j);
    // Item i's event (a contact, or a pose error: bad_pose) at its rank.
    const auto event = [&](std::size_t i, std::size_t bad_pose) {
      const Item& item = items[i];
      if (bad_pose != kNoIndex) {
        // As a contact: no state after it in the order is started, and the serial scan's
        // first event decides (a pose error before any contact throws).
#pragma omp critical(cube_batch_bad_pose)
        bad.emplace_back(i, bad_pose);
      }
      std::size_t known = b.load(std::memory_order_relaxed);
      while (item.rank < known &&
             !b.compare_exchange_weak(known, item.rank, std::memory_order_relaxed)) {
      }
    };
    // A continuous check: each state's raised margins, up to the first whose bounds read a bad
    // pose (checked as the event at its place once the states before it are free).
    const S* raises[kRun];
    std::size_t raised = count, raise_bad = kNoIndex;
    if constexpr (continuous) {
      const std::uint32_t e = items[run.first].edge;
      const std::size_t begin = edge_starts[e];
      const std::size_t end = edge_end(e);
      for (std::size_t j = 0; j < count; ++j) {
        S* raise = scratch->raise.data() + j * n;
        const std::size_t k = items[run.first + j].state;
        // A neighbour's poses: from the run where it holds them (consecutive states in path
        // order), else written into the room's two places past a run's.
        const auto poses_of = [&](std::size_t s) -> const fcl::Transform3<S>* {
          if (!on_demand) return pose_at(*scratch, s, 0);  // the caller's array
          if (s == k) return at[j];
          if (j > 0 && items[run.first + j - 1].state == s) return at[j - 1];
          if (j + 1 < count && items[run.first + j + 1].state == s) return at[j + 1];
          if (s < k) return pose_at(*scratch, s, kRun);
          if (s == scratch->ahead) return scratch->room(scratch->ahead_room, n);
          // Into the room that at[0] does not hold.
          const std::size_t room = scratch->ahead_room == kRun + 1 ? kRun + 2 : kRun + 1;
          const fcl::Transform3<S>* written = pose_at(*scratch, s, room);
          scratch->ahead = s;
          scratch->ahead_room = room;
          return written;
        };
        raise_at(k, begin, end, raise, raise_bad, poses_of, scratch->memo);
        if (raise_bad != kNoIndex) {
          raised = j;
          break;
        }
        raises[j] = raise;
      }
    }
    for (std::size_t done = 0; done < raised;) {
      const std::size_t took = scratch->checker.placeGroup(
          at + done, raised - done, options.self_collision, continuous ? raises + done : nullptr);
      for (std::size_t j = 0; j < took; ++j) {
        const std::size_t i = run.first + done + j;
        const Item& item = items[i];
        if (item.rank > b.load(std::memory_order_relaxed)) return done + j;  // an earlier one
        const int answer =
            scratch->checker.checkPlaced(j, options.self_collision, false, false, nullptr);
        if (answer == 0) continue;
        event(i, answer == StateChecker<S>::kBadPose ? item.state * n + scratch->checker.badLink()
                                                     : kNoIndex);
        return done + j + 1;
      }
      done += took;
    }
    if (raised < count) {
      if (items[run.first + raised].rank > b.load(std::memory_order_relaxed)) return raised;
      event(run.first + raised, raise_bad);
      return raised + 1;
    }
    return count;
  };

  // An edge stops at its first colliding state (thread_policy.h): a lone edge's first
  // kMotionSerialStates states checked run on this thread, and the runs left go to the threads
  // only if at least kMotionParallelMinStates of their states are still undecided. Several edges
  // are independent scans: their runs go to the threads from kParallelMinStates undecided on.
  std::size_t next = 0;
  int team = 1;
  // The calling thread's checker: made once, kept for its share of a region (a checker costs
  // as much to make as tens of states).
  ScratchHandle<S> mine = caller.forThisThread();
  {
    auto& scratch = mine;
    const std::size_t prefix = edges == 1 ? kMotionSerialStates : 0;
    const std::size_t min_left = edges == 1 ? kMotionParallelMinStates : kParallelMinStates;
    for (std::size_t checked = 0; next < runs.size() && checked < prefix; ++next)
      checked += check(scratch, next);
    std::size_t undecided = 0;
    if (next < runs.size() && resolveThreads(options.threads) > 1)
      for (std::size_t r = next; r < runs.size(); ++r)
        if (best[items[runs[r].first].edge].load(std::memory_order_relaxed) == kNoIndex)
          undecided += runs[r].count;
    if (undecided >= min_left) team = regionTeam(resolveThreads(options.threads));
    if (team <= 1)
      for (; next < runs.size(); ++next) check(scratch, next);
  }
  if (next < runs.size())
    parallelForWith(
        runs.size() - next, team, 1, [&] { return caller.forThisThread(); },
        [&](auto& scratch, std::size_t k) { check(scratch, next + k); });
  // The earliest event of each edge in its order: a pose error there throws, edge by edge.
  std::sort(bad.begin(), bad.end());
  for (const auto& [i, pose] : bad)
    if (best[items[i].edge].load(std::memory_order_relaxed) == items[i].rank)
      badPose("checkMotions", pose);
  for (std::size_t e = 0; e < edges; ++e) {
    const std::size_t r = best[e].load(std::memory_order_relaxed);
    if (r != kNoIndex) first[e] = items[edge_starts[e] + r].state - edge_starts[e];
  }
}

// firstCollisions with the raises options.continuous asks for: the SE(3) bounds from the poses,
// or none.
template <typename S, class PoseAt>
void firstCollisionsAsAsked(const Broadphase<S>& core, const Links<S>& links, std::size_t states,
                            const std::size_t* edge_starts, std::size_t edges, MotionOrder order,
                            const BatchOptions& options, bool on_demand, const PoseAt& pose_at,
                            std::size_t* first) {
  if (options.continuous)
    firstCollisions(core, links, states, edge_starts, edges, order, options, on_demand, pose_at,
                    first, Se3Raise<S>{linkReach<S>(links)});
  else
    firstCollisions(core, links, states, edge_starts, edges, order, options, on_demand, pose_at,
                    first);
}

}  // namespace
}  // namespace detail

namespace detail {
namespace {

// checkMotions' check of its edge starts against its number of states.
void checkEdgeStarts(std::size_t states, const std::vector<std::size_t>& edge_starts) {
  if (edge_starts.empty() && states > 0)
    batchError("checkMotions", "states given without edge_starts (every state needs an edge)");
  for (std::size_t e = 0; e < edge_starts.size(); ++e)
    if ((e == 0 && edge_starts[0] != 0) || (e > 0 && edge_starts[e] <= edge_starts[e - 1]) ||
        edge_starts[e] >= states)
      batchError("checkMotions",
                 "edge_starts must start at 0 and increase strictly within the states");
}

// checkMotions' checks of its arguments; the number of states.
template <typename S>
std::size_t checkedEdges(const Links<S>& links, const std::vector<fcl::Transform3<S>>& poses,
                         const std::vector<std::size_t>& edge_starts) {
  const std::size_t states = checkedStates(links, poses, "checkMotions");
  checkEdgeStarts(states, edge_starts);
  return states;
}

// checkMotions' checks of its arguments over a pose function, before any work.
template <typename S>
void checkPoseEdges(const Links<S>& links, std::size_t states,
                    const std::vector<std::size_t>& edge_starts, const PoseFunction<S>& pose_of) {
  if (links.size() == 0) batchError("checkMotions", "the body set has no link");
  if (!pose_of) batchError("checkMotions", "null pose function");
  checkEdgeStarts(states, edge_starts);
}

// The runs' pose sources (pose_at(scratch, state, j) above): the caller's array, n poses a
// state, read in place.
template <typename S>
struct ArrayPoses {
  const fcl::Transform3<S>* poses;
  std::size_t n;
  template <class Scratch>
  const fcl::Transform3<S>* operator()(Scratch&, std::size_t state, std::size_t) const {
    return poses + state * n;
  }
};

// The caller's pose function, writing a state's n poses into the thread's room j.
template <typename S>
struct FunctionPoses {
  const PoseFunction<S>& pose_of;
  std::size_t n;
  template <class Scratch>
  const fcl::Transform3<S>* operator()(Scratch& scratch, std::size_t state, std::size_t j) const {
    fcl::Transform3<S>* at = scratch.room(j, n);
    pose_of(state, at);
    return at;
  }
};

}  // namespace
}  // namespace detail

template <typename S>
std::vector<StateResult<S>> checkStates(const CubeCollisionManager<S>& world,
                                        const BodySet<S>& body,
                                        const std::vector<fcl::Transform3<S>>& poses,
                                        const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  const std::size_t states = detail::checkedStates(links, poses, "checkStates");
  std::vector<StateResult<S>> out(states);
  const detail::Broadphase<S>& core = detail::coreOf(world);
  core.table().wantVolumes();
  const std::size_t n = links.size();
  detail::checkStateRuns(core, links, states, options, 0, out,
                         detail::ArrayPoses<S>{poses.data(), n});
  return out;
}

template <typename S>
std::vector<std::size_t> checkMotions(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                                      const std::vector<fcl::Transform3<S>>& poses,
                                      const std::vector<std::size_t>& edge_starts,
                                      MotionOrder order, const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  const std::size_t states = detail::checkedEdges(links, poses, edge_starts);
  const std::size_t n = links.size();
  const detail::ArrayPoses<S> pose_at{poses.data(), n};
  std::vector<std::size_t> first(edge_starts.size());
  detail::firstCollisionsAsAsked(detail::coreOf(world), links, states, edge_starts.data(),
                                 edge_starts.size(), order, options, false, pose_at, first.data());
  return first;
}

template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body,
    const std::vector<fcl::Transform3<S>>& poses, const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds, MotionOrder order,
    const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  const std::size_t states = detail::checkedEdges(links, poses, edge_starts);
  detail::checkMotionBounds(motion_bounds, poses.size(), "checkMotions");
  const std::size_t n = links.size();
  std::vector<std::size_t> first(edge_starts.size());
  detail::firstCollisions(detail::coreOf(world), links, states, edge_starts.data(),
                          edge_starts.size(), order, options, false,
                          detail::ArrayPoses<S>{poses.data(), n}, first.data(),
                          detail::GivenRaise<S>{motion_bounds, n});
  return first;
}

template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        const std::vector<fcl::Transform3<S>>& poses,
                        const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
                        MotionOrder order, const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  const std::size_t states = detail::checkedStates(links, poses, "checkMotions");
  detail::checkMotionBounds(motion_bounds, poses.size(), "checkMotions");
  const std::size_t n = links.size();
  const std::size_t start = 0;
  std::size_t first = kNoIndex;
  detail::firstCollisions(detail::coreOf(world), links, states, &start, states == 0 ? 0 : 1, order,
                          options, false, detail::ArrayPoses<S>{poses.data(), n}, &first,
                          detail::GivenRaise<S>{motion_bounds, n});
  return first;
}

template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        const std::vector<fcl::Transform3<S>>& poses, MotionOrder order,
                        const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  const std::size_t states = detail::checkedStates(links, poses, "checkMotions");
  const std::size_t n = links.size();
  const detail::ArrayPoses<S> pose_at{poses.data(), n};
  const std::size_t start = 0, edges = states == 0 ? 0 : 1;
  std::size_t first = kNoIndex;
  detail::firstCollisionsAsAsked(detail::coreOf(world), links, states, &start, edges, order,
                                 options, false, pose_at, &first);
  return first;
}

template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        std::size_t states,
                        const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
                        MotionOrder order, const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  if (links.size() == 0) batchError("checkMotion", "the body set has no link");
  if (!pose_of) batchError("checkMotion", "null pose function");
  if (states == 0) return kNoIndex;
  const std::size_t start = 0;
  std::size_t first = kNoIndex;
  const detail::FunctionPoses<S> pose_at{pose_of, links.size()};
  detail::firstCollisionsAsAsked(detail::coreOf(world), links, states, &start, 1, order, options,
                                 true, pose_at, &first);
  return first;
}

template <typename S>
std::vector<StateResult<S>> checkStates(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of, const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  if (links.size() == 0) batchError("checkStates", "the body set has no link");
  if (!pose_of) batchError("checkStates", "null pose function");
  std::vector<StateResult<S>> out(states);
  const detail::Broadphase<S>& core = detail::coreOf(world);
  core.table().wantVolumes();
  const std::size_t n = links.size();
  // Each run's poses written into the thread's room for a run.
  detail::checkStateRuns(core, links, states, options,
                         std::min(detail::StateChecker<S>::kGroupStates, states), out,
                         detail::FunctionPoses<S>{pose_of, n});
  return out;
}

template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of, MotionOrder order,
    const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  detail::checkPoseEdges(links, states, edge_starts, pose_of);
  const detail::FunctionPoses<S> pose_at{pose_of, links.size()};
  std::vector<std::size_t> first(edge_starts.size());
  detail::firstCollisionsAsAsked(detail::coreOf(world), links, states, edge_starts.data(),
                                 edge_starts.size(), order, options, true, pose_at, first.data());
  return first;
}

template <typename S>
std::vector<std::size_t> checkMotions(
    const CubeCollisionManager<S>& world, const BodySet<S>& body, std::size_t states,
    const std::vector<std::size_t>& edge_starts,
    const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
    const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds, MotionOrder order,
    const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  detail::checkPoseEdges(links, states, edge_starts, pose_of);
  detail::checkMotionBounds(motion_bounds, states * links.size(), "checkMotions");
  std::vector<std::size_t> first(edge_starts.size());
  detail::firstCollisions(detail::coreOf(world), links, states, edge_starts.data(),
                          edge_starts.size(), order, options, true,
                          detail::FunctionPoses<S>{pose_of, links.size()}, first.data(),
                          detail::GivenRaise<S>{motion_bounds, links.size()});
  return first;
}

template <typename S>
std::size_t checkMotion(const CubeCollisionManager<S>& world, const BodySet<S>& body,
                        std::size_t states,
                        const typename detail::NoDeduce<PoseFunction<S>>::type& pose_of,
                        const typename detail::NoDeduce<MotionBounds<S>>::type& motion_bounds,
                        MotionOrder order, const BatchOptions& options) {
  const auto& links = detail::BodyAccess::links(body);
  if (links.size() == 0) batchError("checkMotion", "the body set has no link");
  if (!pose_of) batchError("checkMotion", "null pose function");
  detail::checkMotionBounds(motion_bounds, states * links.size(), "checkMotion");
  if (states == 0) return kNoIndex;
  const std::size_t start = 0;
  std::size_t first = kNoIndex;
  detail::firstCollisions(detail::coreOf(world), links, states, &start, 1, order, options, true,
                          detail::FunctionPoses<S>{pose_of, links.size()}, &first,
                          detail::GivenRaise<S>{motion_bounds, links.size()});
  return first;
}

BatchScratch::BatchScratch() = default;
BatchScratch::~BatchScratch() = default;
BatchScratch::BatchScratch(BatchScratch&& other) noexcept = default;
BatchScratch& BatchScratch::operator=(BatchScratch&& other) noexcept = default;
void BatchScratch::release() {
  if (slots_ == nullptr) return;
  if (slots_->busy.exchange(true, std::memory_order_acquire))
    throw std::logic_error("cube::BatchScratch::release: in use by a call");
  slots_->for_float = {};
  slots_->for_double = {};
  slots_->plan = {};
  slots_->busy.store(false, std::memory_order_release);
}

#define CUBE_INSTANTIATE_BATCH(S)                                                                  \
  template std::vector<StateResult<S>> checkStates<S>(                                             \
      const CubeCollisionManager<S>&, const BodySet<S>&, const std::vector<fcl::Transform3<S>>&,   \
      const BatchOptions&);                                                                        \
  template std::vector<std::size_t> checkMotions<S>(                                               \
      const CubeCollisionManager<S>&, const BodySet<S>&, const std::vector<fcl::Transform3<S>>&,   \
      const std::vector<std::size_t>&, MotionOrder, const BatchOptions&);                          \
  template std::size_t checkMotion<S>(const CubeCollisionManager<S>&, const BodySet<S>&,           \
                                      const std::vector<fcl::Transform3<S>>&, MotionOrder,         \
                                      const BatchOptions&);                                        \
  template std::size_t checkMotion<S>(const CubeCollisionManager<S>&, const BodySet<S>&,           \
                                      std::size_t, const PoseFunction<S>&, MotionOrder,            \
                                      const BatchOptions&);                                        \
  template std::vector<std::size_t> checkMotions<S>(                                               \
      const CubeCollisionManager<S>&, const BodySet<S>&, const std::vector<fcl::Transform3<S>>&,   \
      const std::vector<std::size_t>&, const MotionBounds<S>&, MotionOrder, const BatchOptions&);  \
  template std::size_t checkMotion<S>(const CubeCollisionManager<S>&, const BodySet<S>&,           \
                                      const std::vector<fcl::Transform3<S>>&,                      \
                                      const MotionBounds<S>&, MotionOrder, const BatchOptions&);   \
  template std::size_t checkMotion<S>(const CubeCollisionManager<S>&, const BodySet<S>&,           \
                                      std::size_t, const PoseFunction<S>&, const MotionBounds<S>&, \
                                      MotionOrder, const BatchOptions&);                           \
  template std::vector<StateResult<S>> checkStates<S>(                                             \
      const CubeCollisionManager<S>&, const BodySet<S>&, std::size_t, const PoseFunction<S>&,      \
      const BatchOptions&);                                                                        \
  template std::vector<std::size_t> checkMotions<S>(                                               \
      const CubeCollisionManager<S>&, const BodySet<S>&, std::size_t,                              \
      const std::vector<std::size_t>&, const PoseFunction<S>&, MotionOrder, const BatchOptions&);
CUBE_INSTANTIATE_BATCH(double)
CUBE_INSTANTIATE_BATCH(float)
#undef CUBE_INSTANTIATE_BATCH

#define CUBE_INSTANTIATE_BATCH_POSE_BOUNDS(S)                                          \
  template std::vector<std::size_t> checkMotions<S>(                                   \
      const CubeCollisionManager<S>&, const BodySet<S>&, std::size_t,                  \
      const std::vector<std::size_t>&, const PoseFunction<S>&, const MotionBounds<S>&, \
      MotionOrder, const BatchOptions&);
CUBE_INSTANTIATE_BATCH_POSE_BOUNDS(double)
CUBE_INSTANTIATE_BATCH_POSE_BOUNDS(float)
#undef CUBE_INSTANTIATE_BATCH_POSE_BOUNDS

}  // namespace cube
