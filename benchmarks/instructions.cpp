// cube_instructions: fixed workloads of the cube manager for instruction counts under callgrind
// (benchmarks/instructions.sh runs it). Timing on this shared machine moves 10-20% between runs;
// instruction counts do not, so a refactor is judged by them. Each run does one case: the scene
// is built with instrumentation off, then the case's calls run with callgrind's instrumentation
// on (CALLGRIND_START/STOP_INSTRUMENTATION), and the binary prints how many calls it made and a
// checksum of the answers (pairs found, contacts, colliding states), so that two builds are
// compared on the same work.
//
// Usage: cube_instructions <case> <objects>
// cases: self (broadphase self-collide, counting callback), queries (100 object queries,
// counting callback), robot (a 30-object robot manager against the world, 16 poses), update (1%
// of the objects moved, update(), 10 steps), distance (10 object distances, FCL's narrow phase),
// contacts (collideAll self-collide, FCL's narrow phase), states (checkStates of 50 states of a
// 30-link robot, one thread), edges (checkMotions of 20 collision-free edges of 32 states of that
// robot, one thread), single (the states of states, one call each), singlekept (the same with one
// BatchScratch kept for every call), edgeeach / edgekept (the edges of edges, one checkMotion
// over a pose function each, without / with a kept BatchScratch), se3edges / boundedges (the edges
// of edges checked continuously: SE(3) bounds from the poses / the caller's bounds), first (the
// first pipeline query of a manager: collideAll with FCL's default request, which builds the
// per-object volumes), build (a new manager: registerObjects and setup(), 3 times), turn (every
// object turned about the origin as FCL's update program turns them, then update(), which
// rebuilds; 3 motions), still (update() with nothing moved, then a self-collide, counting
// callback, 10 steps), keep (the same with Config::keep_pairs and 1% of the objects moved before
// each step, the motion not counted), keepstill (keep_pairs, nothing moved). distance, contacts and
// states count steady queries: one pipeline query runs before the count, as it would have in a
// program that queries the world repeatedly. The paths that cull pairs of no object table, from the
// FCL objects: merged (collideMerged of the world's candidate pairs, every contact, one thread),
// pairs (collidePairs of them, FCL's default request, one thread), callback (the world's
// self-collide with cube::defaultCollisionCallback, every contact), margins (contactsWithinMargin
// of a self-collide with a margin on every object, one thread), fcltree (collideAll on FCL's
// dynamic AABB tree of the scene, every contact, one thread). cullpairs: a self-collide of a small
// manager (170 objects) with Config::cull_pairs and a callback running fcl::collide, after a first
// one that builds its records. armstates / armedges: the OMPL example's validity and motion
// checks of its 7-joint arm in its world (examples/ompl_planner.cpp; the objects argument is
// its world's size before the arm's base is cleared, 2000 there), without OMPL.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else  // without valgrind's headers the workloads still run (and count nothing)
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "arm.h"
#include "cube_collision/batch.h"
#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/margins.h"
#include "cube_collision/narrow_phase.h"
#include "cube_collision/queries.h"
#include "scenes.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
namespace scenes = cube::scenes;

bool countPair(Object*, Object*, void* data) {
  ++*static_cast<std::size_t*>(data);
  return false;
}

// A user's own narrow phase behind Config::cull_pairs: counts the pairs fcl::collide finds in
// contact, which no cull may change (a count of the calls would change with the cull).
bool collidingPair(Object* a, Object* b, void* data) {
  fcl::CollisionResult<S> result;
  *static_cast<std::size_t*>(data) += fcl::collide(a, b, fcl::CollisionRequest<S>(), result) > 0;
  return false;
}

struct Run {
  std::size_t calls = 0;
  std::size_t checksum = 0;
};

