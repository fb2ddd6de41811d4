// A real planner on the batched checks: OMPL's RRTConnect plans a 7-joint arm through a world of
// obstacles, once with a StateValidityChecker and a MotionValidator built on cube::checkStates /
// cube::checkMotion, once the way FCL users write them today (each link's setTransform and
// computeAABB, world->collide(link) link by link on FCL's DynamicAABBTreeCollisionManager, a
// robot manager's self-collide, OMPL's DiscreteMotionValidator over that checker). Same
// problems, same seeds: identical answers give identical exploration, so the example checks that
// both found the very same paths, and prints the planning times, each checker's time inside its
// checks and the planner's own time (the rest). A third run per problem checks the edges
// continuously (cube::checkMotion with motion bounds from the arm's kinematics: an edge is valid
// only if no link can touch anything between its states), same seeds; its paths differ (it
// refuses edges the discrete check accepts), so the example checks every path it found, and the
// discrete runs' too, on a subdivision 100 times finer with FCL, and prints the counts.
//
// Usage: ompl_planner [world objects] [problems] [threads] [object size scale] [--load N]
//                     [--resolution R] [--refine F]
// (default 2000 5 0 1.0: BatchOptions' default threads, the hardware's). The planner keeps OMPL's
// defaults: RRTConnect's range (a fifth of the space's extent) and the motion checks' resolution
// (1% of it), unless --resolution sets that fraction; the continuous run checks F times as many
// states (default kRefine). --load N runs N spinning processes beside
// the planning (a loaded machine).

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <ompl/base/DiscreteMotionValidator.h>
#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "arm.h"
#include "busy_load.h"
#include "cube_collision/batch.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

using S = double;
using Object = fcl::CollisionObjectd;
using Poses = std::vector<fcl::Transform3d>;
constexpr int kJoints = cube::scenes::kArmJoints;
constexpr double kLength = cube::scenes::kArmLink;
// The continuous run's states per state of OMPL's resolution: its motion bounds shrink with the
// states' spacing, and with OMPL's own spacing they raise the links so much that links two apart
// (always within one link length of each other) count as touching.
constexpr int kRefine = 32;

// ---- The arm (examples/scenes/arm.h) ------------------------------------------------------------

using cube::scenes::armGeometry;
using cube::scenes::armPoses;  // forward kinematics

const double* jointsOf(const ob::State* s) {
  return s->as<ob::RealVectorStateSpace::StateType>()->values;
}

// ---- Time inside the checks --------------------------------------------------------------------

// Wall time spent inside a planning run's validity and motion checks (kinematics, interpolation and
// OMPL's DiscreteMotionValidator included), so that the rest, the planner's own work, can be told
// apart: the same for both checkers, since they explore the same states. Only the outermost check
// counts (DiscreteMotionValidator calls isValid from inside a motion check). One planner thread.
class CheckClock {
 public:
  class Scope {
   public:
    explicit Scope(CheckClock& clock) : clock_(clock) {
      if (clock_.depth_++ == 0) start_ = std::chrono::steady_clock::now();
    }
    ~Scope() {
      if (--clock_.depth_ == 0)
        clock_.seconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    CheckClock& clock_;
    std::chrono::steady_clock::time_point start_;
  };
  double seconds() const { return seconds_; }

 private:
  int depth_ = 0;
  double seconds_ = 0;
};

// ---- Checkers built on the batched checks ------------------------------------------------------

// The set-up the checks keep between calls (cube::BatchScratch), one per planner thread: OMPL
// may call a checker from several threads at once, and a scratch serves one call at a time.
cube::BatchOptions withThreadScratch(cube::BatchOptions options) {
  thread_local cube::BatchScratch scratch;
  options.scratch = &scratch;
  return options;
}

class CubeValidity final : public ob::StateValidityChecker {
 public:
  CubeValidity(const ob::SpaceInformationPtr& si, const cube::CubeCollisionManagerd& world,
               const cube::BodySet<S>& body, int threads, CheckClock& clock)
      : ob::StateValidityChecker(si), world_(world), body_(body), clock_(clock) {
    options_.self_collision = true;
    options_.threads = threads;
  }
  bool isValid(const ob::State* s) const override {
    const CheckClock::Scope timed(clock_);
    Poses poses(kJoints);  // const and thread-safe, as OMPL asks: no member is written
    armPoses(jointsOf(s), poses.data());
    return !cube::checkStates(world_, body_, poses, withThreadScratch(options_))[0].colliding;
  }

