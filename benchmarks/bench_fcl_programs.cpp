// FCL 0.7's own broadphase test programs re-timed with the cube manager in their manager lists:
// test_fcl_broadphase_collision_1.cpp (register, setup, every object moved, update, self
// collide, 1,000 query collides), test_fcl_broadphase_collision_2.cpp (the same without the
// motion, and its empty-manager case), test_fcl_broadphase_distance.cpp (query distances and
// self distance), at their Release sizes, with the same scenes, managers, requests and FCL's
// default callbacks.
//
//   cube_fcl_programs [--reps N] [--json out.json] [--sizes 100,1000] [--self-sizes 512,1000,5000]
//                     [--programs update,collision,distance,self_distance,empty]
//                     [--naive-max OBJECTS] [--rebuild-budget B] [--quick]
//
// Each cell is timed per manager with std::chrono::steady_clock, the manager order rotated
// between repetitions (the first manager timed reads the query objects out of cache), and the
// minimum over the repetitions kept. FCL's narrow phase is warmed up first: its first calls pay a
// one-time initialisation that would land on whichever manager is timed first.
// The cube manager's answers are checked against Naive's (where Naive runs) or else the dynamic
// tree's; any difference is printed and makes the exit status 1. The other managers' differences
// are printed and recorded, not fatal.

#include <fcl/broadphase/broadphase_SSaP.h>
#include <fcl/broadphase/broadphase_SaP.h>
#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree_array.h>
#include <fcl/broadphase/broadphase_interval_tree.h>
#include <fcl/broadphase/broadphase_spatialhash.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/broadphase/detail/sparse_hash_table.h>
#include <fcl/broadphase/detail/spatial_hash.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace {

using S = double;
using Clock = std::chrono::steady_clock;
using Object = fcl::CollisionObject<S>;
using Manager = fcl::BroadPhaseCollisionManager<S>;
using ObjectPtr = std::unique_ptr<Object>;
using Mesh = fcl::BVHModel<fcl::OBBRSS<S>>;

// The managers of FCL's programs in their order, then the cube manager.
const std::vector<std::string> kManagers = {"Naive",
                                            "SSaP",
                                            "SaP",
                                            "IntervalTree",
                                            "SpatialHashing",
                                            "DynamicAABBTree",
                                            "DynamicAABBTree_Array",
                                            "DynamicAABBTree_l2",
                                            "DynamicAABBTree_Array_l2",
                                            "cube"};
constexpr int kNaive = 0;
constexpr int kSaP = 2;
constexpr int kDynTree = 5;
constexpr int kCube = 9;

struct Options {
  int reps = 3;
  std::string json;
  std::vector<std::size_t> sizes = {100, 1000};
  std::vector<std::size_t> self_sizes = {512, 1000, 5000};
  std::vector<std::string> programs = {"update", "collision", "distance", "self_distance", "empty"};
  std::size_t naive_max = 3000;  // objects; Naive's self queries are quadratic
  double rebuild_budget = cube::Config().rebuild_budget;  // the cube manager's
  std::size_t collide_queries = 1000;
  std::size_t distance_queries = 100;
  std::size_t empty_queries = 1000;
  bool quick = false;
  std::string command;
};

// ---------------------------------------------------------------------------------------------
// Scenes, drawn as FCL's test utilities draw them (rand(), the same order of draws), so a seed
// gives FCL's own kind of scene.

S randIn(S lo, S hi) {
  const S t = std::rand() / (static_cast<S>(RAND_MAX) + 1);
  return lo + t * (hi - lo);
}

fcl::Transform3<S> randomTransform(S scale) {
  const S x = randIn(-scale, scale), y = randIn(-scale, scale), z = randIn(-scale, scale);
  const S pi = fcl::constants<S>::pi();
  const S a = randIn(0, 2 * pi), b = randIn(0, 2 * pi), c = randIn(0, 2 * pi);
  // FCL's eulerToMatrix(a, b, c): c about X, then b about Y, then a about Z.
  fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
  tf.linear() = (fcl::AngleAxis<S>(c, fcl::Vector3<S>::UnitX()) *
                 fcl::AngleAxis<S>(b, fcl::Vector3<S>::UnitY()) *
                 fcl::AngleAxis<S>(a, fcl::Vector3<S>::UnitZ()))
                    .toRotationMatrix();
  tf.translation() = fcl::Vector3<S>(x, y, z);
  return tf;
}

