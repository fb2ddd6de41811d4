// Batched state and motion checks: a 30-link robot in batches of states against a
// static world, checkStates / checkMotions against every FCL manager used the way FCL users do
// it today. Per state: each link's setTransform and computeAABB, then the faster of (a) a robot
// manager's update() (of the world's kind) and world->collide(robot), (b) world->collide(link) link
// by link; stop at the first contact (FCL's default callback and request). With self-collision the
// robot manager's self-collide follows, adjacent links skipped. Edges: the states in path order,
// stopping at the edge's first colliding state.
//
// Names: batch_<kind>/<scene>/<n>/<manager>; kind states_free (70% of the states free),
// states_hit (70% colliding), states_self (70% free, self-collision on), edges (edges of 20 to
// 100 states from a free state, self-collision off), edges_free (20 edges of 32 states, every
// state free: short steps as a planner keeps), edges_continuous (20 edges of 20 to 100 states
// from a free state, with a tenth of the edges' joint motion, checked continuously with the
// motion bounds of the chain's kinematics; its managers are cube, cube_t2 and cube_discrete, the
// same edges checked without the bounds, with counters us_per_checked_state, the time over the
// states the check visits, and, for cube, vs_discrete = cube_discrete's time per visited state /
// cube's), single (the states of states_free, one per call: against FCL's per-state check,
// whose cost is the same as in states_free; and cube_kept, cube's calls with one BatchScratch
// kept for all of them, as a planner keeps one per thread), states_long (meshes only: random states
// as they come of the same chain with links 8 times as long, nearly all in contact with several
// meshes). Managers: the FCL managers first, then cube_loop and cube_loop_t2 (the library's
// single-state path on one and two threads: a CubeCollisionManager of the 30 link objects moved
// per state, setTransform, computeAABB and update(), then collideAll(world, robot), and with
// self-collision collideAll of the robot manager, adjacent links excluded), then cube (one
// thread) and cube_t2 (two threads), which report vs_best_fcl = the best FCL manager's time in
// this run / cube's, vs_loop = the cube_loop case's time of the same thread count / cube's, and
// us_per_state. Each case first checks, outside the timed part, that its answers equal the
// per-link check with FCL's dynamic tree (state by state, edge by edge); a mismatch fails the
// binary.

#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_SSaP.h>
#include <fcl/broadphase/broadphase_SaP.h>
#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree_array.h>
#include <fcl/broadphase/broadphase_interval_tree.h>
#include <fcl/broadphase/broadphase_spatialhash.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cube_collision/batch.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

extern bool g_extra_failed;
extern bool g_smoke;  // cube_bench.cpp: --smoke

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Manager = fcl::BroadPhaseCollisionManager<S>;
using Poses = std::vector<fcl::Transform3<S>>;
namespace scenes = cube::scenes;

constexpr std::size_t kLinks = 30;
constexpr std::size_t kStates = 200;

const char* const kFcl[] = {"DynamicAABBTree", "DynamicAABBTree_Array", "SaP",  "SSaP",
                            "IntervalTree",    "SpatialHashing",        "Naive"};

std::unique_ptr<Manager> makeFcl(const std::string& name, const std::vector<Object*>& objs,
                                 double typical, double half) {
  std::unique_ptr<Manager> m;
  if (name == "DynamicAABBTree") m = std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
  if (name == "DynamicAABBTree_Array")
    m = std::make_unique<fcl::DynamicAABBTreeCollisionManager_Array<S>>();
  if (name == "SaP") m = std::make_unique<fcl::SaPCollisionManager<S>>();
  if (name == "SSaP") m = std::make_unique<fcl::SSaPCollisionManager<S>>();
  if (name == "IntervalTree") m = std::make_unique<fcl::IntervalTreeCollisionManager<S>>();
  if (name == "SpatialHashing") {
    const fcl::Vector3<S> lo = fcl::Vector3<S>::Constant(-1.2 * half);
    m = std::make_unique<fcl::SpatialHashingCollisionManager<S>>(S(2 * typical), lo, -lo, 1000u);
  }
  if (name == "Naive") m = std::make_unique<fcl::NaiveCollisionManager<S>>();
  m->registerObjects(objs);
  m->setup();
  return m;
}

