// cube_bench: the cube manager against every FCL broadphase manager on the same objects.
//
// Benchmark names are <case>/<scene>/<n>/<manager> (Google Benchmark appends /manual_time to
// the cases timed by hand). Every case first checks, once and outside the timed region, that
// the cube manager reports what a reference manager reports on the same objects (Naive up to
// 2,000 objects, else DynamicAABBTree); a mismatch skips the case with an error and makes the
// binary exit with status 1. FCL managers are checked the same way but only report an `agree`
// counter: their bugs are not ours to fail on.

#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_SSaP.h>
#include <fcl/broadphase/broadphase_SaP.h>
#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree_array.h>
#include <fcl/broadphase/broadphase_interval_tree.h>
#include <fcl/broadphase/broadphase_spatialhash.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "busy_load.h"
#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

// Set by the cases registered from other files (bench_*.cpp) when a correctness check fails.
bool g_extra_failed = false;
// --smoke (ctest's run): every check as always, but no untimed probe that only serves the
// timings (bench_batch.cpp's choice of the faster way to drive FCL).
bool g_smoke = false;

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Manager = fcl::BroadPhaseCollisionManager<S>;
using CubeManager = cube::CubeCollisionManager<S>;
using Pair = std::pair<Object*, Object*>;
using Clock = std::chrono::steady_clock;
namespace scenes = cube::scenes;

bool g_failed = false;

// ---------------------------------------------------------------------------------------------
// Managers

enum class Mgr { cube, dtree, dtree_array, sap, ssap, interval, shash, naive };
const Mgr kAllManagers[] = {Mgr::cube, Mgr::dtree,    Mgr::dtree_array, Mgr::sap,
                            Mgr::ssap, Mgr::interval, Mgr::shash,       Mgr::naive};

const char* managerName(Mgr m) {
  switch (m) {
    case Mgr::cube:
      return "cube";
    case Mgr::dtree:
      return "DynamicAABBTree";
    case Mgr::dtree_array:
      return "DynamicAABBTree_Array";
    case Mgr::sap:
      return "SaP";
    case Mgr::ssap:
      return "SSaP";
    case Mgr::interval:
      return "IntervalTree";
    case Mgr::shash:
      return "SpatialHashing";
    case Mgr::naive:
      return "Naive";
  }
  return "?";
}

/// What SpatialHashing must know before any object is registered.
struct Extent {
  fcl::Vector3<S> lo = fcl::Vector3<S>::Zero();
  fcl::Vector3<S> hi = fcl::Vector3<S>::Zero();
  double typical = 1;  // typical object size
};

Extent extentOf(const std::vector<Object*>& objs, double typical) {
  Extent e;
  e.typical = typical;
  e.lo.setConstant(std::numeric_limits<S>::max());
  e.hi.setConstant(-std::numeric_limits<S>::max());
  for (const Object* o : objs) {
    e.lo = e.lo.cwiseMin(o->getAABB().min_);
    e.hi = e.hi.cwiseMax(o->getAABB().max_);
  }
  return e;
}

/// How a case uses its manager: motion loops (update + self-collide) turn on cube's pair list
/// (Config::keep_pairs), as the README tells such callers to; a user's own narrow-phase callback
/// may turn on the culling in front of it (Config::cull_pairs).
enum class Use { queries, motion_loop, culled_callback };

/// A new manager of kind m. For Mgr::cube, `*cube` (if given) is set to the same object with its
/// own type, for what FCL's interface lacks (QueryStats, bytes()).
std::unique_ptr<Manager> makeManager(Mgr m, const Extent& e, CubeManager** cube = nullptr,
                                     Use use = Use::queries) {
  switch (m) {
    case Mgr::cube: {
      cube::Config config;
      config.keep_pairs = use == Use::motion_loop;
      config.cull_pairs = use == Use::culled_callback;
      auto mgr = std::make_unique<CubeManager>(config);
      if (cube != nullptr) *cube = mgr.get();
      return mgr;
    }
    case Mgr::dtree:
      return std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
    case Mgr::dtree_array:
      return std::make_unique<fcl::DynamicAABBTreeCollisionManager_Array<S>>();
    case Mgr::sap:
      return std::make_unique<fcl::SaPCollisionManager<S>>();
    case Mgr::ssap:
      return std::make_unique<fcl::SSaPCollisionManager<S>>();
    case Mgr::interval:
      return std::make_unique<fcl::IntervalTreeCollisionManager<S>>();
    case Mgr::shash:
      // Cells about twice the typical object; the table sized to the scene, as a user would.
      return std::make_unique<fcl::SpatialHashingCollisionManager<S>>(S(2 * e.typical), e.lo, e.hi,
                                                                      1000u);
    case Mgr::naive:
      return std::make_unique<fcl::NaiveCollisionManager<S>>();
  }
  return nullptr;
}

/// makeManager() with `objs` registered and setup() called.
std::unique_ptr<Manager> built(Mgr m, const std::vector<Object*>& objs, const Extent& e,
                               CubeManager** cube = nullptr, Use use = Use::queries) {
  auto mgr = makeManager(m, e, cube, use);
  mgr->registerObjects(objs);
  mgr->setup();
  return mgr;
}

/// The manager whose answers the others are checked against.
Mgr referenceFor(std::size_t n) {
  return n <= 2000 ? Mgr::naive : Mgr::dtree;
}

// ---------------------------------------------------------------------------------------------
// Callbacks

struct Counter {
  std::size_t calls = 0;
  static bool fn(Object*, Object*, void* d) {
    ++static_cast<Counter*>(d)->calls;
    return false;
  }
};

struct Recorder {
  std::vector<Pair> pairs;
  static bool fn(Object* a, Object* b, void* d) {
    static_cast<Recorder*>(d)->pairs.emplace_back(std::min(a, b), std::max(a, b));
    return false;
  }
  std::vector<Pair> sorted() {
    std::sort(pairs.begin(), pairs.end());
    return pairs;
  }
};

// Exhaustive narrow phase: the default request stops at the first contact, which would time a
// traversal-order-dependent prefix of the work instead of the work.
constexpr std::size_t kAllContacts = std::numeric_limits<int>::max();

fcl::CollisionRequest<S> allContacts() {
  fcl::CollisionRequest<S> r;
  r.num_max_contacts = kAllContacts;
  return r;
}

/// Cube's narrow-phase pipeline on `threads` threads (0: the hardware's), optionally with a
/// cache; `stats` gets its counts.
cube::NarrowPhaseOptions<S> pipeline(int threads, cube::NarrowPhaseCache<S>* cache = nullptr,
                                     cube::NarrowPhaseStats* stats = nullptr) {
  cube::NarrowPhaseOptions<S> o;
  o.threads = threads;
  o.cache = cache;
  o.stats = stats;
  return o;
}