std::shared_ptr<fcl::CollisionGeometry<S>> shape(int kind, bool mesh) {
  const fcl::Transform3<S> id = fcl::Transform3<S>::Identity();
  if (kind == 0) {
    fcl::Box<S> box(5, 10, 20);
    if (!mesh) return std::make_shared<fcl::Box<S>>(box);
    auto m = std::make_shared<Mesh>();
    fcl::generateBVHModel(*m, box, id);
    return m;
  }
  if (kind == 1) {
    fcl::Sphere<S> sphere(30);
    if (!mesh) return std::make_shared<fcl::Sphere<S>>(sphere);
    auto m = std::make_shared<Mesh>();
    fcl::generateBVHModel(*m, sphere, id, 16, 16);
    return m;
  }
  fcl::Cylinder<S> cylinder(10, 40);
  if (!mesh) return std::make_shared<fcl::Cylinder<S>>(cylinder);
  auto m = std::make_shared<Mesh>();
  fcl::generateBVHModel(*m, cylinder, id, 16, 16);
  return m;
}

// generateEnvironments / generateEnvironmentsMesh: n boxes, n spheres, n cylinders, each at a
// random transform in [-scale, scale]^3, a geometry of its own per object.
void generateEnvironment(std::vector<ObjectPtr>& out, S scale, std::size_t n, bool mesh) {
  for (int kind = 0; kind < 3; ++kind) {
    std::vector<fcl::Transform3<S>> tfs;
    for (std::size_t i = 0; i < n; ++i) tfs.push_back(randomTransform(scale));
    for (std::size_t i = 0; i < n; ++i)
      out.push_back(std::make_unique<Object>(shape(kind, mesh), tfs[i]));
  }
}

// generateSelfDistanceEnvironments(Mesh): cubes on a grid of step 2 * scale / n_edge. FCL's
// generator has five shape loops sharing one bound (n_edge^3 / 4), so only its boxes are made,
// and its cell indices wrap in the index type of its loop (unsigned int for shapes, size_t for
// meshes): both kept as they are, so the scene is FCL's.
template <typename Index>
void generateSelfDistanceEnvironment(std::vector<ObjectPtr>& out, S scale, std::size_t n,
                                     bool mesh) {
  const unsigned int n_edge = static_cast<unsigned int>(std::floor(std::pow(n, 1 / 3.0)));
  const S step = scale * 2 / n_edge;
  const S delta = step * 0.05;
  const S single = step - 2 * delta;
  for (Index i = 0; i < n_edge * n_edge * n_edge / 4; ++i) {
    const int x = static_cast<int>(i % (n_edge * n_edge));
    const int y = static_cast<int>((i - n_edge * n_edge * x) % n_edge);
    const int z = static_cast<int>(i - n_edge * n_edge * x - n_edge * y);
    const fcl::Vector3<S> at(x * step + delta + 0.5 * single - scale,
                             y * step + delta + 0.5 * single - scale,
                             z * step + delta + 0.5 * single - scale);
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.translation() = at;
    fcl::Box<S> box(single, single, single);
    std::shared_ptr<fcl::CollisionGeometry<S>> g;
    if (mesh) {
      auto m = std::make_shared<Mesh>();
      fcl::generateBVHModel(*m, box, fcl::Transform3<S>::Identity());
      g = m;
    } else {
      g = std::make_shared<fcl::Box<S>>(box);
    }
    out.push_back(std::make_unique<Object>(g, tf));
  }
}

std::vector<Object*> raw(const std::vector<ObjectPtr>& objs) {
  std::vector<Object*> r;
  for (const auto& o : objs) r.push_back(o.get());
  return r;
}

// ---------------------------------------------------------------------------------------------
// Managers

std::unique_ptr<Manager> makeManager(int kind, std::vector<Object*>& env, S cells_per_axis,
                                     const cube::Config& cube_config) {
  switch (kind) {
    case 0:
      return std::make_unique<fcl::NaiveCollisionManager<S>>();
    case 1:
      return std::make_unique<fcl::SSaPCollisionManager<S>>();
    case 2:
      return std::make_unique<fcl::SaPCollisionManager<S>>();
    case 3:
      return std::make_unique<fcl::IntervalTreeCollisionManager<S>>();
    case 4: {
      // As FCL's programs: the bound of the environment, cells of its smallest extent / 20
      // (/ 5 for self distance).
      fcl::Vector3<S> lo, hi;
      fcl::SpatialHashingCollisionManager<S>::computeBound(env, lo, hi);
      const fcl::Vector3<S> ext = (hi - lo) / cells_per_axis;
      const S cell = std::min(std::min(ext[0], ext[1]), ext[2]);
      using Table =
          fcl::detail::SparseHashTable<fcl::AABB<S>, Object*, fcl::detail::SpatialHash<S>>;
      return std::make_unique<fcl::SpatialHashingCollisionManager<S, Table>>(cell, lo, hi);
    }
    case 5:
      return std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
    case 6:
      return std::make_unique<fcl::DynamicAABBTreeCollisionManager_Array<S>>();
    case 7: {
      auto m = std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
      m->tree_init_level = 2;
      return m;
    }
    case 8: {
      auto m = std::make_unique<fcl::DynamicAABBTreeCollisionManager_Array<S>>();
      m->tree_init_level = 2;
      return m;
    }
    default:
      return std::make_unique<cube::CubeCollisionManager<S>>(cube_config);
  }
}