// The robot: a chain of 30 links (boxes, capsules, cylinders) of length `len`, joints about
// alternating axes. Forward kinematics gives the links' poses from a base pose and 30 angles.
struct Robot {
  double len;
  std::vector<std::shared_ptr<fcl::CollisionGeometry<S>>> geometry;
  cube::BodySet<S> body;

  explicit Robot(double link_length) : len(link_length) {
    for (std::size_t i = 0; i < kLinks; ++i) {
      std::shared_ptr<fcl::CollisionGeometry<S>> g;
      switch (i % 3) {
        case 0:
          g = std::make_shared<fcl::Boxd>(0.3 * len, 0.3 * len, len);
          break;
        case 1:
          g = std::make_shared<fcl::Capsuled>(0.15 * len, 0.7 * len);
          break;
        default:
          g = std::make_shared<fcl::Cylinderd>(0.15 * len, len);
      }
      geometry.push_back(g);
      body.addLink(g);
    }
    for (std::size_t i = 0; i + 1 < kLinks; ++i) body.excludePair(i, i + 1);
  }
  void pose(const fcl::Transform3<S>& base, const double* q, fcl::Transform3<S>* out) const {
    fcl::Transform3<S> t = base;
    for (std::size_t i = 0; i < kLinks; ++i) {
      const fcl::Vector3<S> axis = i % 2 ? fcl::Vector3<S>::UnitX() : fcl::Vector3<S>::UnitY();
      t = t * fcl::AngleAxis<S>(q[i], axis);
      fcl::Transform3<S> mid = t;
      mid.translate(fcl::Vector3<S>(0, 0, len / 2));
      out[i] = mid;
      t.translate(fcl::Vector3<S>(0, 0, len));
    }
  }
};

// A configuration: base position and 30 angles.
struct Config {
  fcl::Vector3<S> base;
  double q[kLinks];
};

Config randomConfig(std::mt19937& rng, double half) {
  std::uniform_real_distribution<double> p(-0.9 * half, 0.9 * half), a(-0.6, 0.6);
  Config c;
  c.base = fcl::Vector3<S>(p(rng), p(rng), p(rng));
  for (double& x : c.q) x = a(rng);
  return c;
}

void poseOf(const Robot& r, const Config& c, Poses& out) {
  fcl::Transform3<S> base = fcl::Transform3<S>::Identity();
  base.translation() = c.base;
  const std::size_t at = out.size();
  out.resize(at + kLinks);
  r.pose(base, c.q, out.data() + at);
}

// FCL's way, one state, with the robot's link objects and a robot manager of the same kind.
struct FclRobot {
  std::vector<std::unique_ptr<Object>> links;
  std::unique_ptr<Manager> manager, self_manager;

  FclRobot(const Robot& r, const std::string& kind, double half) {
    std::vector<Object*> ptrs;
    for (const auto& g : r.geometry) {
      links.push_back(std::make_unique<Object>(g));
      links.back()->setUserData(reinterpret_cast<void*>(std::uintptr_t(links.size() - 1)));
      ptrs.push_back(links.back().get());
    }
    // Of the world's kind: FCL's managers static_cast the other manager of a collide to their
    // own type.
    manager = makeFcl(kind, ptrs, 2 * r.len, half);
    // Self-collision through it too, except where update() does not return (see run()).
    self_manager = kind == "SaP" || kind == "IntervalTree"
                       ? makeFcl("DynamicAABBTree", ptrs, 2 * r.len, half)
                       : nullptr;
  }
  void place(const fcl::Transform3<S>* poses) {
    for (std::size_t l = 0; l < links.size(); ++l) {
      links[l]->setTransform(poses[l]);
      links[l]->computeAABB();
    }
  }
  // Self-collision through the robot manager, adjacent links skipped.
  static bool selfCallback(Object* a, Object* b, void* data) {
    const auto i = reinterpret_cast<std::uintptr_t>(a->getUserData());
    const auto j = reinterpret_cast<std::uintptr_t>(b->getUserData());
    if (i + 1 == j || j + 1 == i) return false;
    return fcl::DefaultCollisionFunction<S>(a, b, data);
  }
  bool selfCollides() {
    fcl::DefaultCollisionData<S> d;
    (self_manager ? self_manager : manager)->collide(&d, &FclRobot::selfCallback);
    return d.result.isCollision();
  }
  // (a): update the robot manager and collide it with the world.
  bool viaManager(const Manager& world, const fcl::Transform3<S>* poses, bool self) {
    place(poses);
    manager->update();
    fcl::DefaultCollisionData<S> d;
    world.collide(manager.get(), &d, fcl::DefaultCollisionFunction<S>);
    if (d.result.isCollision()) return true;
    return self && selfCollides();
  }
  // (b): link by link against the world.
  bool perLink(const Manager& world, const fcl::Transform3<S>* poses, bool self) {
    place(poses);
    for (const auto& l : links) {
      fcl::DefaultCollisionData<S> d;
      world.collide(l.get(), &d, fcl::DefaultCollisionFunction<S>);
      if (d.result.isCollision()) return true;
    }
    if (!self) return false;
    (self_manager ? self_manager : manager)->update();
    return selfCollides();
  }
};

