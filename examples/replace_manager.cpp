// Migration example: a typical FCL program, written against fcl::BroadPhaseCollisionManagerd*.
// Moving it to cube-collision changes one line, the `new` in makeManager(). The program runs
// itself twice, once with each manager, and checks that the contacts are identical.
//
// Usage: replace_manager [object count]   (default 2000)

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <random>
#include <tuple>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace {

// ---- The FCL program, unchanged but for one line ----------------------------------------------

fcl::BroadPhaseCollisionManagerd* makeManager(bool cube) {
  if (cube) return new cube::CubeCollisionManagerd();  // <- the one line that changes
  return new fcl::DynamicAABBTreeCollisionManagerd();  //    (was this)
}

struct World {
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
  std::map<const fcl::CollisionGeometryd*, int> index;  // to name contacts by object
};

// Boxes and spheres scattered in a 100 m cube, each with its own geometry.
World makeWorld(int n, unsigned seed) {
  World w;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-50, 50), size(0.5, 3.0), angle(-M_PI, M_PI);
  for (int i = 0; i < n; ++i) {
    std::shared_ptr<fcl::CollisionGeometryd> g;
    if (i % 2)
      g = std::make_shared<fcl::Boxd>(size(rng), size(rng), size(rng));
    else
      g = std::make_shared<fcl::Sphered>(size(rng) / 2);
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.translation() = fcl::Vector3d(pos(rng), pos(rng), pos(rng));
    tf.rotate(fcl::AngleAxisd(angle(rng), fcl::Vector3d::UnitZ()));
    w.index[g.get()] = i;
    w.objects.push_back(std::make_unique<fcl::CollisionObjectd>(g, tf));
  }
  return w;
}

// (object, object) for every contact, lower index first, sorted: comparable across runs.
using Contacts = std::vector<std::pair<int, int>>;

Contacts named(const World& w, const fcl::CollisionResultd& result) {
  Contacts out;
  for (std::size_t i = 0; i < result.numContacts(); ++i) {
    const auto& c = result.getContact(i);
    const int a = w.index.at(c.o1), b = w.index.at(c.o2);
    out.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(out.begin(), out.end());
  return out;
}

struct Report {
  Contacts self, queries;
  double min_distance = 0;
};

Report run(bool use_cube, int n) {
  World world = makeWorld(n, 1);
  World probes = makeWorld(n / 10 + 1, 2);

  std::unique_ptr<fcl::BroadPhaseCollisionManagerd> manager(makeManager(use_cube));
  std::vector<fcl::CollisionObjectd*> objs;
  for (auto& o : world.objects) {
    o->computeAABB();
    objs.push_back(o.get());
  }
  manager->registerObjects(objs);
  manager->setup();

  // Things move: shift every third object and tell the manager.
  for (std::size_t i = 0; i < world.objects.size(); i += 3) {
    auto& o = world.objects[i];
    o->setTranslation(o->getTranslation() + fcl::Vector3d(1.5, -0.5, 0.25));
    o->computeAABB();
  }
  manager->update();

  Report report;
  {
    fcl::DefaultCollisionData<double> data;
    data.request.num_max_contacts = 100000;  // every contact, not just the first
    manager->collide(&data, fcl::DefaultCollisionFunction<double>);
    report.self = named(world, data.result);
  }
  for (auto& p : probes.objects) {
    p->computeAABB();
    fcl::DefaultCollisionData<double> data;
    data.request.num_max_contacts = 100000;
    manager->collide(p.get(), &data, fcl::DefaultCollisionFunction<double>);
    for (std::size_t i = 0; i < data.result.numContacts(); ++i) {
      const auto& c = data.result.getContact(i);
      const bool world_first = world.index.count(c.o1) > 0;
      report.queries.emplace_back(world.index.at(world_first ? c.o1 : c.o2),
                                  probes.index.at(world_first ? c.o2 : c.o1));
    }
  }
  std::sort(report.queries.begin(), report.queries.end());
  {
    fcl::DefaultDistanceData<double> data;
    manager->distance(&data, fcl::DefaultDistanceFunction<double>);
    report.min_distance = data.result.min_distance;
  }
  return report;
}

// Distances agree, or both report touching objects (FCL gives a negative value, not a depth,
// for penetrating pairs unless signed distance is requested).
bool sameDistance(double a, double b) {
  if (a <= 0 || b <= 0) return a <= 0 && b <= 0;
  return std::abs(a - b) <= 1e-9 * std::max(1.0, b);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 2000;
  if (n < 2) {
    std::fprintf(stderr, "usage: %s [object count >= 2]\n", argv[0]);
    return 2;
  }
  const Report fcl_report = run(false, n);
  const Report cube_report = run(true, n);

  std::printf("%-28s %14s %14s\n", "", "fcl DynamicAABB", "cube");
  std::printf("%-28s %14zu %14zu\n", "self-collide contacts", fcl_report.self.size(),
              cube_report.self.size());
  std::printf("%-28s %14zu %14zu\n", "query contacts", fcl_report.queries.size(),
              cube_report.queries.size());
  std::printf("%-28s %14.6f %14.6f\n", "minimum distance", fcl_report.min_distance,
              cube_report.min_distance);

  const bool same = fcl_report.self == cube_report.self &&
                    fcl_report.queries == cube_report.queries &&
                    sameDistance(fcl_report.min_distance, cube_report.min_distance);
  std::printf(same ? "contacts identical\n" : "CONTACTS DIFFER\n");
  if (!same) return 1;
  // Identical empty lists would prove nothing.
  if (cube_report.self.empty() || cube_report.queries.empty()) {
    std::printf("no contacts to compare: use more objects\n");
    return 3;
  }
  return 0;
}