// ---------------------------------------------------------------------------------------------
// A program's configuration, its cells and their answers

enum class Kind { update, collision, distance, self_distance, empty };

struct Program {
  Kind kind;
  S scale = 2000;
  std::size_t env_size = 0;
  std::size_t query_size = 0;
  std::size_t max_contacts = 1;
  bool exhaustive = false;
  bool mesh = false;
};

const char* kindName(Kind k) {
  switch (k) {
    case Kind::update:
      return "update";
    case Kind::collision:
      return "collision";
    case Kind::distance:
      return "distance";
    case Kind::self_distance:
      return "self_distance";
    default:
      return "empty";
  }
}

// One answer per item (the self query, or each query object) and manager.
struct Answer {
  bool collision = false;
  std::size_t contacts = 0;
  S distance = 0;
};

struct Cell {
  std::string name;
  bool is_distance = false;
  std::vector<double> best_us;               // per manager, min over repetitions; <0: not run
  std::vector<std::vector<Answer>> answers;  // per manager, per item (last repetition)
  std::vector<std::size_t> differ;           // per manager: items unlike the reference's
};

struct Result {
  Program program;
  std::size_t objects = 0;
  std::size_t queries = 0;
  std::vector<int> managers;  // kinds that ran
  int reference = kNaive;
  std::vector<Cell> cells;
  std::vector<std::string> mismatches;
  bool cube_ok = true;
};

double since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

Answer collideAnswer(const fcl::DefaultCollisionData<S>& d) {
  return Answer{d.result.isCollision(), d.result.numContacts(), 0};
}

bool sameAnswer(const Answer& a, const Answer& b, bool is_distance, bool exhaustive) {
  if (is_distance) {
    // FCL's programs' tolerance: 0.01 absolute or relative.
    if (a.distance == b.distance) return true;
    const S d = std::fabs(a.distance - b.distance);
    return d < 0.01 || d / std::fabs(a.distance) < 0.01;
  }
  // Without exhaustive requests a manager may stop at another pair first: only yes/no counts.
  return exhaustive ? a.contacts == b.contacts : a.collision == b.collision;
}

class Runner {
 public:
  Runner(const Program& p, const Options& o) : p_(p), o_(o) {}

  Result run(unsigned seed) {
    std::srand(seed);
    makeScene();
    r_.program = p_;
    r_.objects = env_.size();
    r_.queries = query_.size();
    for (int k = 0; k < static_cast<int>(kManagers.size()); ++k)
      if (k != kNaive || env_.size() <= o_.naive_max) r_.managers.push_back(k);
    r_.reference = r_.managers.front() == kNaive ? kNaive : kDynTree;
    const std::size_t m = r_.managers.size();
    const std::size_t step = std::max<std::size_t>(1, m / static_cast<std::size_t>(o_.reps));
    for (int rep = 0; rep < o_.reps; ++rep) {
      std::vector<std::size_t> order;  // positions in r_.managers, rotated
      for (std::size_t i = 0; i < m; ++i) order.push_back((rep * step + i) % m);
      runOnce(order);
    }
    check();
    return r_;
  }

 private:
  void makeScene() {
    switch (p_.kind) {
      case Kind::update:
      case Kind::collision:
        generateEnvironment(env_, p_.scale, p_.env_size, p_.mesh);
        generateEnvironment(query_, p_.scale, p_.query_size, p_.mesh);
        break;
      case Kind::empty:
        generateEnvironment(query_, p_.scale, p_.query_size, p_.mesh);
        break;
      case Kind::self_distance:
        if (p_.mesh)
          generateSelfDistanceEnvironment<std::size_t>(env_, p_.scale, p_.env_size, true);
        else
          generateSelfDistanceEnvironment<unsigned int>(env_, p_.scale, p_.env_size, false);
        break;
      case Kind::distance:
        generateEnvironment(env_, p_.scale, p_.env_size, p_.mesh);
        distanceQueries();
        break;
    }
    for (const auto& o : env_) initial_.push_back(o->getTransform());
    if (p_.kind == Kind::update) drawMotion();
  }