// The library's single-state path: a robot CubeCollisionManager of the link objects, moved per
// state, and the pipeline's query (collideAll) against the world.
struct CubeLoop {
  std::vector<std::unique_ptr<Object>> links;
  cube::CubeCollisionManager<S> manager;
  cube::NarrowPhaseOptions<S> options;

  CubeLoop(const Robot& r, int threads) {
    std::vector<Object*> ptrs;
    for (const auto& g : r.geometry) {
      links.push_back(std::make_unique<Object>(g));
      ptrs.push_back(links.back().get());
    }
    manager.registerObjects(ptrs);
    manager.setup();
    for (std::size_t i = 0; i + 1 < ptrs.size(); ++i) manager.excludePair(ptrs[i], ptrs[i + 1]);
    options.threads = threads;
  }
  bool check(const Manager& world, const fcl::Transform3<S>* poses, bool self) {
    for (std::size_t l = 0; l < links.size(); ++l) {
      links[l]->setTransform(poses[l]);
      links[l]->computeAABB();
    }
    manager.update();
    if (cube::collideAll<S>(world, manager, fcl::CollisionRequest<S>(), options).isCollision())
      return true;
    return self && cube::collideAll<S>(manager, fcl::CollisionRequest<S>(), options).isCollision();
  }
};

enum class Kind {
  states_free,
  states_hit,
  states_self,
  edges,
  edges_free,
  edges_continuous,
  single,
  states_long
};

bool isEdges(Kind k) {
  return k == Kind::edges || k == Kind::edges_free;
}

const char* kindName(Kind k) {
  switch (k) {
    case Kind::states_free:
      return "states_free";
    case Kind::states_hit:
      return "states_hit";
    case Kind::states_self:
      return "states_self";
    case Kind::edges:
      return "edges";
    case Kind::edges_free:
      return "edges_free";
    case Kind::single:
      return "single";
    case Kind::states_long:
      return "states_long";
    case Kind::edges_continuous:
      return "edges_continuous";
  }
  return "?";
}

// One world with its batches, built on first use.
struct Setup {
  scenes::Scene<S> scene;
  std::vector<Object*> objects;
  double typical = 1, half = 1;
  std::unique_ptr<cube::CubeCollisionManager<S>> world;
  std::unique_ptr<Robot> robot;
  std::unique_ptr<Robot> long_robot;  // links 8 typical sizes long: states_long's
  Poses free_mix, hit_mix, self_mix;  // kStates states each
  Poses long_states;                  // kStates random states of long_robot, as they come
  std::vector<Poses> singles;         // the states of free_mix, one vector each
  Poses edge_poses, free_edge_poses;
  std::vector<std::size_t> edge_starts, free_edge_starts;
  const std::vector<std::size_t>& startsOf(Kind k) const {
    return k == Kind::edges_free ? free_edge_starts : edge_starts;
  }
  Poses short_poses;  // edges_continuous: the edges, their starts and motion bounds
  std::vector<std::size_t> short_starts;
  std::vector<S> short_bounds;
  std::map<std::string, double> per_checked;  // per kind: cube_discrete's seconds per visited state
  std::map<std::string, std::unique_ptr<Manager>> fcl;
  std::map<std::string, double> best_fcl;      // per kind: the best FCL manager's seconds per call
  std::map<std::string, double> loop_seconds;  // per kind and thread count: cube_loop's

