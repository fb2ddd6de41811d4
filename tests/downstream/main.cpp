// A downstream program: uses only the installed headers and library (through find_package or
// pkg-config). Checks the cube manager against fcl::NaiveCollisionManager on a small world.

#include <cube_collision/callbacks.h>
#include <cube_collision/cube_collision_manager.h>
#include <cube_collision/queries.h>
#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>
#if defined(CUBE_COLLISION_HAS_CAIRO)
#include <cube_collision/export.h>
#endif

using Object = fcl::CollisionObjectd;
using Pair = std::pair<Object*, Object*>;

namespace {

int failures = 0;

// Always on (assert() is compiled out in Release): a failed check names itself and the program
// exits non-zero, which fails its ctest.
void check(bool ok, const char* what) {
  if (!ok) {
    std::printf("CHECK FAILED: %s\n", what);
    ++failures;
  }
}

}  // namespace

// argv[1]: where to draw the hierarchy, if the library was built with Cairo.
int main(int argc, char** argv) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> pos(-10, 10), size(0.5, 2);
  std::vector<std::unique_ptr<Object>> objects;
  std::vector<Object*> pointers;
  for (int i = 0; i < 300; ++i) {
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.translation() = fcl::Vector3d(pos(rng), pos(rng), pos(rng));
    objects.push_back(
        std::make_unique<Object>(std::make_shared<fcl::Boxd>(size(rng), size(rng), size(rng)), tf));
    objects.back()->computeAABB();
    pointers.push_back(objects.back().get());
  }

  cube::CubeCollisionManagerd cube_manager;
  fcl::NaiveCollisionManagerd naive;
  cube_manager.registerObjects(pointers);
  naive.registerObjects(pointers);

  // Colliding pairs through the callable overload, and through the naive manager.
  auto colliding = [](fcl::BroadPhaseCollisionManagerd& m) {
    std::vector<Pair> out;
    auto* data = &out;
    m.collide(data, [](Object* a, Object* b, void* d) {
      fcl::CollisionRequestd request;
      fcl::CollisionResultd result;
      if (fcl::collide(a, b, request, result) > 0)
        static_cast<std::vector<Pair>*>(d)->emplace_back(std::min(a, b), std::max(a, b));
      return false;
    });
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto by_cube = colliding(cube_manager);
  const auto by_naive = colliding(naive);

  std::size_t by_lambda = 0;
  cube_manager.collide([&](Object*, Object*) { ++by_lambda; });

  cube::CollisionData<double> data;
  data.request.num_max_contacts = 100000;
  cube_manager.collide(&data, cube::defaultCollisionCallback<double>);
  const auto helper = cube::collideAll(cube_manager, data.request);

  std::printf("downstream: %zu colliding pairs (naive %zu), %zu candidates, %zu contacts\n",
              by_cube.size(), by_naive.size(), by_lambda, helper.numContacts());
  check(!by_naive.empty(), "the world has colliding pairs");
  check(by_cube == by_naive, "cube's colliding pairs equal Naive's");
  check(by_lambda >= by_cube.size(), "the callable overload sees every colliding pair");
  check(data.result.numContacts() == by_cube.size(),
        "defaultCollisionCallback: one contact per colliding box pair");
  check(helper.numContacts() == by_cube.size(), "collideAll: one contact per colliding box pair");
  // The narrow-phase pipeline through the install: OpenMP threads and a cache, linked as the
  // consumer links them; the same contacts, in the same order, as on one thread. With contact
  // geometry asked for, FCL answers every touching pair (the tight volumes prove box pairs
  // touching without it otherwise), so the cache has answers to hold.
  fcl::CollisionRequestd with_geometry = data.request;
  with_geometry.enable_contact = true;
  cube::NarrowPhaseCache<double> cache;
  cube::NarrowPhaseOptions<double> two;
  two.threads = 2;
  two.cache = &cache;
  cube::NarrowPhaseOptions<double> one;
  one.threads = 1;
  const auto serial = cube::collideAll(cube_manager, with_geometry, one);
  for (int round = 0; round < 2; ++round) {  // round 1: every pair from the cache
    const auto parallel = cube::collideAll(cube_manager, with_geometry, two);
    bool same = parallel.numContacts() == serial.numContacts();
    for (std::size_t k = 0; same && k < serial.numContacts(); ++k)
      same = parallel.getContact(k).o1 == serial.getContact(k).o1 &&
             parallel.getContact(k).o2 == serial.getContact(k).o2;
    check(same, "collideAll on 2 threads with a cache equals 1 thread, in order");
  }
  check(cache.size() > 0, "the cache holds the pairs FCL answered");
  if (failures > 0) return 1;
  std::printf("OK\n");

#if defined(CUBE_COLLISION_HAS_CAIRO)
  // Links Cairo in: a static install must carry it to the consumer's link line.
  if (argc > 1) {
    cube::writeSvg(cube::HierarchyView<double>(cube_manager), argv[1]);
    std::ifstream svg(argv[1]);
    std::string first;
    svg >> first;
    check(first.rfind("<?xml", 0) == 0 || first.rfind("<svg", 0) == 0,
          "writeSvg wrote an SVG document");
    if (failures > 0) return 1;
    std::printf("drew %s\n", argv[1]);
  }
#else
  (void)argc;
  (void)argv;
#endif
  return 0;
}