  // As FCL's distance program: query objects drawn in batches, kept if they collide with none
  // of the environment (its Naive manager's answer; any manager's is the same).
  void distanceQueries() {
    auto envp = raw(env_);
    fcl::DynamicAABBTreeCollisionManager<S> judge;
    judge.registerObjects(envp);
    judge.setup();
    while (query_.size() < p_.query_size) {
      std::vector<ObjectPtr> candidates;
      generateEnvironment(candidates, p_.scale, p_.query_size, p_.mesh);
      for (auto& c : candidates) {
        fcl::DefaultCollisionData<S> d;
        judge.collide(c.get(), &d, fcl::DefaultCollisionFunction<S>);
        if (d.result.numContacts() == 0) query_.push_back(std::move(c));
        if (query_.size() == p_.query_size) break;
      }
    }
  }

  // FCL's update program's motion: per object three angles within +-10 degrees about X, Y, Z
  // and a translation within +-0.01 * scale, applied as (dR * R, dR * T + dT).
  void drawMotion() {
    const S max_angle = 10 / 360.0 * 2 * fcl::constants<S>::pi();
    const S max_trans = 0.01 * p_.scale;
    for (std::size_t i = 0; i < env_.size(); ++i) {
      S v[6];
      for (S& x : v) x = 2 * (std::rand() / static_cast<S>(RAND_MAX) - 0.5);
      const fcl::Matrix3<S> dr(fcl::AngleAxis<S>(v[0] * max_angle, fcl::Vector3<S>::UnitX()) *
                               fcl::AngleAxis<S>(v[2] * max_angle, fcl::Vector3<S>::UnitY()) *
                               fcl::AngleAxis<S>(v[4] * max_angle, fcl::Vector3<S>::UnitZ()));
      const fcl::Vector3<S> dt(v[1] * max_trans, v[3] * max_trans, v[5] * max_trans);
      const fcl::Transform3<S>& t = initial_[i];
      fcl::Transform3<S> moved = fcl::Transform3<S>::Identity();
      moved.linear() = dr * t.linear();
      moved.translation() = dr * t.translation() + dt;
      moved_.push_back(moved);
    }
  }

  void place(const std::vector<fcl::Transform3<S>>& tfs) {
    for (std::size_t i = 0; i < env_.size(); ++i) {
      env_[i]->setTransform(tfs[i]);
      env_[i]->computeAABB();
    }
  }

  Cell& cell(const std::string& name, bool is_distance = false) {
    for (auto& c : r_.cells)
      if (c.name == name) return c;
    Cell c;
    c.name = name;
    c.is_distance = is_distance;
    c.best_us.assign(r_.managers.size(), -1);
    c.answers.assign(r_.managers.size(), {});
    c.differ.assign(r_.managers.size(), 0);
    r_.cells.push_back(c);
    return r_.cells.back();
  }

  void keep(Cell& c, std::size_t at, double us) {
    if (c.best_us[at] < 0 || us < c.best_us[at]) c.best_us[at] = us;
  }

  std::size_t maxContacts() const { return p_.exhaustive ? 100000 : p_.max_contacts; }