  Manager& fclWorld(const std::string& name) {
    auto& m = fcl[name];
    if (!m) m = makeFcl(name, objects, typical, half);
    return *m;
  }
};

Setup& setupFor(const std::string& scene, std::size_t n) {
  static std::map<std::string, std::unique_ptr<Setup>> all;
  auto& slot = all[scene + "/" + std::to_string(n)];
  if (slot) return *slot;
  slot = std::make_unique<Setup>();
  Setup& s = *slot;
  scenes::SceneOptions o;
  o.n = n;
  o.layout = scene == "clustered" ? scenes::Layout::clustered : scenes::Layout::uniform;
  o.meshes = scene == "meshes";
  o.seed = 37;
  s.scene = scenes::makeScene<S>(o);
  s.objects = s.scene.pointers();
  s.typical = scenes::typicalSize(o);
  s.half = o.half_extent;
  s.world = std::make_unique<cube::CubeCollisionManager<S>>();
  s.world->registerObjects(s.objects);
  s.world->setup();
  // Links about as long as the world's objects; the pools of free and colliding states come
  // from random configurations, sorted by the cube manager's answers (checked against FCL's
  // in each case).
  s.robot = std::make_unique<Robot>(1.0 * s.typical);
  std::mt19937 rng(5);
  cube::BatchOptions opt;
  for (const bool self : {false, true}) {
    Poses free_pool, hit_pool;
    for (int round = 0;
         round < 40 && (free_pool.size() < kStates * kLinks || hit_pool.size() < kStates * kLinks);
         ++round) {
      Poses batch;
      for (std::size_t k = 0; k < 200; ++k) poseOf(*s.robot, randomConfig(rng, s.half), batch);
      opt.self_collision = self;
      const auto r = cube::checkStates(*s.world, s.robot->body, batch, opt);
      for (std::size_t k = 0; k < r.size(); ++k) {
        Poses& pool = r[k].colliding ? hit_pool : free_pool;
        pool.insert(pool.end(), batch.begin() + k * kLinks, batch.begin() + (k + 1) * kLinks);
      }
    }
    if (free_pool.empty() || hit_pool.empty()) {
      std::fprintf(stderr, "bench_batch: %s/%zu: no %s states found\n", scene.c_str(), n,
                   free_pool.empty() ? "free" : "colliding");
      g_extra_failed = true;
      (free_pool.empty() ? free_pool : hit_pool) = free_pool.empty() ? hit_pool : free_pool;
    }
    const auto take = [&](Poses& out, double free_share) {
      const std::size_t nf = std::size_t(free_share * kStates);
      out.clear();
      for (std::size_t k = 0; k < kStates; ++k) {
        // Interleaved: free and colliding states spread evenly through the batch.
        const bool free_state = (k * nf) / kStates != ((k + 1) * nf) / kStates;
        const Poses& pool = free_state ? free_pool : hit_pool;
        const std::size_t idx = (k % (pool.size() / kLinks)) * kLinks;
        out.insert(out.end(), pool.begin() + idx, pool.begin() + idx + kLinks);
      }
    };
    if (self) {
      take(s.self_mix, 0.7);
    } else {
      take(s.free_mix, 0.7);
      take(s.hit_mix, 0.3);
    }
  }
  for (std::size_t k = 0; k < kStates; ++k)
    s.singles.emplace_back(s.free_mix.begin() + k * kLinks, s.free_mix.begin() + (k + 1) * kLinks);
  // Edges: 20 edges of 20 to 100 states, straight lines in configuration space from a free
  // configuration (a planner extends its tree from states known to be free).
  cube::BatchOptions one;
  one.threads = 1;
  for (const bool short_edges : {false, true}) {
    Poses& poses = short_edges ? s.short_poses : s.edge_poses;
    std::vector<std::size_t>& starts = short_edges ? s.short_starts : s.edge_starts;
    const double scale = short_edges ? 0.1 : 1.0;
    for (std::size_t e = 0; e < 20; ++e) {
      starts.push_back(poses.size() / kLinks);
      Config a = randomConfig(rng, s.half);
      for (int tries = 0; tries < 10000; ++tries) {
        Poses p;
        poseOf(*s.robot, a, p);
        if (!cube::checkStates(*s.world, s.robot->body, p, one)[0].colliding) break;
        a = randomConfig(rng, s.half);
      }
      Config b = a;
      std::uniform_real_distribution<double> step(-0.05 * s.half, 0.05 * s.half), turn(-0.6, 0.6);
      for (int k = 0; k < 3; ++k) b.base[k] += scale * step(rng);
      for (double& x : b.q) x += scale * (turn(rng) - x);
      const std::size_t count = 20 + 4 * e;
      for (std::size_t k = 0; k < count; ++k) {
        const double t = double(k) / double(count - 1);
        Config c;
        c.base = a.base + t * (b.base - a.base);
        for (std::size_t j = 0; j < kLinks; ++j) c.q[j] = a.q[j] + t * (b.q[j] - a.q[j]);
        poseOf(*s.robot, c, poses);
      }
      if (!short_edges) continue;
      // Link l's motion bound per interval: every point of link l lies within (l - j + 1.1)
      // link lengths of joint j (the joints are len apart; a link's points within 1.03 len of
      // its joint), so it moves at most the base's step plus the sum of each joint's turn
      // times that.
      const double steps = double(count - 1);
      std::vector<S> bound(kLinks);
      for (std::size_t l = 0; l < kLinks; ++l) {
        S b_l = (b.base - a.base).norm() / steps;
        for (std::size_t j = 0; j <= l; ++j)
          b_l += std::abs(b.q[j] - a.q[j]) / steps * (double(l - j) + 1.1) * s.robot->len;
        bound[l] = b_l;
      }
      for (std::size_t k = 0; k < count; ++k)
        s.short_bounds.insert(s.short_bounds.end(), bound.begin(), bound.end());
    }
  }
  // Free edges: 20 edges of 32 states whose every state is free, short steps from a free
  // configuration (the edges a planner keeps).
  for (int tries = 0; tries < 20000 && s.free_edge_starts.size() < 20; ++tries) {
    const Config a = randomConfig(rng, s.half);
    Config b = a;
    std::uniform_real_distribution<double> step(-0.01 * s.half, 0.01 * s.half), turn(-0.1, 0.1);
    for (int k = 0; k < 3; ++k) b.base[k] += step(rng);
    for (double& x : b.q) x += turn(rng);
    Poses edge;
    for (std::size_t k = 0; k < 32; ++k) {
      const double t = double(k) / 31.0;
      Config c;
      c.base = a.base + t * (b.base - a.base);
      for (std::size_t j = 0; j < kLinks; ++j) c.q[j] = a.q[j] + t * (b.q[j] - a.q[j]);
      poseOf(*s.robot, c, edge);
    }
    bool free = true;
    for (const auto& r : cube::checkStates(*s.world, s.robot->body, edge, one))
      free = free && !r.colliding;
    if (!free) continue;
    s.free_edge_starts.push_back(s.free_edge_poses.size() / kLinks);
    s.free_edge_poses.insert(s.free_edge_poses.end(), edge.begin(), edge.end());
  }
  if (s.free_edge_starts.empty()) {
    std::fprintf(stderr, "bench_batch: %s/%zu: no free edge found\n", scene.c_str(), n);
    g_extra_failed = true;
  }
  // Long links: random states as they come (nearly all in contact among meshes), from a
  // generator of their own (the other kinds' states stay as they were).
  s.long_robot = std::make_unique<Robot>(8.0 * s.typical);
  std::mt19937 long_rng(11);
  for (std::size_t k = 0; k < kStates; ++k)
    poseOf(*s.long_robot, randomConfig(long_rng, s.half), s.long_states);
  return s;
}

