// The convenience API: queries with lambdas instead of function pointers and void*, and the
// one-call helpers of cube_collision/queries.h.
//
// Usage: callables [object count]   (default 2000)

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

int main(int argc, char** argv) {
  cube::scenes::SceneOptions options;
  options.n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 2000;
  const auto scene = cube::scenes::makeScene<double>(options);
  const auto probe = cube::scenes::makeScene<double>([&] {
    auto o = options;
    o.n = 1;
    o.seed = 9;
    return o;
  }());

  cube::CubeCollisionManagerd manager;
  manager.registerObjects(scene.pointers());
  using Object = fcl::CollisionObjectd;

  // A lambda with captures; returning true would stop the query.
  std::size_t colliding = 0;
  manager.collide([&](Object* a, Object* b) {
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    colliding += fcl::collide(a, b, request, result) > 0;
    return false;
  });

  // Distance with a lambda: lower `dist` to prune the search.
  double nearest = std::numeric_limits<double>::max();
  manager.distance(probe.objects[0].get(), [&](Object* a, Object* b, double& dist) {
    fcl::DistanceRequestd request;
    fcl::DistanceResultd result;
    const double d = fcl::distance(a, b, request, result);
    if (d < nearest) nearest = d;
    dist = nearest;
    return dist <= 0;  // touching: nothing can be nearer
  });

  // The same answers in one call each.
  const auto pairs = cube::overlappingPairs(manager);
  fcl::CollisionRequestd every_contact;
  every_contact.num_max_contacts = std::numeric_limits<std::size_t>::max();
  const auto contacts = cube::collideAll(manager, every_contact);
  const auto closest = cube::minimumDistance(manager, probe.objects[0].get());

  std::printf(
      "%zu objects: %zu overlapping AABB pairs, %zu colliding pairs (lambda), %zu "
      "contacts (collideAll)\n",
      manager.size(), pairs.size(), colliding, contacts.numContacts());
  std::printf("probe's nearest object: %.6f (lambda), %.6f (minimumDistance)\n", nearest,
              closest.min_distance);

  // Shapes give one contact per colliding pair, so the two ways must agree.
  const bool same = colliding == contacts.numContacts() &&
                    (std::abs(nearest - closest.min_distance) <= 1e-9 * std::abs(nearest) ||
                     (nearest <= 0 && closest.min_distance <= 0));
  std::printf(same ? "lambdas and helpers agree\n" : "MISMATCH\n");
  if (!same) return 1;
  return colliding > 0 ? 0 : 3;  // agreeing on nothing would prove nothing
}
