// Scale check: registers N objects (default 1,000,000), self-collides them, and reports
// the time and the bytes the manager owns per object. The candidate pair count must equal
// fcl::DynamicAABBTreeCollisionManager's on the same objects; the exit status is non-zero if not.
//
//   scale_million [N] [seed]

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

bool countPair(Object*, Object*, void* n) {
  ++*static_cast<std::size_t*>(n);
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  const std::size_t n = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1000000;
  const unsigned seed = argc > 2 ? unsigned(std::strtoul(argv[2], nullptr, 10)) : 1;
  if (n == 0) {
    std::fprintf(stderr, "usage: scale_million [N >= 1] [seed]\n");
    return 2;
  }

  // A handful of shared geometries keeps memory to the objects themselves. The world grows with
  // N so that the density (about six AABB overlaps per object) does not depend on N.
  const double side = 1.0;
  const double half = 0.5 * std::cbrt(double(n) * side * side * side);
  std::vector<std::shared_ptr<fcl::CollisionGeometry<S>>> shapes = {
      std::make_shared<fcl::Box<S>>(side, side * 0.8, side * 0.6),
      std::make_shared<fcl::Box<S>>(side * 0.3, side * 0.3, side),
      std::make_shared<fcl::Sphere<S>>(side * 0.5),
  };
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-half, half), angle(0, 6.2831853);
  std::vector<std::unique_ptr<Object>> owned;
  std::vector<Object*> objs;
  owned.reserve(n);
  objs.reserve(n);
  const auto t_make = Clock::now();
  for (std::size_t i = 0; i < n; ++i) {
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.translation() = fcl::Vector3<S>(u(rng), u(rng), u(rng));
    tf.linear() =
        Eigen::AngleAxis<S>(angle(rng), fcl::Vector3<S>(u(rng), u(rng), half).normalized())
            .toRotationMatrix();
    owned.push_back(std::make_unique<Object>(shapes[i % shapes.size()], tf));
    owned.back()->computeAABB();
    objs.push_back(owned.back().get());
  }
  std::printf("scale_million: %zu objects made in %.2f s\n", n, secondsSince(t_make));

  cube::CubeCollisionManager<S> cube_mgr;
  auto t = Clock::now();
  cube_mgr.registerObjects(objs);
  cube_mgr.setup();
  const double cube_build = secondsSince(t);
  std::size_t cube_pairs = 0;
  t = Clock::now();
  cube_mgr.collide(&cube_pairs, countPair);
  const double cube_collide = secondsSince(t);
  const std::size_t bytes = cube_mgr.bytes();
  std::string why;
  const bool valid = cube_mgr.validate(&why);

  fcl::DynamicAABBTreeCollisionManager<S> fcl_mgr;
  t = Clock::now();
  fcl_mgr.registerObjects(objs);
  fcl_mgr.setup();
  const double fcl_build = secondsSince(t);
  std::size_t fcl_pairs = 0;
  t = Clock::now();
  fcl_mgr.collide(&fcl_pairs, countPair);
  const double fcl_collide = secondsSince(t);

  std::printf(
      "cube:  build %.3f s, self-collide %.3f s, %zu pairs, %zu bytes owned (%.1f B/object)\n",
      cube_build, cube_collide, cube_pairs, bytes, double(bytes) / double(n));
  std::printf("fcl DynamicAABBTree: build %.3f s, self-collide %.3f s, %zu pairs\n", fcl_build,
              fcl_collide, fcl_pairs);
  if (!valid) {
    std::printf("FAIL: validate(): %s\n", why.c_str());
    return 1;
  }
  if (cube_pairs != fcl_pairs) {
    std::printf("FAIL: pair counts differ\n");
    return 1;
  }
  std::printf("OK: pair counts match\n");
  return 0;
}