const Poses& posesOf(const Setup& s, Kind k) {
  switch (k) {
    case Kind::states_hit:
      return s.hit_mix;
    case Kind::states_self:
      return s.self_mix;
    case Kind::edges:
      return s.edge_poses;
    case Kind::edges_free:
      return s.free_edge_poses;
    case Kind::states_long:
      return s.long_states;
    case Kind::edges_continuous:
      return s.short_poses;
    default:
      return s.free_mix;
  }
}

const Robot& robotOf(const Setup& s, Kind k) {
  return k == Kind::states_long ? *s.long_robot : *s.robot;
}

std::size_t statesIn(const Setup& s, Kind k) {
  return posesOf(s, k).size() / kLinks;
}

// A single-state checker's answers: per state (colliding or not), or per edge (first colliding
// state, or none). check(poses, self) answers one state.
template <class Check>
std::vector<std::size_t> stateAnswers(const Setup& s, Kind k, Check&& check_state) {
  const Poses& poses = posesOf(s, k);
  const bool self = k == Kind::states_self;
  const auto check = [&](std::size_t state) {
    return check_state(poses.data() + state * kLinks, self);
  };
  std::vector<std::size_t> out;
  if (isEdges(k)) {
    const std::vector<std::size_t>& starts = s.startsOf(k);
    for (std::size_t e = 0; e < starts.size(); ++e) {
      const std::size_t end = e + 1 < starts.size() ? starts[e + 1] : poses.size() / kLinks;
      std::size_t first = cube::kNoIndex;
      for (std::size_t st = starts[e]; st < end && first == cube::kNoIndex; ++st)
        if (check(st)) first = st - starts[e];
      out.push_back(first);
    }
  } else {
    for (std::size_t st = 0; st < statesIn(s, k); ++st) out.push_back(check(st));
  }
  return out;
}