  void runOnce(const std::vector<std::size_t>& order) {
    const std::size_t m = r_.managers.size();
    place(initial_);
    auto envp = raw(env_);
    std::vector<std::unique_ptr<Manager>> mgr(m);
    const S cells_per_axis = p_.kind == Kind::self_distance ? 5 : 20;
    cube::Config cube_config;
    cube_config.rebuild_budget = o_.rebuild_budget;
    for (std::size_t i = 0; i < m; ++i)
      mgr[i] = makeManager(r_.managers[i], envp, cells_per_axis, cube_config);

    Cell& build = cell("register + setup");
    for (std::size_t at : order) {
      const auto t0 = Clock::now();
      mgr[at]->registerObjects(envp);
      mgr[at]->setup();
      keep(build, at, since(t0));
    }

    if (p_.kind == Kind::update) {
      place(moved_);
      Cell& up = cell("update");
      for (std::size_t at : order) {
        const auto t0 = Clock::now();
        mgr[at]->update();
        keep(up, at, since(t0));
      }
    }

    if (p_.kind == Kind::update || p_.kind == Kind::collision) {
      Cell& self = cell("self collide");
      for (std::size_t at : order) {
        fcl::DefaultCollisionData<S> d;
        d.request.num_max_contacts = maxContacts();
        const auto t0 = Clock::now();
        mgr[at]->collide(&d, fcl::DefaultCollisionFunction<S>);
        keep(self, at, since(t0));
        self.answers[at] = {collideAnswer(d)};
      }
    }

    if (p_.kind == Kind::self_distance) {
      Cell& self = cell("self distance", true);
      for (std::size_t at : order) {
        fcl::DefaultDistanceData<S> d;
        const auto t0 = Clock::now();
        mgr[at]->distance(&d, fcl::DefaultDistanceFunction<S>);
        keep(self, at, since(t0));
        self.answers[at] = {Answer{false, 0, d.result.min_distance}};
      }
    }

    if (p_.kind == Kind::update || p_.kind == Kind::collision || p_.kind == Kind::empty)
      collideQueries(mgr, order);
    if (p_.kind == Kind::distance || p_.kind == Kind::empty) distanceQueries(mgr, order);
  }

  void collideQueries(std::vector<std::unique_ptr<Manager>>& mgr,
                      const std::vector<std::size_t>& order) {
    Cell& c = cell("collide queries");
    std::vector<double> sum(mgr.size(), 0);
    for (auto& a : c.answers) a.assign(query_.size(), {});
    if (p_.kind == Kind::empty) {
      // A query of an empty manager costs about as much as reading the clock: each manager's
      // queries are timed as one block.
      std::vector<fcl::DefaultCollisionData<S>> d(query_.size());
      for (std::size_t at : order) {
        for (auto& x : d) x = fcl::DefaultCollisionData<S>();
        for (auto& x : d) x.request.num_max_contacts = maxContacts();
        const auto t0 = Clock::now();
        for (std::size_t q = 0; q < query_.size(); ++q)
          mgr[at]->collide(query_[q].get(), &d[q], fcl::DefaultCollisionFunction<S>);
        keep(c, at, since(t0));
        for (std::size_t q = 0; q < query_.size(); ++q) c.answers[at][q] = collideAnswer(d[q]);
      }
      return;
    }
    for (std::size_t q = 0; q < query_.size(); ++q) {
      for (std::size_t at : order) {
        fcl::DefaultCollisionData<S> d;
        d.request.num_max_contacts = maxContacts();
        const auto t0 = Clock::now();
        mgr[at]->collide(query_[q].get(), &d, fcl::DefaultCollisionFunction<S>);
        sum[at] += since(t0);
        c.answers[at][q] = collideAnswer(d);
      }
    }
    for (std::size_t at = 0; at < mgr.size(); ++at) keep(c, at, sum[at]);
  }

  void distanceQueries(std::vector<std::unique_ptr<Manager>>& mgr,
                       const std::vector<std::size_t>& order) {
    Cell& c = cell("distance queries", true);
    std::vector<double> sum(mgr.size(), 0);
    for (auto& a : c.answers) a.assign(query_.size(), {});
    if (p_.kind == Kind::empty) {
      std::vector<fcl::DefaultDistanceData<S>> d(query_.size());
      for (std::size_t at : order) {
        for (auto& x : d) x = fcl::DefaultDistanceData<S>();
        const auto t0 = Clock::now();
        for (std::size_t q = 0; q < query_.size(); ++q)
          mgr[at]->distance(query_[q].get(), &d[q], fcl::DefaultDistanceFunction<S>);
        keep(c, at, since(t0));
        for (std::size_t q = 0; q < query_.size(); ++q)
          c.answers[at][q] = Answer{false, 0, d[q].result.min_distance};
      }
      return;
    }
    for (std::size_t q = 0; q < query_.size(); ++q) {
      for (std::size_t at : order) {
        fcl::DefaultDistanceData<S> d;
        const auto t0 = Clock::now();
        mgr[at]->distance(query_[q].get(), &d, fcl::DefaultDistanceFunction<S>);
        sum[at] += since(t0);
        c.answers[at][q] = Answer{false, 0, d.result.min_distance};
      }
    }
    for (std::size_t at = 0; at < mgr.size(); ++at) keep(c, at, sum[at]);
  }