/// Every contact of a self-collide: cube through its pipeline (collideAll), the FCL managers
/// with FCL's default callback.
std::size_t narrowCollide(Mgr m, const Manager& mgr, int threads = 1,
                          cube::NarrowPhaseCache<S>* cache = nullptr) {
  if (m == Mgr::cube)
    return cube::collideAll<S>(mgr, allContacts(), pipeline(threads, cache)).numContacts();
  fcl::DefaultCollisionData<S> d;
  d.request = allContacts();
  mgr.collide(&d, fcl::DefaultCollisionFunction<S>);
  return d.result.numContacts();
}

/// Every contact of a self-collide through FCL's default callback, as a user's own callback
/// would run it; `calls` (if given) counts the callback's calls.
std::size_t defaultCallbackCollide(const Manager& mgr, std::size_t* calls = nullptr) {
  struct Data {
    fcl::DefaultCollisionData<S> d;
    std::size_t calls = 0;
    static bool fn(Object* a, Object* b, void* p) {
      auto& x = *static_cast<Data*>(p);
      ++x.calls;
      return fcl::DefaultCollisionFunction<S>(a, b, &x.d);
    }
  } data;
  data.d.request = allContacts();
  mgr.collide(&data, &Data::fn);
  if (calls != nullptr) *calls = data.calls;
  return data.d.result.numContacts();
}

/// Every contact of manager.collide(q), as narrowCollide.
std::size_t narrowQuery(Mgr m, const Manager& mgr, Object* q, int threads = 1) {
  if (m == Mgr::cube)
    return cube::collideAll<S>(mgr, q, allContacts(), pipeline(threads)).numContacts();
  fcl::DefaultCollisionData<S> d;
  d.request = allContacts();
  mgr.collide(q, &d, fcl::DefaultCollisionFunction<S>);
  return d.result.numContacts();
}

/// "Does the robot collide?" (FCL's default request: stop at the first contact).
bool robotCollides(Mgr m, const Manager& world, Manager& robot, int threads = 1) {
  if (m == Mgr::cube)
    return cube::collideAll<S>(world, robot, fcl::CollisionRequest<S>(), pipeline(threads))
        .isCollision();
  fcl::DefaultCollisionData<S> d;
  world.collide(&robot, &d, fcl::DefaultCollisionFunction<S>);
  return d.result.isCollision();
}

// FCL's default distance callback, counting the fcl::distance calls it makes (one per call
// until the search is done).
struct CountedFclDistance {
  fcl::DefaultDistanceData<S> d;
  std::size_t calls = 0;
  static bool fn(Object* a, Object* b, void* p, S& dist) {
    auto& c = *static_cast<CountedFclDistance*>(p);
    c.calls += !c.d.done;
    return fcl::DefaultDistanceFunction<S>(a, b, &c.d, dist);
  }
};

// Narrow-phase calls of object distance queries (sum over `queries`) and of a self distance.
std::size_t objectDistanceCalls(Mgr m, const Manager& mgr, const std::vector<Object*>& queries) {
  std::size_t calls = 0;
  for (Object* q : queries) {
    if (m == Mgr::cube) {
      cube::DistanceData<S> d;
      mgr.distance(q, &d, cube::defaultDistanceCallback<S>);
      calls += d.narrow_calls;
    } else {
      CountedFclDistance c;
      mgr.distance(q, &c, &CountedFclDistance::fn);
      calls += c.calls;
    }
  }
  return calls;
}

std::size_t selfDistanceCalls(Mgr m, const Manager& mgr) {
  if (m == Mgr::cube) {
    cube::DistanceData<S> d;
    mgr.distance(&d, cube::defaultDistanceCallback<S>);
    return d.narrow_calls;
  }
  CountedFclDistance c;
  mgr.distance(&c, &CountedFclDistance::fn);
  return c.calls;
}

// fcl::collide calls of narrowCollide: the cube callback's count (and into `stats`, if given,
// all of the pipeline's counts); FCL's default callback calls it for every pair it is given (all
// contacts are asked for, so it never stops early).
std::size_t narrowCollideCalls(Mgr m, const Manager& mgr, cube::NarrowPhaseStats* stats = nullptr) {
  if (m == Mgr::cube) {
    cube::NarrowPhaseStats st;
    cube::collideAll<S>(mgr, allContacts(), pipeline(1, nullptr, &st));
    if (stats != nullptr) *stats = st;
    return st.narrow_calls;
  }
  std::size_t pairs = 0;
  mgr.collide(&pairs, [](Object*, Object*, void* p) {
    ++*static_cast<std::size_t*>(p);
    return false;
  });
  return pairs;
}

S selfDistance(Mgr m, const Manager& mgr) {
  if (m == Mgr::cube) {
    cube::DistanceData<S> d;
    mgr.distance(&d, cube::defaultDistanceCallback<S>);
    return d.result.min_distance;
  }
  fcl::DefaultDistanceData<S> d;
  mgr.distance(&d, fcl::DefaultDistanceFunction<S>);
  return d.result.min_distance;
}

/// cube::minimumDistance with the default request and options (the hardware's threads), what a
/// user who follows the README runs.
S pipelineDistance(const Manager& mgr, Object* q) {
  return cube::minimumDistance<S>(mgr, q).min_distance;
}

S objectDistance(Mgr m, const Manager& mgr, Object* q) {
  if (m == Mgr::cube) {
    cube::DistanceData<S> d;
    mgr.distance(q, &d, cube::defaultDistanceCallback<S>);
    return d.result.min_distance;
  }
  fcl::DefaultDistanceData<S> d;
  mgr.distance(q, &d, fcl::DefaultDistanceFunction<S>);
  return d.result.min_distance;
}

// ---------------------------------------------------------------------------------------------
// Scenes

const char* const kSceneNames[] = {"uniform", "clustered", "meshes", "thin"};

scenes::SceneOptions optionsFor(const std::string& scene, std::size_t n) {
  scenes::SceneOptions o;
  o.n = n;
  o.layout = scene == "clustered" ? scenes::Layout::clustered
             : scene == "thin"    ? scenes::Layout::thin
                                  : scenes::Layout::uniform;
  o.meshes = scene == "meshes";
  return o;
}

/// Object-distance scenes are made of objects this much smaller than the collide scenes, so that
/// few touch; those that still do are dropped (the distance callback stops at the first touch).
constexpr double kDistanceScale = 0.3;