// FCL's answers, per state or per edge.
std::vector<std::size_t> fclAnswers(FclRobot& r, const Manager& world, const Setup& s, Kind k,
                                    bool via_manager) {
  return stateAnswers(s, k, [&](const fcl::Transform3<S>* p, bool self) {
    return via_manager ? r.viaManager(world, p, self) : r.perLink(world, p, self);
  });
}

std::vector<std::size_t> loopAnswers(CubeLoop& loop, const Setup& s, Kind k) {
  return stateAnswers(
      s, k, [&](const fcl::Transform3<S>* p, bool self) { return loop.check(*s.world, p, self); });
}

// The states a motion check visits in path order: each edge's up to its answer.
std::size_t visited(const Setup& s, const std::vector<std::size_t>& first) {
  std::size_t n = 0;
  for (std::size_t e = 0; e < first.size(); ++e) {
    const std::size_t end =
        e + 1 < s.short_starts.size() ? s.short_starts[e + 1] : s.short_poses.size() / kLinks;
    n += first[e] == cube::kNoIndex ? end - s.short_starts[e] : first[e] + 1;
  }
  return n;
}

// edges_continuous: continuously with the motion bounds, or (discrete) without them.
std::vector<std::size_t> shortEdges(const Setup& s, int threads, bool discrete) {
  cube::BatchOptions o;
  o.threads = threads;
  if (discrete)
    return cube::checkMotions(*s.world, s.robot->body, s.short_poses, s.short_starts,
                              cube::MotionOrder::path, o);
  return cube::checkMotions(*s.world, s.robot->body, s.short_poses, s.short_starts, s.short_bounds,
                            cube::MotionOrder::path, o);
}