 private:
  const cube::CubeCollisionManagerd& world_;
  const cube::BodySet<S>& body_;
  cube::BatchOptions options_;
  CheckClock& clock_;
};

// The states DiscreteMotionValidator checks (j / nd for j = 1 .. nd), in one call, in its order
// (the last state, then midpoints breadth first): the same answer. Each state's joints are
// interpolated as RealVectorStateSpace::interpolate does and its poses computed only when the
// check reads it (cube::PoseFunction): an edge that collides early costs no kinematics after.
//
// Continuous (a third run): the states j = 0 .. nd, s1 included (the motion from s1 to the first
// state counts too), with each link's motion bound between consecutive states from the
// kinematics: joint j turns the points of link l >= j about an axis through its joint, all
// within (l - j + 1.01) link lengths of it, so a point of link l moves at most the sum over
// j <= l of |dq_j| (l - j + 1.01) lengths while the joints move linearly by dq.
class CubeMotion final : public ob::MotionValidator {
 public:
  CubeMotion(const ob::SpaceInformationPtr& si, const cube::CubeCollisionManagerd& world,
             const cube::BodySet<S>& body, int threads, int refine, CheckClock& clock)
      : ob::MotionValidator(si), world_(world), body_(body), refine_(refine), clock_(clock) {
    options_.self_collision = true;
    options_.threads = threads;
  }
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const CheckClock::Scope timed(clock_);
    const bool ok = firstColliding(s1, s2, cube::MotionOrder::bisection).first == cube::kNoIndex;
    if (ok)
      ++valid_;
    else
      ++invalid_;
    return ok;
  }
  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    const CheckClock::Scope timed(clock_);
    // Path order: the first colliding state, as DiscreteMotionValidator reports it.
    const auto [first, nd] = firstColliding(s1, s2, cube::MotionOrder::path);
    if (first == cube::kNoIndex) {
      ++valid_;
      return true;
    }
    // State `first` is j = first + 1 (continuous: j = first, s1 being j = 0); the one before
    // it is the last valid (continuous: s1 if s1's own grown check fails).
    const std::size_t j = refine_ > 0 ? first : first + 1;
    last_valid.second = double(j > 0 ? j - 1 : 0) / double(nd);
    if (last_valid.first != nullptr)
      si_->getStateSpace()->interpolate(s1, s2, last_valid.second, last_valid.first);
    ++invalid_;
    return false;
  }

 private:
  std::pair<std::size_t, int> firstColliding(const ob::State* s1, const ob::State* s2,
                                             cube::MotionOrder order) const {
    const int nd = si_->getStateSpace()->validSegmentCount(s1, s2) * std::max(refine_, 1);
    const double* from = jointsOf(s1);
    const double* to = jointsOf(s2);
    const std::size_t first_j = refine_ > 0 ? 0 : 1;
    const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* poses) {
      const double t = double(k + first_j) / double(nd);
      double q[kJoints];
      for (int i = 0; i < kJoints; ++i) q[i] = from[i] + (to[i] - from[i]) * t;
      armPoses(q, poses);
    };
    const std::size_t states = std::size_t(nd) + 1 - first_j;
    states_ += states;
    const cube::BatchOptions options = withThreadScratch(options_);
    if (refine_ == 0)
      return {cube::checkMotion(world_, body_, states, pose_of, order, options), nd};
    double step[kJoints];  // per link, the same for every step of the edge
    for (int l = 0; l < kJoints; ++l) {
      double b = 0;
      for (int j = 0; j <= l; ++j) b += std::abs(to[j] - from[j]) * (l - j + 1.01) * kLength;
      step[l] = b / double(nd);
    }
    // Kept between calls on this thread (a planner checks many edges): no allocation per edge.
    thread_local std::vector<S> bounds;
    bounds.resize(states * kJoints);
    for (std::size_t k = 0; k < states; ++k)
      std::copy(step, step + kJoints, bounds.begin() + std::ptrdiff_t(k * kJoints));
    return {cube::checkMotion(world_, body_, states, pose_of, bounds, order, options), nd};
  }

  const cube::CubeCollisionManagerd& world_;
  const cube::BodySet<S>& body_;
  cube::BatchOptions options_;
  int refine_;  // 0: discrete; else continuous on `refine_` times OMPL's states
  CheckClock& clock_;

 public:
  mutable std::size_t states_ = 0;  // states of the edges checked (one planner thread)
};

// ---- The checker FCL users write today ----------------------------------------------------------