/// Objects of `candidates` whose AABB overlaps none of `others` (nor, with `self`, each other).
std::vector<Object*> untouched(const std::vector<Object*>& candidates,
                               const std::vector<Object*>& others, bool self) {
  fcl::DynamicAABBTreeCollisionManager<S> tree;
  tree.registerObjects(others);
  tree.setup();
  std::vector<Object*> out;
  if (self) {
    Recorder r;
    tree.collide(&r, &Recorder::fn);
    std::vector<Object*> touching;
    for (const auto& p : r.pairs) {
      touching.push_back(p.first);
      touching.push_back(p.second);
    }
    std::sort(touching.begin(), touching.end());
    for (Object* o : candidates)
      if (!std::binary_search(touching.begin(), touching.end(), o)) out.push_back(o);
  } else {
    for (Object* o : candidates) {
      Counter c;
      tree.collide(o, &c, &Counter::fn);
      if (c.calls == 0) out.push_back(o);
    }
  }
  return out;
}

/// One scene and everything derived from it, built lazily; only one is kept at a time (the
/// benchmarks are registered scene by scene).
struct SceneSet {
  std::uint64_t id = 0;  // unique per scene built, to key the reference answers
  std::string name;
  std::size_t n = 0;
  scenes::SceneOptions options;
  scenes::Scene<S> main;
  std::vector<Object*> objs;
  std::vector<fcl::Transform3<S>> home;
  Extent extent;

  scenes::Scene<S> query_scene;  // 1,000 objects sized like the main scene's
  std::vector<Object*> queries;
  scenes::Scene<S> robot_scene;  // 30 objects around the origin
  std::vector<Object*> robot;
  Extent robot_extent;
  scenes::Scene<S> dist_scene;  // small objects, the touching ones dropped
  std::vector<Object*> dist_objs;
  Extent dist_extent;
  scenes::Scene<S> dist_query_scene;
  std::vector<Object*> dist_queries;  // 100 objects touching none of dist_objs
  bool derived = false;

  void derive() {
    if (derived) return;
    derived = true;
    const double a = scenes::typicalSize(options);
    // Queries: 1,000 objects of the main scene's size, from another seed.
    scenes::SceneOptions q = options;
    q.n = 1000;
    q.seed = 2;
    q.size_scale = std::cbrt(1000.0 / double(n));
    query_scene = scenes::makeScene<S>(q);
    queries = query_scene.pointers();
    // Robot: 30 links in a box of 400 around the origin (a tenth of the world's width).
    scenes::SceneOptions r;
    r.n = 30;
    r.meshes = options.meshes;
    r.seed = 5;
    r.half_extent = 200;
    robot_scene = scenes::makeScene<S>(r);
    robot = robot_scene.pointers();
    robot_extent = extentOf(robot, scenes::typicalSize(r));
    // Distance: the same layout with smaller objects; touching ones dropped.
    scenes::SceneOptions d = options;
    d.seed = 3;
    d.size_scale = kDistanceScale;
    dist_scene = scenes::makeScene<S>(d);
    auto all = dist_scene.pointers();
    dist_objs = untouched(all, all, true);
    dist_extent = extentOf(dist_objs, a * kDistanceScale);
    scenes::SceneOptions dq = d;
    dq.n = 1000;
    dq.seed = 4;
    dq.size_scale = kDistanceScale * std::cbrt(1000.0 / double(n));
    dist_query_scene = scenes::makeScene<S>(dq);
    dist_queries = untouched(dist_query_scene.pointers(), dist_objs, false);
    if (dist_queries.size() > 100) dist_queries.resize(100);
  }

  /// Managers over the main, distance and robot objects, built once per scene and manager and
  /// shared by the cases that do not change them.
  Manager* mainManager(Mgr m) { return cached(main_managers, m, objs, extent).mgr.get(); }
  Manager* distManager(Mgr m) {
    derive();
    return cached(dist_managers, m, dist_objs, dist_extent).mgr.get();
  }
  Manager* robotManager(Mgr m) {
    derive();
    return cached(robot_managers, m, robot, robot_extent).mgr.get();
  }
  /// mainManager(Mgr::cube) and distManager(Mgr::cube) with their own type.
  const CubeManager* mainCube() { return cached(main_managers, Mgr::cube, objs, extent).cube; }
  const CubeManager* distCube() {
    derive();
    return cached(dist_managers, Mgr::cube, dist_objs, dist_extent).cube;
  }

  void restore() {
    for (std::size_t i = 0; i < objs.size(); ++i) {
      objs[i]->setTransform(home[i]);
      objs[i]->computeAABB();
    }
  }

 private:
  struct Entry {
    std::unique_ptr<Manager> mgr;
    CubeManager* cube = nullptr;  // mgr's object if it is the cube manager
  };
  using Cache = std::map<Mgr, Entry>;
  static const Entry& cached(Cache& c, Mgr m, const std::vector<Object*>& o, const Extent& e) {
    auto& slot = c[m];
    if (!slot.mgr) slot.mgr = built(m, o, e, &slot.cube);
    return slot;
  }
  // Declared last so that they go before the objects they point to.
  Cache main_managers, dist_managers, robot_managers;
};

std::unique_ptr<SceneSet> g_scene;

SceneSet& sceneFor(const std::string& name, std::size_t n) {
  if (!g_scene || g_scene->name != name || g_scene->n != n) {
    g_scene.reset();  // free the previous one first
    static std::uint64_t next_id = 0;
    auto s = std::make_unique<SceneSet>();
    s->id = ++next_id;
    s->name = name;
    s->n = n;
    s->options = optionsFor(name, n);
    s->main = scenes::makeScene<S>(s->options);
    s->objs = s->main.pointers();
    for (Object* o : s->objs) s->home.push_back(o->getTransform());
    s->extent = extentOf(s->objs, scenes::typicalSize(s->options));
    g_scene = std::move(s);
  }
  return *g_scene;
}

/// 1% motion: each step moves the next max(1, n/100) objects of a fixed random permutation to
/// their home pose plus a random offset of up to one typical object size per axis, so the scene
/// stays statistically the same however many steps a manager runs.
class Motion {
 public:
  explicit Motion(const SceneSet& s)
      : objs_(s.objs),
        home_(s.home),
        perm_(s.objs.size()),
        rng_(7),
        offset_(-1, 1),
        step_(scenes::typicalSize(s.options)),
        per_step_(std::max<std::size_t>(1, s.objs.size() / 100)) {
    std::iota(perm_.begin(), perm_.end(), 0u);
    std::shuffle(perm_.begin(), perm_.end(), rng_);
  }
  std::size_t perStep() const { return per_step_; }
  /// Picks the objects of the next step (does not move them yet).
  const std::vector<Object*>& pick() {
    moved_.clear();
    idx_.clear();
    for (std::size_t k = 0; k < per_step_; ++k) {
      const std::uint32_t i = perm_[cursor_++ % perm_.size()];
      idx_.push_back(i);
      moved_.push_back(objs_[i]);
    }
    return moved_;
  }
  /// Moves the picked objects and recomputes their AABBs.
  void move() {
    for (std::uint32_t i : idx_) {
      fcl::Transform3<S> tf = home_[i];
      tf.translation() +=
          fcl::Vector3<S>(offset_(rng_) * step_, offset_(rng_) * step_, offset_(rng_) * step_);
      objs_[i]->setTransform(tf);
      objs_[i]->computeAABB();
    }
  }