// edges_continuous: the continuous check, outside the timed part, against the discrete one (a
// continuous answer comes no later than the discrete one's: a raised margin keeps every
// contact) and the same on two threads.
void runContinuous(benchmark::State& state, Setup& s, const std::string& manager) {
  const bool discrete = manager == "cube_discrete";
  const int threads = manager == "cube_t2" ? 2 : 1;
  const auto plain = shortEdges(s, 1, true);
  const auto mine = shortEdges(s, threads, discrete);
  bool sound = mine == shortEdges(s, 1, discrete);
  for (std::size_t e = 0; e < plain.size(); ++e) sound = sound && mine[e] <= plain[e];
  if (!sound) {
    state.SkipWithError("continuous answers later than the discrete check, or per thread count");
    g_extra_failed = true;
    return;
  }
  double seconds = 0;
  std::size_t calls = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(shortEdges(s, threads, discrete));
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    seconds += dt;
    ++calls;
    state.SetIterationTime(dt);
  }
  const double per_call = seconds / double(std::max<std::size_t>(calls, 1));
  const std::size_t checked = visited(s, mine);
  std::size_t free_edges = 0;
  for (const std::size_t f : mine) free_edges += f == cube::kNoIndex;
  state.counters["us_per_state"] = 1e6 * per_call / double(s.short_poses.size() / kLinks);
  state.counters["us_per_checked_state"] = 1e6 * per_call / double(checked);
  state.counters["free_edges"] = double(free_edges);
  double& ref = s.per_checked["edges_continuous"];
  if (discrete) ref = per_call / double(checked);
  if (!discrete && ref > 0) state.counters["vs_discrete"] = ref / (per_call / double(checked));
}

std::vector<std::size_t> cubeAnswers(const Setup& s, Kind k, int threads,
                                     cube::BatchScratch* kept = nullptr) {
  cube::BatchOptions o;
  o.threads = threads;
  o.scratch = kept;
  o.self_collision = k == Kind::states_self;
  const Poses& poses = posesOf(s, k);
  if (isEdges(k))
    return cube::checkMotions(*s.world, s.robot->body, poses, s.startsOf(k),
                              cube::MotionOrder::path, o);
  std::vector<std::size_t> out;
  if (k == Kind::single) {  // the states of states_free, one call each
    for (const Poses& one : s.singles)
      out.push_back(cube::checkStates(*s.world, s.robot->body, one, o)[0].colliding);
    return out;
  }
  for (const auto& r : cube::checkStates(*s.world, robotOf(s, k).body, poses, o))
    out.push_back(r.colliding);
  return out;
}

void run(benchmark::State& state, Kind kind, const std::string& scene, std::size_t n,
         const std::string& manager) {
  Setup& s = setupFor(scene, n);
  if (kind == Kind::edges_continuous) return runContinuous(state, s, manager);
  const bool is_cube = manager == "cube" || manager == "cube_t2" || manager == "cube_kept";
  const bool is_loop = manager == "cube_loop" || manager == "cube_loop_t2";
  const std::string key = std::string(kindName(kind));
  // The reference: FCL's dynamic tree, link by link.
  static std::map<std::string, std::vector<std::size_t>> reference;
  const std::string ref_key = key + "/" + scene + "/" + std::to_string(n);
  if (!reference.count(ref_key)) {
    FclRobot ref(robotOf(s, kind), "DynamicAABBTree", s.half);
    reference[ref_key] = fclAnswers(ref, s.fclWorld("DynamicAABBTree"), s, kind, false);
  }
  const std::vector<std::size_t>& want = reference[ref_key];
  const std::size_t states = statesIn(s, kind);
  double seconds = 0;
  std::size_t calls = 0;
  if (is_cube) {
    const int threads = manager == "cube_t2" ? 2 : 1;
    // cube_kept: one BatchScratch for every call (a planner's per-thread one).
    cube::BatchScratch scratch;
    cube::BatchScratch* kept = manager == "cube_kept" ? &scratch : nullptr;
    if (cubeAnswers(s, kind, threads, kept) != want) {
      state.SkipWithError("cube's answers differ from FCL's");
      g_extra_failed = true;
      return;
    }
    for (auto _ : state) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(cubeAnswers(s, kind, threads, kept));
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      ++calls;
      state.SetIterationTime(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
  } else if (is_loop) {
    CubeLoop loop(robotOf(s, kind), manager == "cube_loop" ? 1 : 2);
    if (loopAnswers(loop, s, kind) != want) {
      state.SkipWithError("the single-state path's answers differ from FCL's");
      g_extra_failed = true;
      return;
    }
    for (auto _ : state) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(loopAnswers(loop, s, kind));
      const double dt =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      seconds += dt;
      ++calls;
      state.SetIterationTime(dt);
    }
  } else {
    const Manager& world = s.fclWorld(manager);
    FclRobot r(robotOf(s, kind), manager, s.half);
    // FCL 0.7's SaP and IntervalTree do not return from update() after the robot's motions
    // between states: for them, only (b).
    const bool can_a = manager != "SaP" && manager != "IntervalTree";
    const bool agree_a = !can_a || fclAnswers(r, world, s, kind, true) == want;
    const bool agree_b = fclAnswers(r, world, s, kind, false) == want;
    // The faster of the two ways, chosen on one untimed call each (a smoke run, whose timings
    // are not looked at, takes the robot's manager wherever it works).
    const auto time_way = [&](bool via) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(fclAnswers(r, world, s, kind, via));
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    const bool via = can_a && (g_smoke || time_way(true) < time_way(false));
    for (auto _ : state) {
      const auto t0 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(fclAnswers(r, world, s, kind, via));
      const double dt =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      seconds += dt;
      ++calls;
      state.SetIterationTime(dt);
    }
    state.counters["agree"] = agree_a && agree_b;
    state.counters["via_robot_manager"] = via;
  }
  const double per_call = seconds / double(std::max<std::size_t>(calls, 1));
  state.counters["us_per_state"] = 1e6 * per_call / double(states);
  auto& best = s.best_fcl[key];
  if (!is_cube && !is_loop && (best == 0 || per_call < best)) best = per_call;
  if (is_cube && best > 0) state.counters["vs_best_fcl"] = best / per_call;
  // The single-state path of the same thread count, when it ran before in this process.
  const bool two = manager == "cube_t2" || manager == "cube_loop_t2";
  const std::string loop_key = key + (two ? "/t2" : "/t1");
  if (is_loop) s.loop_seconds[loop_key] = per_call;
  if (is_cube && s.loop_seconds.count(loop_key))
    state.counters["vs_loop"] = s.loop_seconds[loop_key] / per_call;
}

