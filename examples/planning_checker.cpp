// Migration example, the motion-planning case: the collision checker of a sampling planner.
// A 10-link arm (boxes and capsules) moves along a trajectory through a static world (small
// obstacles plus a floor). For every configuration the checker updates the arm's link poses,
// then asks two questions: does the arm touch the world (manager against manager)? does it touch
// itself (links that share a joint excluded by the callback)? It runs with
// cube::CubeCollisionManagerd and with fcl::DynamicAABBTreeCollisionManagerd, reports checks per
// second and whether both flagged the same configurations. Then an fcl::OcTree obstacle (an
// octomap point cloud wall) is queried against the arm and the world, compared with
// fcl::NaiveCollisionManager.
//
// Usage: planning_checker [world objects] [configurations]   (default 5000 3000)

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <octomap/OcTree.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <set>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace {

using Object = fcl::CollisionObjectd;
using Manager = fcl::BroadPhaseCollisionManagerd;
constexpr int kLinks = 10;

// ---- The arm ----------------------------------------------------------------------------------

struct Arm {
  std::array<double, kLinks> length{};
  std::array<fcl::Vector3d, kLinks> axis;
  std::array<int, kLinks> id{};  // user data of each link: its index
  std::vector<std::unique_ptr<Object>> links;

  Arm() {
    for (int i = 0; i < kLinks; ++i) {
      length[i] = i == 0 ? 0.4 : 0.32;
      // Yaw at the base, then alternating pitch and roll joints.
      axis[i] = i == 0 ? fcl::Vector3d::UnitZ()
                       : (i % 2 ? fcl::Vector3d::UnitY() : fcl::Vector3d::UnitX());
      id[i] = i;
      std::shared_ptr<fcl::CollisionGeometryd> g;
      if (i % 2 == 0)
        g = std::make_shared<fcl::Boxd>(0.12, 0.12, length[i]);
      else
        g = std::make_shared<fcl::Capsuled>(0.05, length[i] - 0.1);
      links.push_back(std::make_unique<Object>(g));
      links.back()->setUserData(&id[i]);
    }
  }

  // Forward kinematics: link i spans its joint frame's z axis from 0 to length[i]; the base
  // stands on a pedestal 0.3 above the floor.
  void setConfiguration(const std::array<double, kLinks>& q) {
    fcl::Transform3d joint = fcl::Transform3d::Identity();
    joint.translation() = fcl::Vector3d(0, 0, 0.3);
    for (int i = 0; i < kLinks; ++i) {
      joint.rotate(fcl::AngleAxisd(q[i], axis[i]));
      fcl::Transform3d centre = joint;
      centre.translate(fcl::Vector3d(0, 0, length[i] / 2));
      links[i]->setTransform(centre);
      links[i]->computeAABB();
      joint.translate(fcl::Vector3d(0, 0, length[i]));
    }
  }

  std::vector<Object*> pointers() const {
    std::vector<Object*> out;
    for (const auto& l : links) out.push_back(l.get());
    return out;
  }
};

std::array<double, kLinks> configurationAt(int step) {
  // A smooth trajectory sweeping the arm through its workspace.
  std::array<double, kLinks> q{};
  const double t = step * 0.01;
  for (int i = 0; i < kLinks; ++i) q[i] = (i == 0 ? 3.0 : 1.1) * std::sin((0.7 + 0.23 * i) * t + i);
  return q;
}

// ---- The world --------------------------------------------------------------------------------

struct World {
  std::vector<std::unique_ptr<Object>> objects;  // floor first

  World(int n, unsigned seed) {
    auto floor = std::make_unique<Object>(std::make_shared<fcl::Boxd>(20, 20, 0.1));
    floor->setTranslation(fcl::Vector3d(0, 0, -0.05));
    objects.push_back(std::move(floor));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> xy(-5, 5), z(0.05, 4), size(0.04, 0.2),
        angle(-M_PI, M_PI);
    while (static_cast<int>(objects.size()) < n + 1) {
      const fcl::Vector3d p(xy(rng), xy(rng), z(rng));
      // Leave the space right around the pedestal free, so that some configurations are too.
      if ((p - fcl::Vector3d(0, 0, 0.3)).norm() < 1.2) continue;
      std::shared_ptr<fcl::CollisionGeometryd> g;
      switch (objects.size() % 3) {
        case 0:
          g = std::make_shared<fcl::Boxd>(size(rng), size(rng), size(rng));
          break;
        case 1:
          g = std::make_shared<fcl::Sphered>(size(rng) / 2);
          break;
        default:
          g = std::make_shared<fcl::Cylinderd>(size(rng) / 2, size(rng));
          break;
      }
      fcl::Transform3d tf = fcl::Transform3d::Identity();
      tf.translation() = p;
      tf.rotate(fcl::AngleAxisd(angle(rng), fcl::Vector3d(1, 1, 0).normalized()));
      objects.push_back(std::make_unique<Object>(g, tf));
    }
    for (auto& o : objects) o->computeAABB();
  }

  std::vector<Object*> pointers() const {
    std::vector<Object*> out;
    for (const auto& o : objects) out.push_back(o.get());
    return out;
  }
};

// ---- Callbacks --------------------------------------------------------------------------------

int linkIndex(Object* o) {
  return *static_cast<const int*>(o->getUserData());
}

bool touches(Object* a, Object* b) {
  fcl::CollisionRequestd request;  // one contact: a yes/no answer is all a planner needs
  fcl::CollisionResultd result;
  return fcl::collide(a, b, request, result) > 0;
}

// Robot against world: stop at the first contact.
bool worldCallback(Object* a, Object* b, void* hit) {
  if (!touches(a, b)) return false;
  *static_cast<bool*>(hit) = true;
  return true;
}

// Robot against itself: links sharing a joint overlap by construction, skip them.
bool selfCallback(Object* a, Object* b, void* hit) {
  if (std::abs(linkIndex(a) - linkIndex(b)) <= 1) return false;
  return worldCallback(a, b, hit);
}

// Every managed object touching the query object. The argument order is not relied on:
// fcl::NaiveCollisionManager calls callback(query, managed), its tree managers and ours
// callback(managed, query).
struct Touching {
  Object* query;
  std::set<Object*> found;
};

bool recordCallback(Object* a, Object* b, void* data) {
  auto& t = *static_cast<Touching*>(data);
  if (touches(a, b)) t.found.insert(a == t.query ? b : a);
  return false;
}

struct Outcome {
  std::vector<int> world_hits, self_hits;  // colliding configurations
  double seconds = 0;
};

// The planner's inner loop, identical for both manager types.
Outcome check(Manager& world, Manager& robot, Arm& arm, int configurations) {
  Outcome out;
  const auto start = std::chrono::steady_clock::now();
  for (int c = 0; c < configurations; ++c) {
    arm.setConfiguration(configurationAt(c));
    robot.update();
    bool world_hit = false, self_hit = false;
    world.collide(&robot, &world_hit, &worldCallback);
    robot.collide(&self_hit, &selfCallback);
    if (world_hit) out.world_hits.push_back(c);
    if (self_hit) out.self_hits.push_back(c);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

std::unique_ptr<Object> makeOctreeWall() {
  // A point-cloud wall beside the arm, as a depth sensor would report it.
  auto tree = std::make_shared<octomap::OcTree>(0.05);
  for (double y = -1.0; y <= 1.0; y += 0.05)
    for (double z = 0.0; z <= 2.0; z += 0.05)
      tree->updateNode(octomap::point3d(1.4f, float(y), float(z)), true);
  auto obj = std::make_unique<Object>(std::make_shared<fcl::OcTreed>(tree));
  obj->computeAABB();
  return obj;
}

}  // namespace

int main(int argc, char** argv) {
  const int n_world = argc > 1 ? std::atoi(argv[1]) : 5000;
  const int configurations = argc > 2 ? std::atoi(argv[2]) : 3000;
  if (n_world < 0 || configurations < 1) {
    std::fprintf(stderr, "usage: %s [world objects] [configurations]\n", argv[0]);
    return 2;
  }
  World world(n_world, 7);
  Arm arm;
  arm.setConfiguration(configurationAt(0));

  cube::CubeCollisionManagerd cube_world, cube_robot;
  fcl::DynamicAABBTreeCollisionManagerd fcl_world, fcl_robot;
  for (Manager* m : {static_cast<Manager*>(&cube_world), static_cast<Manager*>(&fcl_world)}) {
    m->registerObjects(world.pointers());
    m->setup();
  }
  for (Manager* m : {static_cast<Manager*>(&cube_robot), static_cast<Manager*>(&fcl_robot)}) {
    m->registerObjects(arm.pointers());
    m->setup();
  }

  const Outcome fcl_out = check(fcl_world, fcl_robot, arm, configurations);
  const Outcome cube_out = check(cube_world, cube_robot, arm, configurations);

  std::printf("planning checker: %d-link arm, %d world objects + floor, %d configurations\n\n",
              kLinks, n_world, configurations);
  std::printf("%-16s %14s %18s %18s\n", "manager", "checks/s", "world collisions",
              "self collisions");
  std::printf("%-16s %14.0f %18zu %18zu\n", "fcl DynamicAABB", configurations / fcl_out.seconds,
              fcl_out.world_hits.size(), fcl_out.self_hits.size());
  std::printf("%-16s %14.0f %18zu %18zu\n", "cube", configurations / cube_out.seconds,
              cube_out.world_hits.size(), cube_out.self_hits.size());
  const bool same_configs =
      fcl_out.world_hits == cube_out.world_hits && fcl_out.self_hits == cube_out.self_hits;
  std::printf("same colliding configurations: %s\n\n", same_configs ? "yes" : "NO");

  // The OcTree obstacle, queried against the arm along the trajectory and against the world,
  // with the cube manager and with the naive (all pairs) manager.
  auto wall = makeOctreeWall();
  fcl::NaiveCollisionManagerd naive_world, naive_robot;
  naive_world.registerObjects(world.pointers());
  naive_robot.registerObjects(arm.pointers());
  bool same_octree = true;
  std::size_t arm_octree_hits = 0;
  for (int c = 0; c < configurations; c += 10) {
    arm.setConfiguration(configurationAt(c));
    cube_robot.update();
    naive_robot.update();
    Touching by_cube{wall.get(), {}}, by_naive{wall.get(), {}};
    cube_robot.collide(wall.get(), &by_cube, &recordCallback);
    naive_robot.collide(wall.get(), &by_naive, &recordCallback);
    same_octree = same_octree && by_cube.found == by_naive.found;
    arm_octree_hits += by_cube.found.size();
  }
  Touching world_by_cube{wall.get(), {}}, world_by_naive{wall.get(), {}};
  cube_world.collide(wall.get(), &world_by_cube, &recordCallback);
  naive_world.collide(wall.get(), &world_by_naive, &recordCallback);
  same_octree = same_octree && world_by_cube.found == world_by_naive.found;
  std::printf(
      "OcTree wall: %zu link contacts over the sampled configurations, %zu world objects "
      "inside it; same as NaiveCollisionManager: %s\n",
      arm_octree_hits, world_by_cube.found.size(), same_octree ? "yes" : "NO");

  // Agreement on nothing proves nothing: every kind of answer must have occurred.
  const bool exercised =
      !cube_out.world_hits.empty() && cube_out.world_hits.size() < std::size_t(configurations) &&
      !cube_out.self_hits.empty() && arm_octree_hits > 0 && !world_by_cube.found.empty();
  if (!exercised)
    std::printf(
        "some kind of collision never happened, so it was not compared: use a larger "
        "world or more configurations\n");
  if (!same_configs || !same_octree) return 1;
  return exercised ? 0 : 3;
}
