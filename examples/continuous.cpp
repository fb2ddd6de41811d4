// Continuous collision with a broadphase: a tenth of a scene's objects move (translation and
// rotation, a screw motion) from where they are to a new pose; which pairs can meet on the way,
// and when the first contacts happen. Checks both against brute force over every pair.
//
// Usage: continuous [object count]   (default 2000)

#include "cube_collision/continuous.h"

#include <fcl/narrowphase/continuous_collision.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

int main(int argc, char** argv) {
  cube::scenes::SceneOptions options;
  options.n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 2000;
  const auto scene = cube::scenes::makeScene<double>(options);
  const double size = cube::scenes::typicalSize(options);

  cube::CubeCollisionManagerd manager;
  manager.registerObjects(scene.pointers());

  // Every tenth object moves three object sizes along x while turning a quarter turn.
  std::vector<cube::Motion<double>> motions;
  for (std::size_t i = 0; i < scene.objects.size(); i += 10) {
    fcl::CollisionObjectd* obj = scene.objects[i].get();
    fcl::Transform3d end = obj->getTransform();
    end.translation().x() += 3 * size;
    end.linear() =
        fcl::AngleAxisd(M_PI / 2, fcl::Vector3d::UnitZ()).toRotationMatrix() * end.linear();
    motions.push_back({obj, end});
  }

  fcl::ContinuousCollisionRequestd request;
  request.ccd_motion_type = fcl::CCDM_SCREW;
  request.num_max_iterations = 20;  // fcl::collide at 20 evenly spaced times

  const auto t0 = std::chrono::steady_clock::now();
  const auto pairs = cube::sweptPairs(manager, motions, request.ccd_motion_type);
  const auto contacts = cube::continuousCollideAll(manager, motions, request);
  const double ms =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e3;
  std::printf("%zu objects, %zu moving: %zu pairs whose swept boxes meet, %zu collide (%.1f ms)\n",
              scene.objects.size(), motions.size(), pairs.size(), contacts.size(), ms);
  // Sorted by time: pairs already touching at the start come first (t = 0).
  std::size_t at_start = 0;
  while (at_start < contacts.size() && contacts[at_start].time_of_contact == 0) ++at_start;
  std::printf("%zu touch at the start, %zu meet on the way", at_start, contacts.size() - at_start);
  if (at_start < contacts.size())
    std::printf(", the first at t = %.3f", contacts[at_start].time_of_contact);
  std::printf("\n");

  // Brute force: fcl::continuousCollide on every pair with a mover.
  std::vector<const fcl::Transform3d*> end(scene.objects.size(), nullptr);
  for (std::size_t k = 0; k < motions.size(); ++k) end[k * 10] = &motions[k].end;
  std::size_t want = 0;
  double first = 2;
  for (std::size_t i = 0; i < scene.objects.size(); ++i)
    for (std::size_t j = i + 1; j < scene.objects.size(); ++j) {
      if (!end[i] && !end[j]) continue;
      const auto* a = scene.objects[i].get();
      const auto* b = scene.objects[j].get();
      fcl::ContinuousCollisionResultd r;
      fcl::continuousCollide(a, end[i] ? *end[i] : a->getTransform(), b,
                             end[j] ? *end[j] : b->getTransform(), request, r);
      if (r.is_collide) {
        ++want;
        first = std::min(first, r.time_of_contact);
      }
    }
  const bool ok =
      want == contacts.size() && (want == 0 || first == contacts.front().time_of_contact);
  std::printf("brute force over every pair: %zu collide%s\n", want, ok ? "" : "  MISMATCH");
  return ok ? 0 : 1;
}