bool runsFcl(const std::string& m, const std::string& scene, std::size_t n, Kind k) {
  if (m == "Naive" && n > 2000) return false;
  if (n >= 100000 && m != "DynamicAABBTree" && m != "DynamicAABBTree_Array") return false;
  // Edges and single states: the two tree managers (the fastest FCL ones on every other kind).
  if ((isEdges(k) || k == Kind::single || k == Kind::states_long) && m != "DynamicAABBTree" &&
      m != "DynamicAABBTree_Array")
    return false;
  (void)scene;
  return true;
}

void registerBatch() {
  for (const char* scene : {"uniform", "clustered", "meshes"})
    for (std::size_t n :
         {std::size_t(1000), std::size_t(2000), std::size_t(10000), std::size_t(100000)}) {
      // 2,000: meshes only (where the single-state path was the batch's closest rival).
      if (n == 2000 && std::string(scene) != "meshes") continue;
      if (n >= 100000 && std::string(scene) == "meshes") continue;
      for (Kind k : {Kind::states_free, Kind::states_hit, Kind::states_self, Kind::edges,
                     Kind::edges_free, Kind::edges_continuous, Kind::single, Kind::states_long}) {
        // Long links: meshes only, where a state meets many objects FCL must answer.
        if (k == Kind::states_long && std::string(scene) != "meshes") continue;
        std::vector<std::string> managers;
        if (k == Kind::edges_continuous) managers.push_back("cube_discrete");  // first: the base
        for (const char* m : kFcl)
          if (k != Kind::edges_continuous && runsFcl(m, scene, n, k)) managers.push_back(m);
        if (k != Kind::single && k != Kind::edges_continuous) {
          managers.push_back("cube_loop");
          managers.push_back("cube_loop_t2");
        }
        managers.push_back("cube");
        if (k != Kind::single) managers.push_back("cube_t2");
        if (k == Kind::single) managers.push_back("cube_kept");
        for (const std::string& m : managers) {
          const std::string name =
              std::string("batch_") + kindName(k) + "/" + scene + "/" + std::to_string(n) + "/" + m;
          benchmark::RegisterBenchmark(name.c_str(),
                                       [k, scene = std::string(scene), n, m](benchmark::State& st) {
                                         run(st, k, scene, n, m);
                                       })
              ->Unit(benchmark::kMicrosecond)
              ->UseManualTime();
        }
      }
    }
}

const bool registered = (registerBatch(), true);

}  // namespace