class FclValidity final : public ob::StateValidityChecker {
 public:
  FclValidity(const ob::SpaceInformationPtr& si, const fcl::BroadPhaseCollisionManagerd& world,
              const std::vector<std::shared_ptr<fcl::CollisionGeometryd>>& geometry,
              CheckClock& clock)
      : ob::StateValidityChecker(si), world_(world), clock_(clock) {
    std::vector<Object*> ptrs;
    for (std::size_t i = 0; i < geometry.size(); ++i) {
      links_.push_back(std::make_unique<Object>(geometry[i]));
      links_.back()->setUserData(reinterpret_cast<void*>(i));
      ptrs.push_back(links_.back().get());
    }
    robot_.registerObjects(ptrs);
    robot_.setup();
  }
  // OMPL's checkers are const; this one writes its link objects (one planner thread only).
  bool isValid(const ob::State* s) const override {
    const CheckClock::Scope timed(clock_);
    Poses poses(kJoints);
    armPoses(jointsOf(s), poses.data());
    for (int i = 0; i < kJoints; ++i) {
      links_[i]->setTransform(poses[i]);
      links_[i]->computeAABB();
    }
    for (const auto& l : links_) {
      fcl::DefaultCollisionData<S> d;
      world_.collide(l.get(), &d, fcl::DefaultCollisionFunction<S>);
      if (d.result.isCollision()) return false;
    }
    robot_.update();
    fcl::DefaultCollisionData<S> d;
    robot_.collide(&d, &FclValidity::selfCallback);
    return !d.result.isCollision();
  }

 private:
  static bool selfCallback(Object* a, Object* b, void* data) {
    const auto i = reinterpret_cast<std::uintptr_t>(a->getUserData());
    const auto j = reinterpret_cast<std::uintptr_t>(b->getUserData());
    if (i + 1 == j || j + 1 == i) return false;  // adjacent links share a joint
    return fcl::DefaultCollisionFunction<S>(a, b, data);
  }
  const fcl::BroadPhaseCollisionManagerd& world_;
  std::vector<std::unique_ptr<Object>> links_;
  mutable fcl::DynamicAABBTreeCollisionManagerd robot_;
  CheckClock& clock_;
};

// OMPL's DiscreteMotionValidator (over FclValidity), its time counted as the checks'.
class TimedDiscreteMotion final : public ob::MotionValidator {
 public:
  TimedDiscreteMotion(const ob::SpaceInformationPtr& si, CheckClock& clock)
      : ob::MotionValidator(si), inner_(si), clock_(clock) {}
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const CheckClock::Scope timed(clock_);
    return inner_.checkMotion(s1, s2);
  }
  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    const CheckClock::Scope timed(clock_);
    return inner_.checkMotion(s1, s2, last_valid);
  }

 private:
  ob::DiscreteMotionValidator inner_;
  CheckClock& clock_;
};

// ---- Planning ---------------------------------------------------------------------------------

// A sampler whose random numbers start from a given seed: each planning run repeats the same
// sequence (OMPL's global seed only seeds the first generators of a process).
class SeededSampler final : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint_fast32_t seed)
      : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

struct Outcome {
  bool solved = false;
  double seconds = 0;
  double check_seconds = 0;                // of `seconds`, inside the validity and motion checks
  std::size_t edges = 0, edge_states = 0;  // cube's checkMotion calls and their states
  std::vector<std::vector<double>> path;
  bool fine_contact = false;  // the path touches something on a 100 times finer subdivision
};

enum class Checker { cube, cube_continuous, fcl };