  void check() {
    const std::size_t ref = static_cast<std::size_t>(
        std::find(r_.managers.begin(), r_.managers.end(), r_.reference) - r_.managers.begin());
    for (auto& c : r_.cells) {
      if (c.answers[ref].empty()) continue;
      for (std::size_t at = 0; at < r_.managers.size(); ++at) {
        for (std::size_t i = 0; i < c.answers[ref].size(); ++i) {
          const Answer& want = c.answers[ref][i];
          const Answer& got = c.answers[at][i];
          if (sameAnswer(want, got, c.is_distance, p_.exhaustive)) continue;
          ++c.differ[at];
          const bool cube = r_.managers[at] == kCube;
          if (cube) r_.cube_ok = false;
          if (c.differ[at] > 3) continue;  // the first few are enough to see
          std::ostringstream s;
          s << (cube ? "MISMATCH " : "note: ") << kManagers[r_.managers[at]] << " " << c.name
            << " item " << i << ": ";
          if (c.is_distance)
            s << got.distance << " vs " << kManagers[r_.reference] << " " << want.distance;
          else
            s << got.collision << "/" << got.contacts << " contacts vs " << kManagers[r_.reference]
              << " " << want.collision << "/" << want.contacts;
          r_.mismatches.push_back(s.str());
        }
      }
    }
  }

  Program p_;
  const Options& o_;
  std::vector<ObjectPtr> env_, query_;
  std::vector<fcl::Transform3<S>> initial_, moved_;
  Result r_;
};

// ---------------------------------------------------------------------------------------------
// Warm-up, output

// Every pair of shape and mesh through FCL's narrow phase, collide and distance, and each
// manager through one small program, untimed.
void warmUp() {
  std::vector<ObjectPtr> objs;
  for (int mesh = 0; mesh < 2; ++mesh)
    for (int kind = 0; kind < 3; ++kind)
      objs.push_back(std::make_unique<Object>(shape(kind, mesh != 0), randomTransform(10)));
  for (auto& a : objs)
    for (auto& b : objs) {
      fcl::CollisionRequest<S> creq;
      fcl::CollisionResult<S> cres;
      fcl::collide(a.get(), b.get(), creq, cres);
      fcl::DistanceRequest<S> dreq;
      fcl::DistanceResult<S> dres;
      fcl::distance(a.get(), b.get(), dreq, dres);
    }
  Options o;
  o.reps = 1;
  for (Kind k : {Kind::update, Kind::distance, Kind::self_distance, Kind::empty}) {
    Program p;
    p.kind = k;
    p.env_size = k == Kind::self_distance ? 64 : 5;
    p.query_size = 5;
    Runner(p, o).run(7);
  }
}

std::string requestName(const Program& p) {
  if (p.kind == Kind::distance || p.kind == Kind::self_distance) return "-";
  if (p.exhaustive) return "exhaustive";
  return std::to_string(p.max_contacts) + (p.max_contacts == 1 ? " contact" : " contacts");
}

std::string fmtUs(double us) {
  char b[32];
  if (us < 0) return "-";
  if (us >= 1e6)
    std::snprintf(b, sizeof b, "%.2f s", us / 1e6);
  else if (us >= 1e3)
    std::snprintf(b, sizeof b, "%.3g ms", us / 1e3);
  else
    std::snprintf(b, sizeof b, "%.3g us", us);
  return b;
}

// The best FCL manager of a cell leaves out Naive where it does no work (it keeps a list:
// nothing to build or refit) and SaP's self collide (a read of the pair list it keeps).
bool countsAsBest(int kind, const std::string& cell) {
  if (kind == kNaive) return cell != "register + setup" && cell != "update";
  if (kind == kSaP) return cell != "self collide";
  return true;
}

void printResult(const Result& r) {
  const Program& p = r.program;
  std::printf("\n%s scale %g, n %zu (%zu objects), %zu queries, %s, %s, reference %s%s\n",
              kindName(p.kind), p.scale, p.env_size, r.objects, r.queries,
              p.mesh ? "meshes" : "shapes", requestName(p).c_str(), kManagers[r.reference].c_str(),
              r.cube_ok ? "" : "  ** CUBE MISMATCH **");
  std::printf("  %-18s", "cell");
  for (int k : r.managers) std::printf(" %12.12s", kManagers[k].c_str());
  std::printf(" %16s\n", "best FCL / cube");
  for (const auto& c : r.cells) {
    std::printf("  %-18s", c.name.c_str());
    double best = -1, cube = -1;
    for (std::size_t at = 0; at < r.managers.size(); ++at) {
      const int k = r.managers[at];
      std::printf(" %12s", fmtUs(c.best_us[at]).c_str());
      if (k == kCube) {
        cube = c.best_us[at];
      } else if (countsAsBest(k, c.name) && c.best_us[at] >= 0 &&
                 (best < 0 || c.best_us[at] < best)) {
        best = c.best_us[at];
      }
    }
    if (best >= 0 && cube > 0)
      std::printf(" %15.2fx\n", best / cube);
    else
      std::printf(" %16s\n", "-");
  }
  for (const auto& m : r.mismatches) std::printf("  %s\n", m.c_str());
}

