// The batch's pair rules: margins, filter bits and the predicate as brute force applies them, and
// the first colliding pair is the documented one.

#include <fcl/geometry/octree/octree.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

TEST(Batch, MarginsFilterBitsAndThePredicate) {
  World w;
  fillWorld(w, 300, 21, false, false);
  // World margins: one object of three has its own, the rest the manager-wide one.
  w.manager.setMargin(0.05);
  for (std::size_t i = 0; i < w.objects.size(); i += 3)
    w.manager.setMargin(w.objects[i].get(), 0.2);
  for (std::size_t i = 0; i < w.objects.size(); i += 4)
    w.manager.setFilter(w.objects[i].get(), 2, ~0ull);
  std::mt19937 rng(4);
  cube::BodySet<S> body;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> bits;
  for (std::size_t l = 0; l < 6; ++l) {
    const std::uint64_t mask =
        l % 2 ? ~std::uint64_t(2) : ~std::uint64_t(0);  // odd links skip group 2
    body.addLink(randomShape(rng, 1.0, false), l % 3 == 0 ? 0.3 : 0.0, 1, mask);
    bits.emplace_back(1, mask);
  }
  // The predicate drops objects whose x is negative, seen as (world object, link object).
  const std::function<bool(Object*, Object*)> keep = [](Object* a, Object* b) {
    return a->getTranslation()[0] >= 0 && b->collisionGeometry() != nullptr;
  };
  w.manager.setPairFilter(keep);
  const auto poses = randomStates(80, body.size(), 5);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 2;
  std::size_t hits = 0;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits, keep, bits);
  EXPECT_GT(hits, 5u);
  EXPECT_LT(hits, 75u);
  o.first_pair = false;
  o.clearance = true;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, nullptr, keep, bits);
}

// Random scenes of every kind of world object (boxes, spheres, cylinders, capsules, meshes,
// planes, halfspaces, an octree) and bodies of several links per leaf group: the first pair is
// the documented one (lowest link, then world objects by registration number, then links) in
// every colliding state, on every thread count.
TEST(Batch, FirstPairIsTheDocumentedOneInRandomScenes) {
  std::size_t colliding = 0, checked = 0;
  for (std::uint32_t seed = 1; seed <= 12; ++seed) {
    World w;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> coin(0, 1);
    for (std::size_t i = 0; i < 40; ++i) {
      const double kind = coin(rng);
      Geometry g;
      fcl::Transform3d tf = randomPose(rng, 6);
      if (kind < 0.08) {
        g = std::make_shared<fcl::Planed>(randomPose(rng, 1).linear().col(0), 8 * coin(rng) - 4);
        tf = fcl::Transform3d::Identity();
      } else if (kind < 0.14) {
        g = std::make_shared<fcl::Halfspaced>(randomPose(rng, 1).linear().col(2),
                                              -6 - 3 * coin(rng));
        tf = fcl::Transform3d::Identity();
      } else {
        g = randomShape(rng, 2.0, true);
      }
      w.objects.push_back(std::make_unique<Object>(g, tf));
    }
    auto tree = std::make_shared<octomap::OcTree>(0.5);
    for (double t = -6; t <= 6; t += 0.5) tree->updateNode(octomap::point3d(t, -t, 0.25 * t), true);
    w.objects.insert(w.objects.begin() + std::ptrdiff_t(seed % 40),
                     std::make_unique<Object>(std::make_shared<fcl::OcTreed>(tree),
                                              fcl::Transform3d::Identity()));
    for (auto& o : w.objects) o->computeAABB();
    w.manager.registerObjects(w.pointers());
    w.manager.setup();
    const cube::BodySet<S> body = randomBody(5 + seed % 7, 100 + seed, seed % 2 == 0);
    const auto poses = randomStates(300, body.size(), 200 + seed, 6);
    cube::BatchOptions o;
    o.first_pair = true;
    o.self_collision = seed % 3 != 0;
    o.threads = 1;
    const auto one = cube::checkStates(w.manager, body, poses, o);
    std::size_t hits = 0;
    expectSame(one, w, body, poses, o, &hits);
    colliding += hits;
    checked += one.size();
    for (const int t : {2, 3, 8}) {
      o.threads = t;
      const auto many = cube::checkStates(w.manager, body, poses, o);
      ASSERT_EQ(many.size(), one.size());
      for (std::size_t k = 0; k < one.size(); ++k) {
        EXPECT_EQ(many[k].link, one[k].link) << "state " << k << ", " << t << " threads";
        EXPECT_EQ(many[k].object, one[k].object) << "state " << k << ", " << t << " threads";
        EXPECT_EQ(many[k].other_link, one[k].other_link)
            << "state " << k << ", " << t << " threads";
      }
    }
  }
  // Enough colliding and free states that a wrong pick would show.
  EXPECT_GT(colliding, checked / 4);
  EXPECT_LT(colliding, checked);
}

}  // namespace