std::vector<std::unique_ptr<Object>> queryObjects(const scenes::SceneOptions& o, std::size_t n,
                                                  std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> p(-o.half_extent, o.half_extent);
  std::vector<std::unique_ptr<Object>> out;
  for (std::size_t i = 0; i < n; ++i) {
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.translation() = fcl::Vector3d(p(rng), p(rng), p(rng));
    out.push_back(
        std::make_unique<Object>(std::make_shared<fcl::Sphered>(0.5 * scenes::typicalSize(o)), tf));
    out.back()->computeAABB();
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: cube_instructions <case> <objects>\n");
    return 2;
  }
  const std::string which = argv[1];
  scenes::SceneOptions o;
  o.n = std::strtoul(argv[2], nullptr, 10);
  o.seed = 5;
  o.meshes = which == "long";  // long: a world of meshes
  const bool arm = which == "armstates" || which == "armedges";
  if (arm) {  // the OMPL example's world around its arm (examples/ompl_planner.cpp)
    o.half_extent = 8;
    o.seed = 11;
  }
  scenes::Scene<S> scene = scenes::makeScene<S>(o);
  std::vector<Object*> objects = scene.pointers();
  if (arm)  // nothing within the base's reach, as in the example
    objects.erase(std::remove_if(objects.begin(), objects.end(),
                                 [](const Object* x) { return x->getTranslation().norm() < 1.2; }),
                  objects.end());
  cube::CubeCollisionManager<S> world;
  world.registerObjects(objects);
  world.setup();
  Run run;
  if (which == "distance" || which == "contacts" || which == "states" || which == "edges" ||
      which == "single" || which == "long" || which == "singlekept" || which == "edgeeach" ||
      which == "edgekept" || which == "se3edges" || which == "boundedges" || arm)
    cube::collideAll<S>(world);  // the volumes the first pipeline query builds ("first")

  if (which == "self") {
    CALLGRIND_START_INSTRUMENTATION;
    world.collide(&run.checksum, countPair);
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 1;
  } else if (which == "queries") {
    const auto qs = queryObjects(o, 100, 7);
    CALLGRIND_START_INSTRUMENTATION;
    for (const auto& q : qs) world.collide(q.get(), &run.checksum, countPair);
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = qs.size();
  } else if (which == "robot") {
    scenes::SceneOptions r = o;
    r.n = 30;
    r.half_extent = o.half_extent / 10;
    r.seed = 9;
    scenes::Scene<S> robot_scene = scenes::makeScene<S>(r);
    cube::CubeCollisionManager<S> robot;
    robot.registerObjects(robot_scene.pointers());
    robot.setup();
    std::vector<fcl::Vector3d> home;
    for (const auto& l : robot_scene.objects) home.push_back(l->getTranslation());
    CALLGRIND_START_INSTRUMENTATION;
    for (int k = 0; k < 16; ++k) {
      const double x = o.half_extent * (-0.8 + 1.6 * k / 15.0);
      for (std::size_t i = 0; i < robot_scene.objects.size(); ++i) {
        robot_scene.objects[i]->setTranslation(home[i] + fcl::Vector3d(x, 0, 0));
        robot_scene.objects[i]->computeAABB();
      }
      robot.update();
      fcl::DefaultCollisionData<S> d;
      world.collide(&robot, &d, fcl::DefaultCollisionFunction<S>);
      run.checksum += d.result.isCollision();
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 16;
  } else if (which == "update") {
    CALLGRIND_START_INSTRUMENTATION;
    for (int step = 0; step < 10; ++step) {
      scenes::jitter(scene, 0.01, 0.1 * scenes::typicalSize(o), true, 100 + step);
      world.update();
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    world.collide(&run.checksum, countPair);
    run.calls = 10;
  } else if (which == "build") {
    // A drop-in user's build: a new manager, registerObjects, setup(); three times.
    CALLGRIND_START_INSTRUMENTATION;
    for (int k = 0; k < 3; ++k) {
      cube::CubeCollisionManager<S> fresh;
      fresh.registerObjects(scene.pointers());
      fresh.setup();
      run.checksum += fresh.size();
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 3;
  } else if (which == "turn") {
    // FCL's update program's motion (test_fcl_broadphase_collision_1.cpp): every object turned
    // about the origin by up to 10 degrees about each axis and moved by up to 1% of the scene,
    // then update(), which finds the cubes far past the rebuild threshold and rebuilds; three
    // motions from the scene's poses, the motion not counted.
    std::vector<fcl::Transform3d> home;
    for (const auto& obj : scene.objects) home.push_back(obj->getTransform());
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double max_angle = 10.0 / 180.0 * 3.14159265358979323846;
    for (int step = 0; step < 3; ++step) {
      for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const fcl::Matrix3d dr(fcl::AngleAxisd(u(rng) * max_angle, fcl::Vector3d::UnitX()) *
                               fcl::AngleAxisd(u(rng) * max_angle, fcl::Vector3d::UnitY()) *
                               fcl::AngleAxisd(u(rng) * max_angle, fcl::Vector3d::UnitZ()));
        const fcl::Vector3d dt = 0.01 * o.half_extent * fcl::Vector3d(u(rng), u(rng), u(rng));
        fcl::Transform3d moved = fcl::Transform3d::Identity();
        moved.linear() = dr * home[i].linear();
        moved.translation() = dr * home[i].translation() + dt;
        scene.objects[i]->setTransform(moved);
        scene.objects[i]->computeAABB();
      }
      CALLGRIND_START_INSTRUMENTATION;
      world.update();
      CALLGRIND_STOP_INSTRUMENTATION;
      world.collide(&run.checksum, countPair);
    }
    run.calls = 3;
  } else if (which == "still" || which == "keep" || which == "keepstill") {
    // A motion loop's steps as a user of FCL's interface runs them: update(), then a
    // self-collide with the user's callback, 10 steps; 1% of the objects moved before each
    // step ("keep", outside the count) or none ("still", "keepstill"); "keep" and "keepstill"
    // with Config::keep_pairs, listed once before the count.
    cube::Config config;
    config.keep_pairs = which != "still";
    cube::CubeCollisionManager<S> loop(config);
    loop.registerObjects(scene.pointers());
    loop.setup();
    loop.update();
    for (int step = 0; step < 10; ++step) {
      if (which == "keep")
        scenes::jitter(scene, 0.01, 0.1 * scenes::typicalSize(o), true, 100 + step);
      CALLGRIND_START_INSTRUMENTATION;
      loop.update();
      loop.collide(&run.checksum, countPair);
      CALLGRIND_STOP_INSTRUMENTATION;
    }
    run.calls = 10;
  } else if (which == "distance") {
    const auto qs = queryObjects(o, 10, 11);
    CALLGRIND_START_INSTRUMENTATION;
    for (const auto& q : qs) {
      const auto r = cube::minimumDistance<S>(world, q.get(), fcl::DistanceRequest<S>());
      run.checksum += std::size_t(r.min_distance > 0);
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = qs.size();
  } else if (which == "first") {
    CALLGRIND_START_INSTRUMENTATION;
    run.checksum = cube::collideAll<S>(world).numContacts();
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 1;
  } else if (which == "contacts") {
    fcl::CollisionRequest<S> all;
    all.num_max_contacts = 1000000;
    cube::NarrowPhaseOptions<S> one;
    one.threads = 1;
    CALLGRIND_START_INSTRUMENTATION;
    run.checksum = cube::collideAll<S>(world, all, one).numContacts();
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 1;
  } else if (which == "states" || which == "edges" || which == "single" || which == "long" ||
             which == "singlekept" || which == "edgeeach" || which == "edgekept" ||
             which == "se3edges" || which == "boundedges") {
    // states: 50 random states; edges: 20 edges of 32 states each, joints interpolated between
    // a random state and one near it (a planner's edges), checked in path order; long: 50
    // random states of links 8 typical sizes long among meshes (most states meet several).
    // se3edges, boundedges: the edges checked continuously, with the SE(3) bounds from the poses
    // and with the caller's bounds (each link a fiftieth of its length a step).
    cube::BodySet<S> body;
    const double len = scenes::typicalSize(o) * (which == "long" ? 8 : 1);
    for (int i = 0; i < 30; ++i)
      body.addLink(i % 2 ? std::shared_ptr<fcl::CollisionGeometryd>(
                               std::make_shared<fcl::Capsuled>(0.15 * len, 0.7 * len))
                         : std::make_shared<fcl::Boxd>(0.3 * len, 0.3 * len, len));
    std::mt19937 rng(13);
    std::uniform_real_distribution<double> p(-0.9 * o.half_extent, 0.9 * o.half_extent),
        a(-0.6, 0.6), step(-0.05, 0.05);
    std::vector<fcl::Transform3d> poses;
    const auto chain = [&](const fcl::Vector3d& base, const double* q) {
      fcl::Transform3d t = fcl::Transform3d::Identity();
      t.translation() = base;
      for (int i = 0; i < 30; ++i) {
        t = t * fcl::AngleAxisd(q[i], i % 2 ? fcl::Vector3d::UnitX() : fcl::Vector3d::UnitY());
        fcl::Transform3d mid = t;
        mid.translate(fcl::Vector3d(0, 0, len / 2));
        poses.push_back(mid);
        t.translate(fcl::Vector3d(0, 0, len));
      }
    };
    const bool edges = which == "edges" || which == "edgeeach" || which == "edgekept" ||
                       which == "se3edges" || which == "boundedges";
    const int count = edges ? 20 : 50, per_edge = edges ? 32 : 1;
    std::vector<std::size_t> starts;
    cube::BatchOptions probe;
    probe.threads = 1;
    for (int k = 0, tries = 0; k < count; ++tries) {
      const std::size_t at = poses.size();
      const fcl::Vector3d base(p(rng), p(rng), p(rng));
      double q0[30], q1[30], q[30];
      for (int i = 0; i < 30; ++i) q0[i] = a(rng);
      fcl::Vector3d move = fcl::Vector3d::Zero();
      for (int i = 0; i < 30; ++i) q1[i] = q0[i] + (edges ? step(rng) : 0.0);
      if (edges) move = 10 * len * fcl::Vector3d(step(rng), step(rng), step(rng));
      for (int s = 0; s < per_edge; ++s) {
        const double f = per_edge > 1 ? double(s) / (per_edge - 1) : 0.0;
        for (int i = 0; i < 30; ++i) q[i] = q0[i] + f * (q1[i] - q0[i]);
        chain(base + f * move, q);
      }
      if (edges && tries < 100000) {
        // A planner's free edge: every state free (found outside the counted part).
        const std::vector<fcl::Transform3d> mine(poses.begin() + long(at), poses.end());
        bool free = true;
        for (const auto& r : cube::checkStates(world, body, mine, probe))
          free = free && !r.colliding;
        if (!free) {
          poses.resize(at);
          continue;
        }
      }
      starts.push_back(at / 30);
      ++k;
    }
    cube::BatchOptions one;
    one.threads = 1;
    cube::BatchScratch kept;
    if (which == "singlekept" || which == "edgekept") one.scratch = &kept;
    one.continuous = which == "se3edges";
    const std::vector<S> bounds(which == "boundedges" ? poses.size() : 0, len / 50);
    CALLGRIND_START_INSTRUMENTATION;
    if (which == "edgeeach" || which == "edgekept") {  // each edge a call of its own
      for (std::size_t e = 0; e < starts.size(); ++e) {
        const std::size_t from = starts[e] * 30;
        const std::size_t to = e + 1 < starts.size() ? starts[e + 1] * 30 : poses.size();
        const std::size_t n = (to - from) / 30;
        const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
          std::copy(poses.begin() + long(from + 30 * k), poses.begin() + long(from + 30 * k + 30),
                    out);
        };
        const std::size_t f =
            cube::checkMotion(world, body, n, pose_of, cube::MotionOrder::path, one);
        run.checksum += f == cube::kNoIndex ? 0 : f + 1;
      }
    } else if (which == "boundedges") {
      for (const std::size_t f :
           cube::checkMotions(world, body, poses, starts, bounds, cube::MotionOrder::path, one))
        run.checksum += f == cube::kNoIndex ? 0 : f + 1;
    } else if (edges) {
      for (const std::size_t f :
           cube::checkMotions(world, body, poses, starts, cube::MotionOrder::path, one))
        run.checksum += f == cube::kNoIndex ? 0 : f + 1;
    } else if (which == "single" || which == "singlekept") {  // each state a call of its own
      for (std::size_t k = 0; k < poses.size(); k += 30) {
        const std::vector<fcl::Transform3d> state(poses.begin() + long(k),
                                                  poses.begin() + long(k) + 30);
        run.checksum += cube::checkStates(world, body, state, one)[0].colliding;
      }
    } else {
      for (const auto& r : cube::checkStates(world, body, poses, one)) run.checksum += r.colliding;
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = std::size_t(count) * std::size_t(per_edge);
  } else if (arm) {
    // The OMPL example's checks without OMPL: armstates, 2,000 states drawn as RRTConnect draws
    // its samples (uniform over the joints' range), one checkStates call each, as the example's
    // validity checker makes them; armedges, 500 edges from such a state toward another, cut to
    // RRTConnect's range (a fifth of the joint space's extent), each one checkMotion over a pose
    // function in bisection order at OMPL's resolution (1% of the extent), as its motion
    // validator. Self-collision on, one thread, one BatchScratch kept; the kinematics counted,
    // as the example times it inside its checks.
    constexpr int J = scenes::kArmJoints;
    cube::BodySet<S> body;
    for (const auto& g : scenes::armGeometry()) body.addLink(g);
    for (int i = 0; i + 1 < J; ++i) body.excludePair(i, i + 1);
    cube::BatchScratch kept;
    cube::BatchOptions one;
    one.threads = 1;
    one.self_collision = true;
    one.scratch = &kept;
    const double extent = std::sqrt(double(J)) * 2 * M_PI;
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> angle(-M_PI, M_PI);
    const int count = which == "armstates" ? 2000 : 500;
    std::vector<double> from(std::size_t(count) * J), to(std::size_t(count) * J);
    std::vector<int> segments(static_cast<std::size_t>(count));
    for (int e = 0; e < count; ++e) {
      double* a = &from[std::size_t(e) * J];
      double* b = &to[std::size_t(e) * J];
      double d2 = 0;
      for (int i = 0; i < J; ++i) {
        a[i] = angle(rng);
        b[i] = angle(rng);
        d2 += (b[i] - a[i]) * (b[i] - a[i]);
      }
      const double d = std::sqrt(d2), range = 0.2 * extent;
      if (d > range)
        for (int i = 0; i < J; ++i) b[i] = a[i] + (b[i] - a[i]) * (range / d);
      segments[std::size_t(e)] = std::max(1, int(std::ceil(std::min(d, range) / (0.01 * extent))));
    }
    std::vector<fcl::Transform3d> poses(J);
    CALLGRIND_START_INSTRUMENTATION;
    for (int e = 0; e < count; ++e) {
      const double* a = &from[std::size_t(e) * J];
      const double* b = &to[std::size_t(e) * J];
      if (which == "armstates") {
        scenes::armPoses(a, poses.data());
        run.checksum += cube::checkStates(world, body, poses, one)[0].colliding;
        continue;
      }
      const int nd = segments[std::size_t(e)];
      const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
        const double t = double(k + 1) / nd;
        double q[J];
        for (int i = 0; i < J; ++i) q[i] = a[i] + (b[i] - a[i]) * t;
        scenes::armPoses(q, out);
      };
      const std::size_t f = cube::checkMotion(world, body, std::size_t(nd), pose_of,
                                              cube::MotionOrder::bisection, one);
      run.checksum += f == cube::kNoIndex ? 0 : f + 1;
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = std::size_t(count);
  } else if (which == "merged" || which == "pairs") {
    const std::vector<cube::ObjectPair<S>> pairs = cube::overlappingPairs<S>(world);
    cube::NarrowPhaseOptions<S> one;
    one.threads = 1;
    if (which == "merged") {
      fcl::CollisionRequest<S> all;
      all.num_max_contacts = 1000000;
      CALLGRIND_START_INSTRUMENTATION;
      run.checksum = cube::collideMerged<S>(pairs, all, one).numContacts();
      CALLGRIND_STOP_INSTRUMENTATION;
    } else {
      CALLGRIND_START_INSTRUMENTATION;
      const auto results = cube::collidePairs<S>(pairs, fcl::CollisionRequest<S>(), one);
      CALLGRIND_STOP_INSTRUMENTATION;
      for (const auto& r : results) run.checksum += r.numContacts();
    }
    run.calls = 1;
  } else if (which == "callback") {
    cube::CollisionData<S> d;
    d.request.num_max_contacts = 1000000;
    CALLGRIND_START_INSTRUMENTATION;
    world.collide(&d, cube::defaultCollisionCallback<S>);
    CALLGRIND_STOP_INSTRUMENTATION;
    run.checksum = d.result.numContacts();
    run.calls = 1;
  } else if (which == "margins") {
    world.setMargin(0.05 * scenes::typicalSize(o));
    CALLGRIND_START_INSTRUMENTATION;
    const auto near = cube::contactsWithinMargin<S>(world, fcl::DistanceRequest<S>(true), 1);
    CALLGRIND_STOP_INSTRUMENTATION;
    for (const auto& c : near) run.checksum += c.colliding ? 1000 : 1;
    run.calls = 1;
  } else if (which == "fcltree") {
    fcl::DynamicAABBTreeCollisionManager<S> tree;
    tree.registerObjects(scene.pointers());
    tree.setup();
    fcl::CollisionRequest<S> all;
    all.num_max_contacts = 1000000;
    cube::NarrowPhaseOptions<S> one;
    one.threads = 1;
    CALLGRIND_START_INSTRUMENTATION;
    run.checksum = cube::collideAll<S>(tree, all, one).numContacts();
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 1;
  } else if (which == "cullpairs") {
    cube::Config config;
    config.cull_pairs = true;
    cube::CubeCollisionManager<S> culled(config);
    culled.registerObjects(scene.pointers());
    culled.setup();
    std::size_t first = 0;
    culled.collide(&first, collidingPair);
    CALLGRIND_START_INSTRUMENTATION;
    culled.collide(&run.checksum, collidingPair);
    CALLGRIND_STOP_INSTRUMENTATION;
    run.calls = 1;
  } else {
    std::fprintf(stderr, "cube_instructions: unknown case %s\n", which.c_str());
    return 2;
  }
  std::printf("calls %zu checksum %zu\n", run.calls, run.checksum);
  return 0;
}