std::string jsonNumber(double x) {
  if (!std::isfinite(x)) return x > 0 ? "1e308" : (x < 0 ? "-1e308" : "null");
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", x);
  return b;
}

std::string jsonString(const std::string& s) {
  std::string r = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') r += '\\';
    r += ch;
  }
  return r + "\"";
}

void writeJson(const std::string& path, const std::vector<Result>& results, const Options& o,
               const std::string& loadavg) {
  std::ofstream f(path);
  f << "{\n  \"program\": \"cube_fcl_programs\",\n  \"command\": " << jsonString(o.command)
    << ",\n  \"loadavg\": " << jsonString(loadavg) << ",\n  \"reps\": " << o.reps
    << ",\n  \"quick\": " << (o.quick ? "true" : "false") << ",\n  \"time_unit\": \"us\""
    << ",\n  \"configs\": [";
  for (std::size_t ri = 0; ri < results.size(); ++ri) {
    const Result& r = results[ri];
    const Program& p = r.program;
    f << (ri ? "," : "") << "\n    {\"program\": \"" << kindName(p.kind)
      << "\", \"scale\": " << jsonNumber(p.scale) << ", \"env_size\": " << p.env_size
      << ", \"objects\": " << r.objects << ", \"queries\": " << r.queries
      << ", \"max_contacts\": " << p.max_contacts
      << ", \"exhaustive\": " << (p.exhaustive ? "true" : "false")
      << ", \"mesh\": " << (p.mesh ? "true" : "false") << ", \"reference\": \""
      << kManagers[r.reference] << "\", \"cube_ok\": " << (r.cube_ok ? "true" : "false")
      << ",\n     \"mismatches\": [";
    for (std::size_t i = 0; i < r.mismatches.size(); ++i)
      f << (i ? ", " : "") << jsonString(r.mismatches[i]);
    f << "],\n     \"cells\": [";
    for (std::size_t ci = 0; ci < r.cells.size(); ++ci) {
      const Cell& c = r.cells[ci];
      f << (ci ? "," : "") << "\n      {\"cell\": \"" << c.name << "\", \"times\": {";
      for (std::size_t at = 0; at < r.managers.size(); ++at)
        f << (at ? ", " : "") << "\"" << kManagers[r.managers[at]]
          << "\": " << jsonNumber(c.best_us[at]);
      f << "}";
      if (!c.answers.empty() && !c.answers[0].empty()) {
        f << ",\n       \"answers\": {";
        for (std::size_t at = 0; at < r.managers.size(); ++at) {
          const auto& a = c.answers[at];
          f << (at ? ", " : "") << "\"" << kManagers[r.managers[at]] << "\": {";
          if (c.is_distance) {
            S sum = 0, lo = std::numeric_limits<S>::max();
            for (const Answer& x : a) {
              sum += x.distance;
              lo = std::min(lo, x.distance);
            }
            f << "\"min_distance\": " << jsonNumber(lo)
              << ", \"distance_sum\": " << jsonNumber(sum);
          } else {
            std::size_t yes = 0, contacts = 0;
            for (const Answer& x : a) {
              yes += x.collision;
              contacts += x.contacts;
            }
            f << "\"colliding\": " << yes << ", \"contacts\": " << contacts;
          }
          f << ", \"differ\": " << c.differ[at] << "}";
        }
        f << "}";
      }
      f << "}";
    }
    f << "]}";
  }
  f << "\n  ]\n}\n";
}

std::vector<std::size_t> parseSizes(const char* s) {
  std::vector<std::size_t> r;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) r.push_back(static_cast<std::size_t>(std::stoul(item)));
  return r;
}

std::vector<std::string> parseList(const char* s) {
  std::vector<std::string> r;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) r.push_back(item);
  return r;
}

bool wanted(const Options& o, const char* program) {
  return std::find(o.programs.begin(), o.programs.end(), program) != o.programs.end();
}