 private:
  const std::vector<Object*>& objs_;
  const std::vector<fcl::Transform3<S>>& home_;
  std::vector<std::uint32_t> perm_;
  std::mt19937 rng_;
  std::uniform_real_distribution<double> offset_;
  double step_;
  std::size_t per_step_;
  std::size_t cursor_ = 0;
  std::vector<std::uint32_t> idx_;
  std::vector<Object*> moved_;
};

/// The robot's path for robot_narrow: kRobotPoses poses across the world along x (a slight
/// rise in y and z), every link translated by the pose's offset from its home transform.
constexpr int kRobotPoses = 16;

class RobotPath {
 public:
  explicit RobotPath(const SceneSet& s) : links_(s.robot), span_(s.options.half_extent) {
    for (Object* o : links_) home_.push_back(o->getTransform());
  }
  ~RobotPath() { restore(); }
  RobotPath(const RobotPath&) = delete;
  RobotPath& operator=(const RobotPath&) = delete;
  /// Moves every link to pose k and recomputes its AABB.
  void pose(int k) {
    const double t = -0.8 + 1.6 * double(k) / double(kRobotPoses - 1);
    const fcl::Vector3<S> offset(t * span_, 0.1 * t * span_, -0.05 * t * span_);
    for (std::size_t i = 0; i < links_.size(); ++i) {
      fcl::Transform3<S> tf = home_[i];
      tf.translation() += offset;
      links_[i]->setTransform(tf);
      links_[i]->computeAABB();
    }
  }
  void restore() {
    for (std::size_t i = 0; i < links_.size(); ++i) {
      links_[i]->setTransform(home_[i]);
      links_[i]->computeAABB();
    }
  }

 private:
  const std::vector<Object*>& links_;
  std::vector<fcl::Transform3<S>> home_;
  double span_;
};