Outcome plan(Checker which, const std::vector<double>& start, const std::vector<double>& goal,
             std::uint_fast32_t seed, const cube::CubeCollisionManagerd& cube_world,
             const cube::BodySet<S>& body, const fcl::BroadPhaseCollisionManagerd& fcl_world,
             const std::vector<std::shared_ptr<fcl::CollisionGeometryd>>& geometry, int threads,
             double resolution, int refine) {
  CheckClock clock;  // outlives the checkers that space information keeps
  auto space = std::make_shared<ob::RealVectorStateSpace>(kJoints);
  space->setBounds(-M_PI, M_PI);
  space->setStateSamplerAllocator(
      [seed](const ob::StateSpace* s) { return std::make_shared<SeededSampler>(s, seed); });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  if (resolution > 0) si->setStateValidityCheckingResolution(resolution);
  std::shared_ptr<CubeMotion> motion;
  if (which != Checker::fcl) {
    si->setStateValidityChecker(
        std::make_shared<CubeValidity>(si, cube_world, body, threads, clock));
    motion = std::make_shared<CubeMotion>(si, cube_world, body, threads,
                                          which == Checker::cube_continuous ? refine : 0, clock);
    si->setMotionValidator(motion);
  } else {
    si->setStateValidityChecker(std::make_shared<FclValidity>(si, fcl_world, geometry, clock));
    si->setMotionValidator(std::make_shared<TimedDiscreteMotion>(si, clock));
  }
  si->setup();
  ob::ScopedState<> s(space), g(space);
  for (int i = 0; i < kJoints; ++i) {
    s[i] = start[i];
    g[i] = goal[i];
  }
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->setStartAndGoalStates(s, g);
  auto planner = std::make_shared<og::RRTConnect>(si);
  planner->setProblemDefinition(pdef);
  planner->setup();
  Outcome out;
  const auto t0 = std::chrono::steady_clock::now();
  out.solved = planner->solve(ob::timedPlannerTerminationCondition(120.0)) ==
               ob::PlannerStatus::EXACT_SOLUTION;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.check_seconds = clock.seconds();
  if (motion) {
    out.edges = motion->getValidMotionCount() + motion->getInvalidMotionCount();
    out.edge_states = motion->states_;
  }
  if (out.solved) {
    const auto& path = *pdef->getSolutionPath()->as<og::PathGeometric>();
    for (std::size_t k = 0; k < path.getStateCount(); ++k) {
      const double* q = jointsOf(path.getState(k));
      out.path.emplace_back(q, q + kJoints);
    }
    // Each segment on 100 times the states the motion checks take, with FCL's checker.
    CheckClock untimed;
    FclValidity fine(si, fcl_world, geometry, untimed);
    ob::ScopedState<> at(space);
    for (std::size_t k = 0; k + 1 < path.getStateCount() && !out.fine_contact; ++k) {
      const unsigned steps = 100 * space->validSegmentCount(path.getState(k), path.getState(k + 1));
      for (unsigned i = 0; i <= steps && !out.fine_contact; ++i) {
        space->interpolate(path.getState(k), path.getState(k + 1), double(i) / steps, at.get());
        out.fine_contact = !fine.isValid(at.get());
      }
    }
  }
  return out;
}

