// Filter bits, a pair predicate, margins and canonical pair order on one scene: a robot arm's
// links (which never test against each other, as a collision matrix says) among shelves and
// clutter, with a contact margin for the planner. Checks each answer against brute force.
//   pair_rules [objects]

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/margins.h"
#include "scenes.h"

namespace {

using Obj = fcl::CollisionObjectd;

int failures = 0;
void expect(bool ok, const std::string& what) {
  std::printf("  %-58s %s\n", what.c_str(), ok ? "ok" : "FAILED");
  failures += !ok;
}

}  // namespace

int main(int argc, char** argv) {
  const std::size_t n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 2000;
  cube::scenes::SceneOptions options;
  options.n = n;
  options.overlaps_per_object = 2.0;
  auto scene = cube::scenes::makeScene<double>(options);
  const auto objs = scene.pointers();
  const double size = cube::scenes::typicalSize(options);

  // The first 8 objects play the robot's links; the world is everything else.
  enum : std::uint64_t { kRobot = 1, kWorld = 2 };
  cube::Config config;
  config.canonical_pairs = true;  // the same pairs, in the same order, whatever the tree
  cube::CubeCollisionManagerd manager(config);
  manager.registerObjects(objs);
  for (std::size_t i = 0; i < objs.size(); ++i) {
    const bool robot = i < 8;
    // Links meet the world; the world's objects meet only the robot (a static world's own
    // pairs are of no interest to a planner).
    manager.setFilter(objs[i], robot ? kRobot : kWorld, robot ? kWorld : kRobot);
  }
  // And one link is allowed to touch object 8 (say, the tool holds it): a collision matrix.
  manager.setPairFilter([&](Obj* a, Obj* b) {
    return !((a == objs[7] && b == objs[8]) || (a == objs[8] && b == objs[7]));
  });
  for (std::size_t i = 0; i < 8; ++i) {
    objs[8 + i]->setTransform(objs[i]->getTransform());  // put clutter right on the links
    objs[8 + i]->computeAABB();
  }
  manager.update();

  std::vector<std::pair<Obj*, Obj*>> pairs;
  manager.collide([&](Obj* a, Obj* b) { pairs.emplace_back(a, b); });
  std::printf("%zu objects, %zu robot-world pairs whose boxes overlap:\n", n, pairs.size());
  std::set<std::pair<Obj*, Obj*>> brute;
  for (std::size_t i = 0; i < 8; ++i)
    for (std::size_t j = 8; j < objs.size(); ++j)
      if (!(i == 7 && j == 8) && objs[i]->getAABB().overlap(objs[j]->getAABB()))
        brute.emplace(objs[i], objs[j]);
  expect(std::set<std::pair<Obj*, Obj*>>(pairs.begin(), pairs.end()) == brute &&
             pairs.size() == brute.size(),
         "filtered pairs equal brute force (earlier registered first)");
  expect(std::is_sorted(pairs.begin(), pairs.end(),
                        [&](const auto& x, const auto& y) {
                          const auto at = [&](Obj* o) {
                            return std::find(objs.begin(), objs.end(), o) - objs.begin();
                          };
                          return std::make_pair(at(x.first), at(x.second)) <
                                 std::make_pair(at(y.first), at(y.second));
                        }),
         "pairs come in registration order");

  // A contact margin of a fifth of an object for the links, a tenth elsewhere.
  manager.setMargin(0.1 * size);
  for (std::size_t i = 0; i < 8; ++i) manager.setMargin(objs[i], 0.2 * size);
  cube::NarrowPhaseStats stats;
  const auto near = cube::contactsWithinMargin(manager, fcl::DistanceRequestd(true), 0, &stats);
  std::size_t colliding = 0, brute_near = 0;
  for (const auto& c : near) {
    colliding += c.colliding;
    std::printf("  %s: object %td - object %td, distance %.4f\n",
                c.colliding ? "collides " : "too close",
                std::find(objs.begin(), objs.end(), c.a) - objs.begin(),
                std::find(objs.begin(), objs.end(), c.b) - objs.begin(), c.distance);
  }
  for (std::size_t i = 0; i < 8; ++i)
    for (std::size_t j = 8; j < objs.size(); ++j) {
      if (i == 7 && j == 8) continue;
      fcl::CollisionRequestd creq;
      fcl::CollisionResultd cres;
      fcl::DistanceRequestd dreq;
      fcl::DistanceResultd dres;
      brute_near += fcl::collide(objs[i], objs[j], creq, cres) > 0 ||
                    fcl::distance(objs[i], objs[j], dreq, dres) <= 0.3 * size;
    }
  std::printf(
      "%zu pairs within the margins (%zu colliding); %zu candidates, %zu culled, %zu "
      "narrow-phase calls\n",
      near.size(), colliding, stats.candidate_pairs, stats.culled, stats.narrow_calls);
  expect(near.size() == brute_near, "pairs within the margins equal FCL on every pair");
  std::string why;
  expect(manager.validate(&why), "validate() " + why);
  return failures == 0 ? 0 : 1;
}