/// robotCollides at every pose of the path, with robot managers of kind m built for it.
std::vector<bool> robotAnswers(Mgr m, const Manager& world, SceneSet& s, int threads = 1) {
  RobotPath path(s);
  auto robot = built(m, s.robot, s.robot_extent);
  std::vector<bool> out;
  for (int k = 0; k < kRobotPoses; ++k) {
    path.pose(k);
    robot->update();
    out.push_back(robotCollides(m, world, *robot, threads));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Cases

enum class Case {
  build,
  selfcollide,
  selfcollide_narrow,
  queries,
  robot,
  selfdistance,
  objdistance,
  update,
  update_vector,
  churn,          // unregister + register + setup(), FCL's documented sequence
  churn_nosetup,  // unregister + register, relying on incremental insertion
  // With FCL's narrow phase in the loop: cube runs its pipeline (collideAll), the FCL
  // managers FCL's default callback.
  selfcollide_narrow_mt,  // cube only, on the hardware's threads; read against selfcollide_narrow
  queries_narrow,         // 1,000 object queries, every contact
  motion_narrow,          // 1% of the objects move, update(moved), every contact; cube: cached
  robot_narrow,           // a 30-object robot manager moves; "does it collide?" per pose
  // cube only: the user's own callback (FCL's default) behind Config::cull_pairs; read against
  // selfcollide_narrow
  selfcollide_cullcb,
  // cube only, with the pipeline's default options (the hardware's threads): read against the
  // FCL managers of queries_narrow, robot_narrow and objdistance
  queries_narrow_mt,
  robot_narrow_mt,
  objdistance_mt,
  last = objdistance_mt
};

const char* caseName(Case c) {
  switch (c) {
    case Case::build:
      return "build";
    case Case::selfcollide:
      return "selfcollide";
    case Case::selfcollide_narrow:
      return "selfcollide_narrow";
    case Case::queries:
      return "queries";
    case Case::robot:
      return "robot";
    case Case::selfdistance:
      return "selfdistance";
    case Case::objdistance:
      return "objdistance";
    case Case::update:
      return "update";
    case Case::update_vector:
      return "update_vector";
    case Case::churn:
      return "churn";
    case Case::churn_nosetup:
      return "churn_nosetup";
    case Case::selfcollide_narrow_mt:
      return "selfcollide_narrow_mt";
    case Case::queries_narrow:
      return "queries_narrow";
    case Case::motion_narrow:
      return "motion_narrow";
    case Case::robot_narrow:
      return "robot_narrow";
    case Case::selfcollide_cullcb:
      return "selfcollide_cullcb";
    case Case::queries_narrow_mt:
      return "queries_narrow_mt";
    case Case::robot_narrow_mt:
      return "robot_narrow_mt";
    case Case::objdistance_mt:
      return "objdistance_mt";
  }
  return "?";
}

bool isChurn(Case c) {
  return c == Case::churn || c == Case::churn_nosetup;
}
bool isMotion(Case c) {
  return c == Case::update || c == Case::update_vector || isChurn(c);
}
bool manualTime(Case c) {
  // Threads: the process's CPU time would add the workers' time, so wall time is measured.
  return c == Case::build || isMotion(c) || c == Case::selfcollide_narrow_mt ||
         c == Case::motion_narrow || c == Case::robot_narrow || c == Case::queries_narrow_mt ||
         c == Case::robot_narrow_mt || c == Case::objdistance_mt;
}

struct Spec {
  Case c;
  std::string scene;
  std::size_t n;
  Mgr m;
  std::string name() const {
    return std::string(caseName(c)) + "/" + scene + "/" + std::to_string(n) + "/" + managerName(m);
  }
};

/// Outcome of a case's correctness check, computed once per case and replayed on every run.
struct Check {
  bool ok = true;
  std::string message;
  std::map<std::string, double> counters;
};

std::map<std::string, Check> g_checks;

/// Reference answers, computed once per scene and shared by all managers of a case.
struct Reference {
  std::map<std::string, std::vector<Pair>> pairs;
  std::map<std::string, std::vector<std::vector<Object*>>> hits;
  std::map<std::string, std::vector<S>> distances;
  std::map<std::string, std::size_t> counts;
  std::uint64_t scene = 0;
};
Reference g_ref;

Reference& referenceOf(const SceneSet& s) {
  if (g_ref.scene != s.id) g_ref = Reference{{}, {}, {}, {}, s.id};
  return g_ref;
}

std::vector<Pair> selfPairs(const Manager& mgr) {
  Recorder r;
  mgr.collide(&r, &Recorder::fn);
  return r.sorted();
}

std::vector<std::vector<Object*>> queryHits(const Manager& mgr, const std::vector<Object*>& qs) {
  std::vector<std::vector<Object*>> out;
  for (Object* q : qs) {
    Recorder r;
    mgr.collide(q, &r, &Recorder::fn);
    std::vector<Object*> h;
    for (const auto& p : r.pairs) h.push_back(p.first == q ? p.second : p.first);
    std::sort(h.begin(), h.end());
    out.push_back(std::move(h));
  }
  return out;
}

std::vector<Pair> robotPairs(Mgr m, const Manager& scene_mgr, const SceneSet& s) {
  auto robot = built(m, s.robot, s.robot_extent);
  Recorder r;
  scene_mgr.collide(robot.get(), &r, &Recorder::fn);
  return r.sorted();
}

std::vector<S> objectDistances(Mgr m, const Manager& mgr, const std::vector<Object*>& qs) {
  std::vector<S> out;
  for (Object* q : qs) out.push_back(objectDistance(m, mgr, q));
  return out;
}

/// Distances agree if equal up to the rounding of GJK run with the arguments swapped.
bool sameDistance(S a, S b) {
  return std::abs(a - b) <= 1e-6 * std::max<S>(1, std::abs(b));
}

std::string describe(const std::vector<Pair>& got, const std::vector<Pair>& want) {
  std::vector<Pair> extra, missing;
  std::set_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(extra));
  std::set_difference(want.begin(), want.end(), got.begin(), got.end(),
                      std::back_inserter(missing));
  std::ostringstream os;
  os << got.size() << " pairs vs " << want.size() << " expected (" << extra.size()
     << " extra or duplicated, " << missing.size() << " missing)";
  return os.str();
}

/// The state the motion cases check: a few steps of the case's own update path, then the
/// manager's self pairs against a reference built afresh on the moved objects.
std::vector<Pair> pairsAfterMotion(Case c, Mgr m, SceneSet& s, std::vector<Pair>* want) {
  auto mgr = built(m, s.objs, s.extent, nullptr, Use::motion_loop);
  Motion motion(s);
  for (int step = 0; step < 3; ++step) {
    const auto& moved = motion.pick();
    if (isChurn(c))
      for (Object* o : moved) mgr->unregisterObject(o);
    motion.move();
    if (c == Case::update) mgr->update();
    if (c == Case::update_vector) mgr->update(moved);
    if (isChurn(c))
      for (Object* o : moved) mgr->registerObject(o);
    if (c == Case::churn) mgr->setup();
  }
  auto got = selfPairs(*mgr);
  *want = selfPairs(*built(referenceFor(s.n), s.objs, s.extent));
  s.restore();
  return got;
}

double liveHeapBytes() {
  const struct mallinfo2 mi = mallinfo2();
  return double(mi.uordblks) + double(mi.hblkhd);
}

Check runCheck(const Spec& spec, SceneSet& s) {
  Check ck;
  Reference& ref = referenceOf(s);
  const Mgr rm = referenceFor(s.n);
  const std::string key = caseName(spec.c);
  const double n = double(s.n);
  auto fail = [&](const std::string& what) {
    ck.ok = false;
    ck.message = what;
  };
  // FCL managers: mismatches are reported, not fatal.
  auto compare = [&](bool equal, const std::string& what) {
    if (spec.m == Mgr::cube) {
      if (!equal) fail(what);
    } else {
      ck.counters["agree"] = equal ? 1 : 0;
      if (!equal)
        std::fprintf(stderr, "note: %s disagrees with the reference: %s\n", spec.name().c_str(),
                     what.c_str());
    }
  };

  switch (spec.c) {
    case Case::build:
    case Case::selfcollide: {
      if (!ref.pairs.count("self")) ref.pairs["self"] = selfPairs(*s.mainManager(rm));
      const auto& want = ref.pairs["self"];
      if (spec.c == Case::build) {
        // Live heap growth over construction + register + setup: the manager's own memory.
        const double before = liveHeapBytes();
        CubeManager* cube_mgr = nullptr;
        auto mgr = built(spec.m, s.objs, s.extent, &cube_mgr);
        ck.counters["heap_B_per_obj"] = (liveHeapBytes() - before) / n;
        if (spec.m == Mgr::cube) ck.counters["tree_B_per_obj"] = double(cube_mgr->bytes()) / n;
        const auto got = selfPairs(*mgr);
        compare(got == want, describe(got, want));
      } else {
        auto mgr = s.mainManager(spec.m);
        const auto got = selfPairs(*mgr);
        compare(got == want, describe(got, want));
        ck.counters["overlaps_per_obj"] = double(want.size()) / n;
        if (spec.m == Mgr::cube) {
          cube::QueryStats st;
          Counter cnt;
          s.mainCube()->collide(&cnt, &Counter::fn, &st);
          ck.counters["box_tests_per_obj"] = double(st.box_tests) / n;
          ck.counters["cubes_per_obj"] = double(st.cubes_visited) / n;
        }
      }
      break;
    }
    case Case::selfcollide_narrow: {
      if (!ref.counts.count("narrow")) ref.counts["narrow"] = narrowCollide(rm, *s.mainManager(rm));
      const std::size_t want = ref.counts["narrow"];
      const std::size_t got = narrowCollide(spec.m, *s.mainManager(spec.m));
      ck.counters["contacts"] = double(got);
      cube::NarrowPhaseStats st;
      ck.counters["narrow_calls"] = double(narrowCollideCalls(spec.m, *s.mainManager(spec.m), &st));
      if (spec.m == Mgr::cube) {  // what the cull settled without FCL
        ck.counters["culled"] = double(st.culled);
        ck.counters["proved"] = double(st.proved);
      }
      compare(got == want,
              std::to_string(got) + " contacts vs " + std::to_string(want) + " expected");
      break;
    }
    case Case::queries: {
      s.derive();
      if (!ref.hits.count("queries")) {
        auto& h = ref.hits["queries"];
        h = queryHits(*s.mainManager(rm), s.queries);
        // FCL 0.7's Naive collide(obj) calls back every object without an AABB test: keep the
        // overlapping ones, which is what a broadphase must report.
        for (std::size_t i = 0; i < h.size(); ++i)
          h[i].erase(std::remove_if(
                         h[i].begin(), h[i].end(),
                         [&](Object* o) { return !o->getAABB().overlap(s.queries[i]->getAABB()); }),
                     h[i].end());
      }
      const auto& want = ref.hits["queries"];
      auto mgr = s.mainManager(spec.m);
      const auto got = queryHits(*mgr, s.queries);
      std::size_t bad = 0, hits = 0;
      for (std::size_t i = 0; i < want.size(); ++i) {
        bad += got[i] != want[i];
        hits += want[i].size();
      }
      compare(bad == 0, std::to_string(bad) + " of " + std::to_string(want.size()) +
                            " queries report different objects");
      ck.counters["hits_per_query"] = double(hits) / double(want.size());
      if (spec.m == Mgr::cube) {
        cube::QueryStats st;
        Counter cnt;
        for (Object* q : s.queries) s.mainCube()->collide(q, &cnt, &Counter::fn, &st);
        ck.counters["box_tests_per_query"] = double(st.box_tests) / double(s.queries.size());
      }
      break;
    }
    case Case::robot: {
      s.derive();
      if (!ref.pairs.count("robot")) ref.pairs["robot"] = robotPairs(rm, *s.mainManager(rm), s);
      const auto& want = ref.pairs["robot"];
      auto mgr = s.mainManager(spec.m);
      const auto got = robotPairs(spec.m, *mgr, s);
      compare(got == want, describe(got, want));
      ck.counters["pairs"] = double(want.size());
      if (spec.m == Mgr::cube) {
        auto robot = built(Mgr::cube, s.robot, s.robot_extent);
        cube::QueryStats st;
        Counter cnt;
        s.mainCube()->collide(robot.get(), &cnt, &Counter::fn, &st);
        ck.counters["box_tests_per_robot_obj"] = double(st.box_tests) / double(s.robot.size());
      }
      break;
    }
    case Case::selfdistance: {
      s.derive();
      if (!ref.distances.count("self"))
        ref.distances["self"] = {selfDistance(rm, *s.distManager(rm))};
      const S want = ref.distances["self"][0];
      auto mgr = s.distManager(spec.m);
      const S got = selfDistance(spec.m, *mgr);
      std::ostringstream os;
      os.precision(17);
      os << "distance " << got << " vs " << want << " expected";
      compare(sameDistance(got, want), os.str());
      ck.counters["objects"] = double(s.dist_objs.size());
      ck.counters["narrow_calls"] = double(selfDistanceCalls(spec.m, *mgr));
      if (spec.m == Mgr::cube) {
        cube::QueryStats st;
        cube::DistanceData<S> d;
        s.distCube()->distance(&d, cube::defaultDistanceCallback<S>, &st);
        ck.counters["box_tests_per_obj"] = double(st.box_tests) / double(s.dist_objs.size());
      }
      break;
    }
    case Case::objdistance: {
      s.derive();
      if (!ref.distances.count("objects"))
        ref.distances["objects"] = objectDistances(rm, *s.distManager(rm), s.dist_queries);
      const auto& want = ref.distances["objects"];
      auto mgr = s.distManager(spec.m);
      const auto got = objectDistances(spec.m, *mgr, s.dist_queries);
      std::size_t bad = 0;
      for (std::size_t i = 0; i < want.size(); ++i) bad += !sameDistance(got[i], want[i]);
      compare(bad == 0,
              std::to_string(bad) + " of " + std::to_string(want.size()) + " distances differ");
      ck.counters["objects"] = double(s.dist_objs.size());
      ck.counters["queries"] = double(s.dist_queries.size());
      ck.counters["narrow_calls_per_query"] =
          double(objectDistanceCalls(spec.m, *mgr, s.dist_queries)) / double(s.dist_queries.size());
      if (spec.m == Mgr::cube) {
        cube::QueryStats st;
        for (Object* q : s.dist_queries) {
          cube::DistanceData<S> d;
          s.distCube()->distance(q, &d, cube::defaultDistanceCallback<S>, &st);
        }
        ck.counters["box_tests_per_query"] = double(st.box_tests) / double(s.dist_queries.size());
      }
      break;
    }
    case Case::selfcollide_narrow_mt: {
      if (!ref.counts.count("narrow")) ref.counts["narrow"] = narrowCollide(rm, *s.mainManager(rm));
      const std::size_t want = ref.counts["narrow"];
      const std::size_t got = narrowCollide(spec.m, *s.mainManager(spec.m), 0);
      ck.counters["contacts"] = double(got);
      ck.counters["threads"] = double(cube::hardwareThreads());
      compare(got == want,
              std::to_string(got) + " contacts vs " + std::to_string(want) + " expected");
      break;
    }
    case Case::selfcollide_cullcb: {
      if (!ref.counts.count("narrow")) ref.counts["narrow"] = narrowCollide(rm, *s.mainManager(rm));
      const std::size_t want = ref.counts["narrow"];
      const auto culled = built(Mgr::cube, s.objs, s.extent, nullptr, Use::culled_callback);
      std::size_t calls = 0;
      const std::size_t got = defaultCallbackCollide(*culled, &calls);
      ck.counters["contacts"] = double(got);
      ck.counters["callback_calls"] = double(calls);
      compare(got == want,
              std::to_string(got) + " contacts vs " + std::to_string(want) + " expected");
      break;
    }
    case Case::queries_narrow:
    case Case::queries_narrow_mt: {
      s.derive();
      if (!ref.counts.count("queries_narrow")) {
        std::size_t c = 0;
        for (Object* q : s.queries) c += narrowQuery(rm, *s.mainManager(rm), q);
        ref.counts["queries_narrow"] = c;
      }
      const std::size_t want = ref.counts["queries_narrow"];
      const int threads = spec.c == Case::queries_narrow_mt ? 0 : 1;
      std::size_t got = 0;
      for (Object* q : s.queries) got += narrowQuery(spec.m, *s.mainManager(spec.m), q, threads);
      ck.counters["contacts"] = double(got);
      if (threads == 0) ck.counters["threads"] = double(cube::hardwareThreads());
      compare(got == want,
              std::to_string(got) + " contacts vs " + std::to_string(want) + " expected");
      break;
    }
    case Case::motion_narrow: {
      // Three steps of the timed loop, then the contacts against a reference built afresh.
      auto mgr = built(spec.m, s.objs, s.extent, nullptr, Use::motion_loop);
      cube::NarrowPhaseCache<S> cache;
      Motion motion(s);
      std::size_t got = 0;
      for (int step = 0; step < 3; ++step) {
        const auto& moved = motion.pick();
        motion.move();
        mgr->update(moved);
        got = narrowCollide(spec.m, *mgr, 1, &cache);
      }
      const std::size_t want = narrowCollide(rm, *built(rm, s.objs, s.extent));
      s.restore();
      ck.counters["contacts"] = double(got);
      compare(got == want, "after 3 steps: " + std::to_string(got) + " contacts vs " +
                               std::to_string(want) + " expected");
      break;
    }
    case Case::objdistance_mt: {
      const Manager& want_mgr = *s.distManager(rm);
      const Manager& got_mgr = *s.distManager(spec.m);
      std::size_t wrong = 0;
      for (Object* q : s.dist_queries)
        wrong += !sameDistance(pipelineDistance(got_mgr, q), objectDistance(rm, want_mgr, q));
      ck.counters["threads"] = double(cube::hardwareThreads());
      compare(wrong == 0, std::to_string(wrong) + " distances differ");
      break;
    }
    case Case::robot_narrow:
    case Case::robot_narrow_mt: {
      s.derive();
      const std::vector<bool> want = robotAnswers(rm, *s.mainManager(rm), s);
      const std::vector<bool> got =
          robotAnswers(spec.m, *s.mainManager(spec.m), s, spec.c == Case::robot_narrow_mt ? 0 : 1);
      std::size_t colliding = 0;
      for (bool b : want) colliding += b;
      ck.counters["colliding_poses"] = double(colliding);
      compare(got == want, "the answers at some poses differ");
      break;
    }
    case Case::update:
    case Case::update_vector:
    case Case::churn:
    case Case::churn_nosetup: {
      std::vector<Pair> want;
      const auto got = pairsAfterMotion(spec.c, spec.m, s, &want);
      compare(got == want, "after 3 steps: " + describe(got, want));
      break;
    }
  }
  return ck;
}

// ---------------------------------------------------------------------------------------------
// Timed loops

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

void run(benchmark::State& state, const Spec& spec) {
  SceneSet& s = sceneFor(spec.scene, spec.n);
  const std::string name = spec.name();
  auto it = g_checks.find(name);
  if (it == g_checks.end()) {
    it = g_checks.emplace(name, runCheck(spec, s)).first;
    if (!it->second.ok) {
      g_failed = true;
      std::fprintf(stderr, "CHECK FAILED: %s: %s\n", name.c_str(), it->second.message.c_str());
    }
  }
  const Check& ck = it->second;
  if (!ck.ok) {
    state.SkipWithError(("check failed: " + ck.message).c_str());
    return;
  }
  for (const auto& [k, v] : ck.counters) state.counters[k] = v;

  switch (spec.c) {
    case Case::build: {
      for (auto _ : state) {
        auto mgr = makeManager(spec.m, s.extent);
        const auto t0 = Clock::now();
        mgr->registerObjects(s.objs);
        mgr->setup();
        const auto t1 = Clock::now();
        state.SetIterationTime(seconds(t1 - t0));
      }
      break;
    }
    case Case::selfcollide: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) {
        Counter c;
        mgr->collide(&c, &Counter::fn);
        benchmark::DoNotOptimize(c.calls);
      }
      break;
    }
    case Case::selfcollide_narrow: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) benchmark::DoNotOptimize(narrowCollide(spec.m, *mgr));
      break;
    }
    case Case::queries: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) {
        Counter c;
        for (Object* q : s.queries) mgr->collide(q, &c, &Counter::fn);
        benchmark::DoNotOptimize(c.calls);
      }
      break;
    }
    case Case::robot: {
      auto mgr = s.mainManager(spec.m);
      auto robot = s.robotManager(spec.m);
      for (auto _ : state) {
        Counter c;
        mgr->collide(robot, &c, &Counter::fn);
        benchmark::DoNotOptimize(c.calls);
      }
      break;
    }
    case Case::selfdistance: {
      auto mgr = s.distManager(spec.m);
      for (auto _ : state) benchmark::DoNotOptimize(selfDistance(spec.m, *mgr));
      break;
    }
    case Case::objdistance: {
      auto mgr = s.distManager(spec.m);
      for (auto _ : state) {
        S sum = 0;
        for (Object* q : s.dist_queries) sum += objectDistance(spec.m, *mgr, q);
        benchmark::DoNotOptimize(sum);
      }
      break;
    }
    case Case::selfcollide_narrow_mt: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) {
        const auto t0 = Clock::now();
        benchmark::DoNotOptimize(narrowCollide(spec.m, *mgr, 0));
        state.SetIterationTime(seconds(Clock::now() - t0));
      }
      break;
    }
    case Case::selfcollide_cullcb: {
      const auto culled = built(Mgr::cube, s.objs, s.extent, nullptr, Use::culled_callback);
      for (auto _ : state) benchmark::DoNotOptimize(defaultCallbackCollide(*culled));
      break;
    }
    case Case::queries_narrow: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) {
        std::size_t c = 0;
        for (Object* q : s.queries) c += narrowQuery(spec.m, *mgr, q);
        benchmark::DoNotOptimize(c);
      }
      break;
    }
    case Case::motion_narrow: {
      auto mgr = built(spec.m, s.objs, s.extent, nullptr, Use::motion_loop);
      cube::NarrowPhaseCache<S> cache;
      cube::NarrowPhaseStats st;
      Motion motion(s);
      state.counters["updated_per_step"] = double(motion.perStep());
      // One step before the clock starts, for every manager: a loop's steady state (cube's
      // cache filled), not its first step, is what a simulation runs.
      const std::vector<Object*>& first = motion.pick();
      motion.move();
      mgr->update(first);
      if (spec.m == Mgr::cube) cube::collideAll<S>(*mgr, allContacts(), pipeline(1, &cache));
      for (auto _ : state) {
        const auto& moved = motion.pick();
        motion.move();
        const auto t0 = Clock::now();
        mgr->update(moved);
        std::size_t c = 0;
        if (spec.m == Mgr::cube)
          c = cube::collideAll<S>(*mgr, allContacts(), pipeline(1, &cache, &st)).numContacts();
        else
          c = narrowCollide(spec.m, *mgr);
        state.SetIterationTime(seconds(Clock::now() - t0));
        benchmark::DoNotOptimize(c);
      }
      if (spec.m == Mgr::cube && st.candidate_pairs > 0) {
        const double steps = double(state.iterations());
        state.counters["narrow_calls_per_step"] = double(st.narrow_calls) / steps;
        state.counters["cached_per_step"] = double(st.cached) / steps;
      }
      mgr.reset();
      s.restore();
      break;
    }
    case Case::queries_narrow_mt: {
      auto mgr = s.mainManager(spec.m);
      for (auto _ : state) {
        const auto t0 = Clock::now();
        std::size_t c = 0;
        for (Object* q : s.queries) c += narrowQuery(spec.m, *mgr, q, 0);
        state.SetIterationTime(seconds(Clock::now() - t0));
        benchmark::DoNotOptimize(c);
      }
      break;
    }
    case Case::objdistance_mt: {
      auto mgr = s.distManager(spec.m);
      for (auto _ : state) {
        const auto t0 = Clock::now();
        S sum = 0;
        for (Object* q : s.dist_queries) sum += pipelineDistance(*mgr, q);
        state.SetIterationTime(seconds(Clock::now() - t0));
        benchmark::DoNotOptimize(sum);
      }
      break;
    }
    case Case::robot_narrow:
    case Case::robot_narrow_mt: {
      s.derive();
      auto& world = *s.mainManager(spec.m);
      RobotPath path(s);
      auto robot = built(spec.m, s.robot, s.robot_extent);
      const int threads = spec.c == Case::robot_narrow_mt ? 0 : 1;
      int k = 0;
      for (auto _ : state) {
        path.pose(k);
        k = (k + 1) % kRobotPoses;
        const auto t0 = Clock::now();
        robot->update();
        benchmark::DoNotOptimize(robotCollides(spec.m, world, *robot, threads));
        state.SetIterationTime(seconds(Clock::now() - t0));
      }
      break;
    }
    case Case::update:
    case Case::update_vector:
    case Case::churn:
    case Case::churn_nosetup: {
      CubeManager* cube_mgr = nullptr;
      // Churn registers and removes: the pair list is set aside there anyway.
      auto mgr = built(spec.m, s.objs, s.extent, &cube_mgr, Use::motion_loop);
      Motion motion(s);
      state.counters["updated_per_step"] = double(motion.perStep());
      for (auto _ : state) {
        const auto& moved = motion.pick();
        Clock::duration t{};
        if (isChurn(spec.c)) {
          // Unregister before moving: some managers find the object's cells from its AABB.
          const auto t0 = Clock::now();
          for (Object* o : moved) mgr->unregisterObject(o);
          t += Clock::now() - t0;
        }
        motion.move();
        const auto t0 = Clock::now();
        if (spec.c == Case::update) mgr->update();
        if (spec.c == Case::update_vector) mgr->update(moved);
        if (isChurn(spec.c))
          for (Object* o : moved) mgr->registerObject(o);
        if (spec.c == Case::churn) mgr->setup();
        Counter c;
        mgr->collide(&c, &Counter::fn);
        t += Clock::now() - t0;
        benchmark::DoNotOptimize(c.calls);
        state.SetIterationTime(seconds(t));
      }
      // What the manager owns after the steps: for cube, the pair list of Config::keep_pairs
      // included.
      if (cube_mgr != nullptr)
        state.counters["B_per_obj_after"] = double(cube_mgr->bytes()) / double(s.objs.size());
      mgr.reset();
      s.restore();
      break;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// What runs where

const std::size_t kSizes[] = {32, 1000, 10000, 100000};

/// False for combinations left out: Naive beyond 2,000 objects, mesh scenes of 100,000 objects
/// (gigabytes of BVH models), and managers that need far more than a second per call at a size
/// (measured in a probe run on the uniform scene; the figures are in benchmarks/README.md).
bool runs(Case c, const std::string& scene, std::size_t n, Mgr m) {
  if (m == Mgr::naive && n > 2000) return false;
  if (n >= 100000 && scene == "meshes") return false;
  if (c == Case::selfcollide_narrow_mt || c == Case::selfcollide_cullcb)
    return m == Mgr::cube && runs(Case::selfcollide_narrow, scene, n, m);
  if (c == Case::queries_narrow_mt)
    return m == Mgr::cube && runs(Case::queries_narrow, scene, n, m);
  if (c == Case::robot_narrow_mt) return m == Mgr::cube && runs(Case::robot_narrow, scene, n, m);
  if (c == Case::objdistance_mt) return m == Mgr::cube && runs(Case::objdistance, scene, n, m);
  // FCL 0.7's IntervalTree does not return from the motion loop (update(moved), then collide)
  // even at 32 objects.
  if (c == Case::motion_narrow && m == Mgr::interval) return false;
  // The other narrow-phase cases run up to 10,000 objects.
  if ((c == Case::queries_narrow || c == Case::motion_narrow || c == Case::robot_narrow) &&
      n > 10000)
    return false;
  // The update(vector) and churn cases run at 1,000 and 10,000 objects.
  if ((c == Case::update_vector || isChurn(c)) && (n < 1000 || n > 10000)) return false;
  // FCL 0.7's IntervalTree corrupts the heap under unregister/register churn (glibc aborts with
  // "corrupted size vs. prev_size in fastbins" at 1,000 objects).
  if (isChurn(c) && m == Mgr::interval) return false;
  // Self distance at 10,000: SaP 5.8 s and IntervalTree 9.1 s per call (cube 1.4 ms).
  if (c == Case::selfdistance && n >= 10000 && (m == Mgr::sap || m == Mgr::interval)) return false;
  if (n >= 100000) {
    switch (m) {
      case Mgr::cube:
      case Mgr::dtree:
      case Mgr::dtree_array:
        return true;
      case Mgr::sap:  // 10.6 s to build, but its self-collide is the fastest: keep that one
        return c == Case::selfcollide;
      case Mgr::ssap:      // builds in 0.2 s, self-collides in 3.5 s
      case Mgr::interval:  // builds in 1.8 s, self-collides in 4.9 s
      case Mgr::shash:     // builds in 0.1 s, self-collides in 32 s
        return c == Case::build;
      case Mgr::naive:
        return false;
    }
  }
  return true;
}

void registerAll() {
  for (const char* scene : kSceneNames)
    for (std::size_t n : kSizes)
      for (int ci = 0; ci <= int(Case::last); ++ci)
        for (Mgr m : kAllManagers) {
          const Case c = Case(ci);
          if (!runs(c, scene, n, m)) continue;
          const Spec spec{c, scene, n, m};
          auto* b = benchmark::RegisterBenchmark(spec.name().c_str(),
                                                 [spec](benchmark::State& st) { run(st, spec); });
          b->Unit(benchmark::kMicrosecond);
          if (manualTime(c)) b->UseManualTime();
          // A motion case makes a fresh manager per repetition and then steps: the few steps
          // that the minimum time allows a slow manager show only how it starts (a fresh tree,
          // cube's first listing of the pairs), not how it runs. Cube and the tree managers,
          // the contenders, run the same fixed number of steps, which spans at least one of
          // cube's rebuild cycles (about 23 steps); the others keep the minimum time.
          if (isMotion(c) && n >= 10000 &&
              (m == Mgr::cube || m == Mgr::dtree || m == Mgr::dtree_array))
            b->Iterations(n >= 100000 ? 30 : 100);
        }
}

}  // namespace

int main(int argc, char** argv) {
  // --load=N: N processes spin beside the run (a loaded machine), for at most --load_seconds
  // (default 1800), stopped at exit.
  const int load = cube::scenes::BusyLoad::takeArgument(argc, argv, "--load");
  const int load_seconds = cube::scenes::BusyLoad::takeArgument(argc, argv, "--load_seconds");
  const cube::scenes::BusyLoad busy(load, load_seconds > 0 ? load_seconds : 1800);
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--smoke")
      g_smoke = true;
    else
      argv[kept++] = argv[i];
  }
  argc = kept;
  argv[argc] = nullptr;
  if (load > 0) benchmark::AddCustomContext("busy_processes", std::to_string(load));
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const bool failed = g_failed || g_extra_failed;
  if (failed) std::fprintf(stderr, "cube_bench: correctness checks FAILED (see above)\n");
  return failed ? 1 : 0;
}
