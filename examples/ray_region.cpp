// Ray and region queries (cube_collision/spatial_queries.h): a line of sight across a random
// world, the first object it meets and every object along it, the objects in a box and near a
// point. Each answer is checked against a loop over every object; exits non-zero if one differs.
//
// Usage: ray_region [object count]   (default 20000)

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/spatial_queries.h"
#include "scenes.h"

int main(int argc, char** argv) {
  cube::scenes::SceneOptions options;
  options.n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 20000;
  const auto scene = cube::scenes::makeScene<double>(options);
  cube::CubeCollisionManagerd manager;
  manager.registerObjects(scene.pointers());
  int failures = 0;

  // A segment across the world, corner to corner.
  const double h = options.half_extent;
  const fcl::Vector3d from(-h, -h * 0.9, -h * 0.8), to(h, h * 0.95, h * 0.7);
  const auto first = cube::raycastFirst(manager, from, to);
  const auto all = cube::raycastAll(manager, from, to);
  std::printf("segment of length %.0f meets %zu object(s)\n", (to - from).norm(), all.size());
  if (first)
    std::printf("first hit at distance %.4f (t = %.6f, %s), point (%.2f, %.2f, %.2f)\n",
                first->distance, first->t,
                first->kind == cube::HitKind::narrow_phase ? "narrow phase" : "box",
                first->point[0], first->point[1], first->point[2]);
  // Box hits only: the cheaper question "which AABBs does it cross?".
  cube::RayOptions<double> boxes_only;
  boxes_only.narrow_phase = false;
  const auto crossed = cube::raycastAll(manager, from, to, boxes_only);
  std::printf("its AABB crosses %zu box(es)\n", crossed.size());

  // Self-check: the same answers from every object tested in turn.
  std::vector<cube::RayHit<double>> loop;
  for (const auto* obj : scene.pointers())
    if (auto hit = cube::raycastObject(*obj, obj->getAABB(), from, to)) loop.push_back(*hit);
  const bool first_ok = first.has_value() == !loop.empty();
  double nearest = loop.empty() ? 2 : loop.front().t;
  for (const auto& hit : loop) nearest = std::fmin(nearest, double(hit.t));
  if (!first_ok || loop.size() != all.size() || (first && first->t != nearest)) {
    std::printf("FAILED: the loop over every object finds %zu hits, nearest t %.6f\n", loop.size(),
                nearest);
    ++failures;
  }

  // Regions: a box around the centre and a ball around the first hit (or the origin).
  const fcl::AABBd region(fcl::Vector3d(-h / 10, -h / 10, -h / 10),
                          fcl::Vector3d(h / 10, h / 10, h / 10));
  const fcl::Vector3d centre = first ? first->point : fcl::Vector3d(0, 0, 0);
  const double radius = h / 20;
  const auto inside = cube::objectsInBox(manager, region);
  const auto near = cube::objectsNear(manager, centre, radius);
  std::printf("%zu objects overlap the central box, %zu lie within %.0f of (%.1f, %.1f, %.1f)\n",
              inside.size(), near.size(), radius, centre[0], centre[1], centre[2]);
  std::size_t inside_loop = 0, near_loop = 0;
  for (const auto* obj : scene.pointers()) {
    const fcl::AABBd& b = obj->getAABB();
    inside_loop += b.overlap(region);
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double g = std::fmax(0.0, std::fmax(b.min_[k] - centre[k], centre[k] - b.max_[k]));
      d2 += g * g;
    }
    near_loop += d2 <= radius * radius;
  }
  if (inside_loop != inside.size() || near_loop != near.size()) {
    std::printf("FAILED: the loop finds %zu in the box, %zu near the point\n", inside_loop,
                near_loop);
    ++failures;
  }
  if (failures == 0) std::printf("all answers equal the loop over every object\n");
  return failures == 0 ? 0 : 1;
}