// FCL's programs' Release cases, in their order.
std::vector<Program> programs(const Options& o) {
  std::vector<Program> r;
  struct Request {
    std::size_t contacts;
    bool exhaustive;
  };
  const Request requests[] = {{1, false}, {10, false}, {1, true}};
  for (Kind k : {Kind::update, Kind::collision}) {
    if (!wanted(o, kindName(k))) continue;
    for (int mesh = 0; mesh < 2; ++mesh)
      for (const Request& q : requests)
        for (std::size_t n : o.sizes) {
          Program p;
          p.kind = k;
          p.env_size = n;
          p.query_size = o.collide_queries;
          p.max_contacts = q.contacts;
          p.exhaustive = q.exhaustive;
          p.mesh = mesh != 0;
          r.push_back(p);
        }
  }
  if (wanted(o, "distance"))
    for (int mesh = 0; mesh < 2; ++mesh)
      for (S scale : {200.0, 2000.0})
        for (std::size_t n : o.sizes) {
          Program p;
          p.kind = Kind::distance;
          p.scale = scale;
          p.env_size = n;
          p.query_size = o.distance_queries;
          p.mesh = mesh != 0;
          r.push_back(p);
        }
  if (wanted(o, "self_distance"))
    for (int mesh = 0; mesh < 2; ++mesh)
      for (std::size_t n : o.self_sizes) {
        Program p;
        p.kind = Kind::self_distance;
        p.scale = 200;
        p.env_size = n;
        p.mesh = mesh != 0;
        r.push_back(p);
      }
  if (wanted(o, "empty"))
    for (int mesh = 0; mesh < 2; ++mesh)
      for (bool exhaustive : {false, true}) {
        Program p;
        p.kind = Kind::empty;
        p.query_size = o.empty_queries;
        p.max_contacts = 10;
        p.exhaustive = exhaustive;
        p.mesh = mesh != 0;
        r.push_back(p);
      }
  return r;
}

int usage() {
  std::fprintf(stderr,
               "usage: cube_fcl_programs [--reps N] [--json FILE] [--sizes 100,1000] "
               "[--self-sizes 512,1000,5000] [--programs update,collision,distance,"
               "self_distance,empty] [--naive-max OBJECTS] [--rebuild-budget B] [--quick]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  bool sizes_given = false, self_given = false, reps_given = false;
  for (int i = 0; i < argc; ++i) o.command += (i ? " " : "") + std::string(argv[i]);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool more = i + 1 < argc;
    if (a == "--reps" && more) {
      o.reps = std::max(1, std::atoi(argv[++i]));
      reps_given = true;
    } else if (a == "--json" && more) {
      o.json = argv[++i];
    } else if (a == "--sizes" && more) {
      o.sizes = parseSizes(argv[++i]);
      sizes_given = true;
    } else if (a == "--self-sizes" && more) {
      o.self_sizes = parseSizes(argv[++i]);
      self_given = true;
    } else if (a == "--programs" && more) {
      o.programs = parseList(argv[++i]);
    } else if (a == "--naive-max" && more) {
      o.naive_max = static_cast<std::size_t>(std::stoul(argv[++i]));
    } else if (a == "--rebuild-budget" && more) {
      o.rebuild_budget = std::stod(argv[++i]);
    } else if (a == "--quick") {
      o.quick = true;
    } else {
      return usage();
    }
  }
  if (o.quick) {
    // FCL's Debug sizes, about: every program and cell, a few seconds in all.
    if (!sizes_given) o.sizes = {10};
    if (!self_given) o.self_sizes = {256};
    if (!reps_given) o.reps = 1;
    o.collide_queries = 100;
    o.distance_queries = 10;
    o.empty_queries = 100;
  }

  std::string loadavg;
  {
    std::ifstream f("/proc/loadavg");
    std::getline(f, loadavg);
  }
  std::printf("cube_fcl_programs: %d repetitions (minimum kept), load average at start: %s\n",
              o.reps, loadavg.c_str());
  warmUp();

  std::vector<Result> results;
  bool ok = true;
  for (const Program& p : programs(o)) {
    // One scene per program, scale, size and shapes: its three requests see the same objects.
    const unsigned seed = 1 + static_cast<unsigned>(p.kind) * 7919u +
                          static_cast<unsigned>(p.scale) * 131u +
                          static_cast<unsigned>(p.env_size) * 3u + (p.mesh ? 1u : 0u);
    results.push_back(Runner(p, o).run(seed));
    printResult(results.back());
    std::fflush(stdout);
    ok = ok && results.back().cube_ok;
  }
  if (!o.json.empty()) writeJson(o.json, results, o, loadavg);
  if (!ok) std::printf("\nThe cube manager's answers differ from the reference's (see above).\n");
  return ok ? 0 : 1;
}