// Whether the arm at q touches anything in `objs` (brute force, FCL's narrow phase).
bool touches(const std::vector<double>& q,
             const std::vector<std::shared_ptr<fcl::CollisionGeometryd>>& geometry,
             const Object& obj) {
  Poses poses(kJoints);
  armPoses(q.data(), poses.data());
  for (int i = 0; i < kJoints; ++i) {
    const Object link(geometry[i], poses[i]);
    fcl::CollisionRequestd req;
    fcl::CollisionResultd res;
    if (fcl::collide(&link, &obj, req, res) > 0) return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  const int load = cube::scenes::BusyLoad::takeArgument(argc, argv, "--load");
  double resolution = 0;  // OMPL's default
  int refine = kRefine;
  for (int i = 1; i + 1 < argc;) {
    const std::string arg = argv[i];
    if (arg != "--resolution" && arg != "--refine") {
      ++i;
      continue;
    }
    if (arg == "--resolution")
      resolution = std::atof(argv[i + 1]);
    else
      refine = std::max(1, std::atoi(argv[i + 1]));
    for (int j = i; j + 2 <= argc; ++j) argv[j] = argv[j + 2];
    argc -= 2;
  }
  const std::size_t n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 2000;
  const int problems = argc > 2 ? std::atoi(argv[2]) : 5;
  const int threads = argc > 3 ? std::atoi(argv[3]) : 0;
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);

  // The world: objects around the arm (reach 7), none within 1.2 of its base. Each problem's
  // start and goal are cleared of obstacles below.
  cube::scenes::SceneOptions o;
  o.n = n;
  o.half_extent = 8;
  o.seed = 11;
  o.size_scale = argc > 4 ? std::atof(argv[4]) : 1.0;
  auto scene = cube::scenes::makeScene<S>(o);
  const auto geometry = armGeometry();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::vector<std::pair<std::vector<double>, std::vector<double>>> tasks;
  for (int p = 0; p < problems; ++p) {
    std::vector<double> a(kJoints), b(kJoints);
    for (int i = 0; i < kJoints; ++i) {
      a[i] = 0.5 * angle(rng);
      b[i] = 0.5 * angle(rng);
    }
    tasks.emplace_back(a, b);
  }
  std::vector<Object*> objs;
  for (const auto& obj : scene.objects) {
    if (obj->getTranslation().norm() < 1.2) continue;
    bool blocks = false;
    for (const auto& [a, b] : tasks)
      blocks = blocks || touches(a, geometry, *obj) || touches(b, geometry, *obj);
    if (!blocks) objs.push_back(obj.get());
  }
  cube::CubeCollisionManagerd cube_world;
  cube_world.registerObjects(objs);
  cube_world.setup();
  fcl::DynamicAABBTreeCollisionManagerd fcl_world;
  fcl_world.registerObjects(objs);
  fcl_world.setup();
  cube::BodySet<S> body;
  for (const auto& g : geometry) body.addLink(g);
  for (int i = 0; i + 1 < kJoints; ++i) body.excludePair(i, i + 1);

  std::printf(
      "RRTConnect, %d-joint arm, %zu obstacles, %d problems, cube on %d thread(s) (0: the "
      "hardware's), %d busy processes beside\n",
      kJoints, objs.size(), problems, threads, load);
  const cube::scenes::BusyLoad busy(load, 1800);
  std::size_t edges = 0, edge_states = 0;
  double cube_s = 0, fcl_s = 0, cont_s = 0, cube_check_s = 0, fcl_check_s = 0;
  int same = 0, solved = 0, cont_solved = 0, fine_contacts = 0, cont_fine_contacts = 0;
  for (int p = 0; p < problems; ++p) {
    const std::uint_fast32_t seed = 1000 + p;
    const Outcome c = plan(Checker::cube, tasks[p].first, tasks[p].second, seed, cube_world, body,
                           fcl_world, geometry, threads, resolution, refine);
    const Outcome f = plan(Checker::fcl, tasks[p].first, tasks[p].second, seed, cube_world, body,
                           fcl_world, geometry, threads, resolution, refine);
    const Outcome k = plan(Checker::cube_continuous, tasks[p].first, tasks[p].second, seed,
                           cube_world, body, fcl_world, geometry, threads, resolution, refine);
    cont_s += k.seconds;
    cont_solved += k.solved;
    fine_contacts += c.fine_contact;
    cont_fine_contacts += k.fine_contact;
    edges += c.edges;
    edge_states += c.edge_states;
    const bool equal = c.solved == f.solved && c.path == f.path;
    same += equal;
    solved += c.solved;
    cube_s += c.seconds;
    fcl_s += f.seconds;
    cube_check_s += c.check_seconds;
    fcl_check_s += f.check_seconds;
    std::printf(
        "  problem %d: %s, %zu states; cube %.1f ms, FCL %.1f ms (%.2fx)%s; continuous: %s, %zu "
        "states, %.1f ms\n",
        p, c.solved ? "solved" : "not solved", c.path.size(), 1e3 * c.seconds, 1e3 * f.seconds,
        f.seconds / c.seconds, equal ? "" : "  PATHS DIFFER", k.solved ? "solved" : "not solved",
        k.path.size(), 1e3 * k.seconds);
  }
  std::printf(
      "planning time: cube %.1f ms, FCL DynamicAABBTree %.1f ms: %.2fx less; cube continuous "
      "%.1f ms\n",
      1e3 * cube_s, 1e3 * fcl_s, fcl_s / cube_s, 1e3 * cont_s);
  // The planner's own time (the same exploration in both runs) bounds what faster checks can
  // give: FCL's planning time over it is the ratio if cube's checks took no time at all.
  const double own_s = std::min(cube_s - cube_check_s, fcl_s - fcl_check_s);
  std::printf(
      "inside the checks: cube %.1f ms, FCL %.1f ms (%.2fx less); the planner's own time: %.1f ms "
      "(cube's run), %.1f ms (FCL's): checks that took no time would plan %.2fx faster than FCL\n",
      1e3 * cube_check_s, 1e3 * fcl_check_s, fcl_check_s / cube_check_s,
      1e3 * (cube_s - cube_check_s), 1e3 * (fcl_s - fcl_check_s), fcl_s / own_s);
  std::printf(
      "paths touching an obstacle on a 100x finer subdivision: discrete %d of %d, continuous %d "
      "of %d\n",
      fine_contacts, solved, cont_fine_contacts, cont_solved);
  std::printf("same paths: %d of %d problems (%d solved); %zu motion checks, %.1f states an edge\n",
              same, problems, solved, edges, edges ? double(edge_states) / double(edges) : 0.0);
  return same == problems && solved > 0 && cont_fine_contacts == 0 ? 0 : 1;
}
