// Batched state and motion checks (cube_collision/batch.h) against brute force: every link
// against every world object and every checked pair of links, with FCL's narrow phase.

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

#include "core/kernels/pose_boxes.h"
#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// Worlds of 60 objects (no per-object records: below kVolumeMinObjects) and 400 (records), with
// and without meshes, planes in the small one (one tilted: clearance then reads exact gaps).
class BatchWorlds : public ::testing::TestWithParam<std::tuple<std::size_t, bool>> {};

TEST_P(BatchWorlds, StatesEqualBruteForce) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 7 + std::uint32_t(n), meshes, n < 100);
  const cube::BodySet<S> body = randomBody(8, 3, meshes);
  const auto poses = randomStates(60, body.size(), 11);
  std::size_t free_states = 0;
  for (const bool self : {false, true})
    for (const bool first : {false, true}) {
      cube::BatchOptions o;
      o.self_collision = self;
      o.first_pair = first;
      o.clearance = !first;
      o.threads = 1;
      std::size_t hits = 0;
      expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
      free_states = poses.size() / body.size() - hits;
      // The scene must exercise both answers.
      EXPECT_GT(hits, 5u);
      EXPECT_GT(free_states, 5u);
    }
}

TEST_P(BatchWorlds, ThreadCountsGiveTheSameAnswers) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 5, meshes, false);
  const cube::BodySet<S> body = randomBody(6, 9, meshes);
  const auto poses = randomStates(80, body.size(), 13);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  const auto one = cube::checkStates(w.manager, body, poses, o);
  for (const int t : {2, 3, 8}) {
    o.threads = t;
    const auto many = cube::checkStates(w.manager, body, poses, o);
    ASSERT_EQ(many.size(), one.size());
    for (std::size_t k = 0; k < one.size(); ++k) {
      EXPECT_EQ(many[k].colliding, one[k].colliding);
      EXPECT_EQ(many[k].link, one[k].link);
      EXPECT_EQ(many[k].object, one[k].object);
      EXPECT_EQ(many[k].other_link, one[k].other_link);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Batch, BatchWorlds,
                         ::testing::Combine(::testing::Values(std::size_t(60), std::size_t(400)),
                                            ::testing::Bool()));

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

// A sphere of radius 0.5 whose surface is 50 units above the tilted plane x + y + z = 0 (the
// plane's box is the whole space), with a margin of 0.01: free, clearance 50. Also as a
// halfspace, moved 1000 units along the plane; 0.005 above, it is within its margin.
TEST(Batch, SphereAboveATiltedPlaneIsFreeBeyondItsMargin) {
  const fcl::Vector3d n = fcl::Vector3d(1, 1, 1).normalized();
  const fcl::Vector3d along = fcl::Vector3d(1, -1, 0).normalized() * 1000;
  for (const bool halfspace : {false, true}) {
    World w;
    if (halfspace)
      w.objects.push_back(std::make_unique<Object>(std::make_shared<fcl::Halfspaced>(n, 0.0)));
    else
      w.objects.push_back(std::make_unique<Object>(std::make_shared<fcl::Planed>(n, 0.0)));
    w.objects.back()->computeAABB();
    w.manager.registerObjects(w.pointers());
    cube::BodySet<S> body;
    body.addLink(std::make_shared<fcl::Sphered>(0.5), 0.01);
    cube::BatchOptions o;
    o.clearance = true;
    for (const double gap : {50.0, 0.02, 0.005}) {
      const std::vector<fcl::Transform3d> poses = {fcl::Transform3d(
          fcl::Translation3d((halfspace ? along : fcl::Vector3d::Zero()) + n * (0.5 + gap)))};
      const auto got = cube::checkStates(w.manager, body, poses, o);
      ASSERT_EQ(got.size(), 1u);
      EXPECT_EQ(got[0].colliding, gap <= 0.01) << gap;
      if (gap > 0.01) {
        EXPECT_NEAR(got[0].clearance, gap, 1e-9) << gap;
      }
      expectSame(got, w, body, poses, o);
    }
  }
}

// Links of every kind (box, sphere, capsule, cylinder, cone, ellipsoid, convex, mesh) against a
// tilted plane and a tilted halfspace about 1000 units from the origin: collisions, margins and
// clearance equal the brute force (the exact gap to the plane, plane_brute.h).
TEST(Batch, EveryLinkKindAgainstTiltedPlanesFarFromTheOrigin) {
  auto verts = std::make_shared<std::vector<fcl::Vector3d>>(std::vector<fcl::Vector3d>{
      {0.5, 0, -0.2}, {-0.3, 0.4, -0.2}, {-0.3, -0.4, -0.2}, {0, 0, 0.6}});
  auto faces = std::make_shared<std::vector<int>>(
      std::vector<int>{3, 0, 1, 2, 3, 0, 3, 1, 3, 1, 3, 2, 3, 2, 3, 0});
  const std::vector<Geometry> kinds = {std::make_shared<fcl::Boxd>(1.0, 0.4, 0.7),
                                       std::make_shared<fcl::Sphered>(0.45),
                                       std::make_shared<fcl::Capsuled>(0.25, 0.9),
                                       std::make_shared<fcl::Cylinderd>(0.3, 1.1),
                                       std::make_shared<fcl::Coned>(0.4, 0.9),
                                       std::make_shared<fcl::Ellipsoidd>(0.6, 0.3, 0.4),
                                       std::make_shared<fcl::Convexd>(verts, 4, faces, true),
                                       meshBox(0.8, 0.5, 0.3)};
  const fcl::Vector3d n = fcl::Vector3d(2, -1, 3).normalized();
  const fcl::Vector3d origin(700, 500, -400);  // on the plane: d = n . origin
  for (const bool halfspace : {false, true}) {
    World w;
    if (halfspace)
      w.objects.push_back(
          std::make_unique<Object>(std::make_shared<fcl::Halfspaced>(n, n.dot(origin))));
    else
      w.objects.push_back(
          std::make_unique<Object>(std::make_shared<fcl::Planed>(n, n.dot(origin))));
    w.objects.back()->computeAABB();
    w.manager.registerObjects(w.pointers());
    cube::BodySet<S> body;
    for (std::size_t l = 0; l < kinds.size(); ++l) body.addLink(kinds[l], l % 2 ? 0.1 : 0.0);
    // Each link near the plane (-0.6 .. 8 off it, either side of a plane), the links far apart.
    std::mt19937 rng(halfspace ? 31 : 32);
    std::uniform_real_distribution<double> off(-0.6, 8.0), u(-1.0, 1.0);
    const fcl::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
    std::vector<fcl::Transform3d> poses;
    for (int k = 0; k < 150; ++k)
      for (std::size_t l = 0; l < kinds.size(); ++l) {
        fcl::Transform3d tf = randomPose(rng, 0);
        const double side = !halfspace && u(rng) < 0 ? -1 : 1;
        tf.translation() =
            origin + e1 * (10.0 * double(l)) + e2 * (5 * u(rng)) + n * (side * off(rng));
        poses.push_back(tf);
      }
    for (const bool first : {false, true}) {
      cube::BatchOptions o;
      o.first_pair = first;
      o.clearance = !first;
      std::size_t hits = 0;
      expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
      EXPECT_GT(hits, 20u);
      EXPECT_LT(hits, 130u);  // free states: their clearance checked
    }
  }
}

// FCL 0.7's yes/no cylinder-plane test projects lz where lz/2 belongs, and its cone-halfspace
// test takes a cone whose apex points into the halfspace for one lying on its side; the batch
// answers from the geometry whether or not the link's box reaches the plane's. 4,000 tilted
// cylinder (and cone) links over the plane z = 0 and the halfspace z <= 0, the lowest point
// -0.3 .. 2.5 off it, against brute force: centre . n - |axis . n| h/2 - r sqrt(1 - (axis . n)^2)
// for a cylinder, the lower of the apex and the base rim's lowest point for a cone.
TEST(Batch, TiltedCylindersAndConesOverPlanesGetTheTrueAnswer) {
  const fcl::Vector3d n(0, 0, 1);
  for (const bool halfspace : {false, true})
    for (const bool cone : {false, true}) {
      World w;
      if (halfspace)
        w.objects.push_back(std::make_unique<Object>(std::make_shared<fcl::Halfspaced>(n, 0.0)));
      else
        w.objects.push_back(std::make_unique<Object>(std::make_shared<fcl::Planed>(n, 0.0)));
      w.objects.back()->computeAABB();
      w.manager.registerObjects(w.pointers());
      const double r = 0.35, h = 2.0;
      cube::BodySet<S> body;
      if (cone)
        body.addLink(std::make_shared<fcl::Coned>(r, h));
      else
        body.addLink(std::make_shared<fcl::Cylinderd>(r, h));
      std::mt19937 rng(cone ? 51 : 52);
      std::uniform_real_distribution<double> off(-0.3, 2.5), u(-20, 20);
      std::vector<fcl::Transform3d> poses;
      std::vector<bool> truth;
      for (int k = 0; k < 4000; ++k) {
        fcl::Transform3d tf = randomPose(rng, 0);
        const fcl::Vector3d axis = tf.linear().col(2);
        const double an = axis.dot(n), rim = r * std::sqrt(std::max(0.0, 1 - an * an));
        // The centre placed so that the lowest point is `off` above the plane.
        const double lowest_rel =
            cone ? std::min(an * h / 2, -an * h / 2 - rim) : -std::abs(an) * h / 2 - rim;
        const double highest_rel =
            cone ? std::max(an * h / 2, -an * h / 2 + rim) : std::abs(an) * h / 2 + rim;
        const double lowest = off(rng);
        tf.translation() = fcl::Vector3d(u(rng), u(rng), lowest - lowest_rel);
        poses.push_back(tf);
        const double highest = lowest - lowest_rel + highest_rel;
        truth.push_back(halfspace ? lowest <= 0 : (lowest <= 0 && highest >= 0));
      }
      cube::BatchOptions o;
      o.clearance = true;
      const auto got = cube::checkStates(w.manager, body, poses, o);
      ASSERT_EQ(got.size(), truth.size());
      std::size_t wrong = 0, hits = 0;
      for (std::size_t k = 0; k < truth.size(); ++k) {
        wrong += got[k].colliding != truth[k];
        hits += truth[k];
      }
      EXPECT_EQ(wrong, 0u) << (cone ? "cones" : "cylinders")
                           << (halfspace ? " / halfspace" : " / plane");
      EXPECT_GT(hits, 300u);
      EXPECT_LT(hits, 3700u);
      expectSame(got, w, body, poses, o);
    }
}

// FCL 0.7's fcl::distance answers an octree against a shape (each occupied cell as a box): the
// batch's clearance and margins, and contactsWithinMargin, take its answer, not the distance of
// the AABBs (a diagonal row of cells, whose box is far larger than the cells).
TEST(Batch, ClearanceAndMarginsToAnOctreeAreFclsDistance) {
  auto tree = std::make_shared<octomap::OcTree>(0.5);
  for (double x = -5; x <= 5; x += 0.5) tree->updateNode(octomap::point3d(x, 0.6 * x, 0), true);
  World w;
  w.objects.push_back(std::make_unique<Object>(std::make_shared<fcl::OcTreed>(tree)));
  w.objects.back()->computeAABB();
  w.manager.registerObjects(w.pointers());
  cube::BodySet<S> body;
  body.addLink(std::make_shared<fcl::Sphered>(0.3), 0.2);
  std::mt19937 rng(71);
  std::uniform_real_distribution<double> u(-6, 6), z(-1.5, 1.5);
  std::vector<fcl::Transform3d> poses;
  for (int k = 0; k < 300; ++k)
    poses.push_back(fcl::Transform3d(fcl::Translation3d(u(rng), u(rng), z(rng))));
  cube::BatchOptions o;
  o.clearance = true;
  std::size_t hits = 0;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
  EXPECT_GT(hits, 10u);
  EXPECT_LT(hits, 290u);

  // The same spheres as objects of one manager with the octree, margin 0.2 each.
  std::vector<std::unique_ptr<Object>> balls;
  cube::CubeCollisionManagerd m;
  m.registerObject(w.objects[0].get());
  for (const auto& tf : poses) {
    balls.push_back(std::make_unique<Object>(std::make_shared<fcl::Sphered>(0.3), tf));
    balls.back()->computeAABB();
    m.registerObject(balls.back().get());
    m.setMargin(balls.back().get(), 0.2);
  }
  m.setup();
  std::set<const Object*> want;
  for (const auto& b : balls)
    if (bruteTouch(*b, *w.objects[0], 0.2)) want.insert(b.get());
  std::set<const Object*> got;
  for (const auto& c : cube::contactsWithinMargin<S>(m, fcl::DistanceRequestd(), 1)) {
    const bool octree_first = c.a == w.objects[0].get();
    if (octree_first || c.b == w.objects[0].get()) got.insert(octree_first ? c.b : c.a);
  }
  EXPECT_EQ(got, want);
  EXPECT_GT(want.size(), 10u);
}

// The serial scan of an edge in an order, from per-state answers.
std::size_t serialScan(const std::vector<cube::StateResult<S>>& states, std::size_t begin,
                       std::size_t end, cube::MotionOrder order) {
  for (const std::size_t i : visitOrder(end - begin, order))
    if (states[begin + i].colliding) return i;
  return cube::kNoIndex;
}

TEST(Batch, MotionsGiveTheSerialScansAnswer) {
  World w;
  fillWorld(w, 400, 31, false, true);
  const cube::BodySet<S> body = randomBody(5, 17, false);
  // Edges of 1 to 40 states: a straight sweep of the robot's rigid pose across the world.
  std::mt19937 rng(2);
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
  std::vector<fcl::Transform3d> shape;
  for (std::size_t l = 0; l < body.size(); ++l) shape.push_back(randomPose(rng, 1.5));
  for (int e = 0; e < 30; ++e) {
    starts.push_back(poses.size() / body.size());
    const fcl::Vector3d from = randomPose(rng, 9).translation(),
                        to = randomPose(rng, 9).translation();
    const std::size_t n = 1 + std::size_t(e * 13 % 40);
    for (std::size_t k = 0; k < n; ++k) {
      const double t = n == 1 ? 0 : double(k) / double(n - 1);
      for (const auto& s : shape) {
        fcl::Transform3d tf = s;
        tf.translation() += from + t * (to - from);
        poses.push_back(tf);
      }
    }
  }
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  const auto states = cube::checkStates(w.manager, body, poses, o);
  expectSame(states, w, body, poses, o);
  std::size_t edges_hit = 0;
  for (const auto order : {cube::MotionOrder::path, cube::MotionOrder::bisection})
    for (const int t : {1, 2, 3, 8}) {
      o.threads = t;
      const auto first = cube::checkMotions(w.manager, body, poses, starts, order, o);
      ASSERT_EQ(first.size(), starts.size());
      edges_hit = 0;
      for (std::size_t e = 0; e < starts.size(); ++e) {
        const std::size_t end = e + 1 < starts.size() ? starts[e + 1] : states.size();
        EXPECT_EQ(first[e], serialScan(states, starts[e], end, order)) << "edge " << e;
        edges_hit += first[e] != cube::kNoIndex;
      }
      // One edge alone, from the array and from poses written on demand.
      for (std::size_t e = 0; e + 1 < starts.size(); ++e) {
        const std::vector<fcl::Transform3d> edge(poses.begin() + starts[e] * body.size(),
                                                 poses.begin() + starts[e + 1] * body.size());
        const std::size_t want = serialScan(states, starts[e], starts[e + 1], order);
        EXPECT_EQ(cube::checkMotion(w.manager, body, edge, order, o), want);
        std::atomic<std::size_t> calls{0};
        const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
          ++calls;
          for (std::size_t l = 0; l < body.size(); ++l) out[l] = edge[k * body.size() + l];
        };
        const std::size_t n = edge.size() / body.size();
        EXPECT_EQ(cube::checkMotion(w.manager, body, n, pose_of, order, o), want);
        EXPECT_LE(calls.load(), n);
        // On one thread, the states computed past the answer (at rank r of the order) are
        // fewer than those before it: at most 2 r + 3 in all, all of them for a free edge.
        if (t == 1) {
          const std::vector<std::size_t> visit = visitOrder(n, order);
          const std::size_t rank =
              std::size_t(std::find(visit.begin(), visit.end(), want) - visit.begin());
          if (want == cube::kNoIndex)
            EXPECT_EQ(calls.load(), n);
          else
            EXPECT_LE(calls.load(), std::min(n, std::max<std::size_t>(5, 2 * rank + 3)));
          EXPECT_GE(calls.load(), want == cube::kNoIndex ? n : rank + 1);
        }
      }
    }
  // The scene must exercise both answers (ThreadSanitizer's clang build met 28 of 30).
  EXPECT_GT(edges_hit, 3u);
  EXPECT_LT(edges_hit, starts.size());
}

// The posed boxes of the links (AVX2 where the CPU has it) equal the portable version bit for
// bit, and the exact box: c = R mid + t, h = |R| half.
TEST(Batch, PoseBoxesKernelsAgree) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5, 5), pos(0, 2);
  for (const std::size_t n :
       {std::size_t(1), std::size_t(3), std::size_t(4), std::size_t(30), std::size_t(33)}) {
    std::vector<fcl::Transform3d> poses;
    std::vector<double> mid[3], half[3], c[2][3], h[2][3];
    for (std::size_t k = 0; k < n; ++k) {
      poses.push_back(randomPose(rng, 50));
      for (int d = 0; d < 3; ++d) {
        mid[d].push_back(u(rng));
        half[d].push_back(pos(rng));
      }
    }
    for (int v = 0; v < 2; ++v)
      for (int d = 0; d < 3; ++d) {
        c[v][d].assign(n, 0);
        h[v][d].assign(n, 0);
      }
    const auto io = [&](int v) {
      return cube::detail::PoseBoxes<double>{{mid[0].data(), mid[1].data(), mid[2].data()},
                                             {half[0].data(), half[1].data(), half[2].data()},
                                             {c[v][0].data(), c[v][1].data(), c[v][2].data()},
                                             {h[v][0].data(), h[v][1].data(), h[v][2].data()}};
    };
    cube::detail::poseBoxes(poses.data()->data(), n, io(0));
    cube::detail::poseBoxesPortable(poses.data()->data(), n, io(1));
    for (std::size_t k = 0; k < n; ++k) {
      const fcl::Vector3d m(mid[0][k], mid[1][k], mid[2][k]),
          hf(half[0][k], half[1][k], half[2][k]);
      const fcl::Vector3d want_c = poses[k].linear() * m + poses[k].translation();
      const fcl::Vector3d want_h = poses[k].linear().cwiseAbs() * hf;
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(c[0][d][k], c[1][d][k]);
        EXPECT_EQ(h[0][d][k], h[1][d][k]);
        EXPECT_NEAR(c[0][d][k], want_c[d], 1e-9);
        EXPECT_NEAR(h[0][d][k], want_h[d], 1e-9);
      }
    }
  }
}

TEST(Batch, BadInputChangesNothing) {
  World w;
  fillWorld(w, 50, 3, false, false);
  cube::BodySet<S> body = randomBody(3, 1, false);
  const auto poses = randomStates(4, 3, 1);
  EXPECT_THROW(body.addLink(nullptr), std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Planed>(fcl::Vector3d(0, 0, 1), 0)),
               std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Halfspaced>(fcl::Vector3d(0, 0, 1), 0)),
               std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Sphered>(1), -1.0), std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Sphered>(1), std::nan("")),
               std::invalid_argument);
  EXPECT_THROW(body.allowPair(0, 3), std::invalid_argument);
  EXPECT_THROW(body.allowPair(1, 1), std::invalid_argument);
  EXPECT_EQ(body.size(), 3u);
  EXPECT_TRUE(body.checked(0, 2));
  EXPECT_FALSE(body.checked(0, 1));
  auto wrong = poses;
  wrong.pop_back();
  EXPECT_THROW(cube::checkStates(w.manager, body, wrong), std::invalid_argument);
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    auto nan = poses;
    nan[5].translation()[1] = bad;
    EXPECT_THROW(cube::checkStates(w.manager, body, nan), std::invalid_argument);
    nan = poses;
    nan[2].linear()(1, 2) = bad;
    EXPECT_THROW(cube::checkMotion(w.manager, body, nan), std::invalid_argument);
  }
  EXPECT_THROW(cube::checkStates(w.manager, cube::BodySet<S>(), poses), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {1, 2}), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {0, 2, 2}), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {0, 4}), std::invalid_argument);
  // Motions: a bad pose throws where the serial scan meets it, before the first collision.
  {
    const auto more = randomStates(300, 3, 9);
    const auto r = cube::checkStates(w.manager, body, more);
    std::size_t hit = cube::kNoIndex, free_state = cube::kNoIndex;
    for (std::size_t k = 0; k < r.size(); ++k) (r[k].colliding ? hit : free_state) = k;
    ASSERT_NE(hit, cube::kNoIndex);
    ASSERT_NE(free_state, cube::kNoIndex);
    auto nan = more;
    nan[0].translation()[0] = std::nan("");
    std::vector<fcl::Transform3d> edge;
    for (const std::size_t k : {hit, std::size_t(0)})  // a collision, then the bad state
      edge.insert(edge.end(), (k == 0 ? nan : more).begin() + k * 3,
                  (k == 0 ? nan : more).begin() + k * 3 + 3);
    EXPECT_EQ(cube::checkMotion(w.manager, body, edge), 0u);
    edge.clear();
    for (const std::size_t k : {free_state, std::size_t(0)})  // free, then the bad state
      edge.insert(edge.end(), (k == 0 ? nan : more).begin() + k * 3,
                  (k == 0 ? nan : more).begin() + k * 3 + 3);
    EXPECT_THROW(cube::checkMotion(w.manager, body, edge), std::invalid_argument);
    EXPECT_THROW(cube::checkMotion(w.manager, body, 3, cube::PoseFunction<S>()),
                 std::invalid_argument);
    EXPECT_THROW(
        cube::checkMotion(w.manager, cube::BodySet<S>(), 3, [](std::size_t, fcl::Transform3d*) {}),
        std::invalid_argument);
  }
  // Still usable, same answers as before the errors.
  cube::BatchOptions o;
  o.first_pair = true;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o);
  EXPECT_TRUE(cube::checkStates(w.manager, body, {}).empty());
  EXPECT_EQ(cube::checkMotion(w.manager, body, {}), cube::kNoIndex);
  // States with no edge belong to none: refused. No states and no edges: nothing to answer.
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {}), std::invalid_argument);
  EXPECT_TRUE(cube::checkMotions(w.manager, body, {}, {}).empty());
}

// A negative thread count means the hardware's, as 0 does, with the same answers as one thread.
TEST(Batch, NegativeThreadCountsMeanTheHardwares) {
  World w;
  fillWorld(w, 300, 8, false, false);
  const cube::BodySet<S> body = randomBody(6, 2, false);
  const auto poses = randomStates(400, body.size(), 3);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  const auto one = cube::checkStates(w.manager, body, poses, o);
  std::vector<std::size_t> starts;
  for (std::size_t k = 0; k < one.size(); k += 25) starts.push_back(k);
  const auto one_edges =
      cube::checkMotions(w.manager, body, poses, starts, cube::MotionOrder::bisection, o);
  for (const int t : {-1, -8, 0}) {
    o.threads = t;
    const auto got = cube::checkStates(w.manager, body, poses, o);
    ASSERT_EQ(got.size(), one.size());
    for (std::size_t k = 0; k < one.size(); ++k) {
      EXPECT_EQ(got[k].colliding, one[k].colliding);
      EXPECT_EQ(got[k].link, one[k].link);
      EXPECT_EQ(got[k].object, one[k].object);
    }
    EXPECT_EQ(cube::checkMotions(w.manager, body, poses, starts, cube::MotionOrder::bisection, o),
              one_edges);
  }
}

TEST(Batch, APredicateThatMutatesTheWorldIsRefused) {
  World w;
  fillWorld(w, 300, 8, false, false);
  const cube::BodySet<S> body = randomBody(4, 2, false);
  const auto poses = randomStates(40, 4, 3);
  Object extra(std::make_shared<fcl::Sphered>(1));
  extra.computeAABB();
  w.manager.setPairFilter([&](Object*, Object*) {
    w.manager.registerObject(&extra);
    return true;
  });
  for (const int t : {1, 2}) {
    cube::BatchOptions o;
    o.threads = t;
    EXPECT_THROW(cube::checkStates(w.manager, body, poses, o), std::logic_error);
  }
  w.manager.setPairFilter(nullptr);
  EXPECT_EQ(w.manager.size(), 300u);
  std::string why;
  EXPECT_TRUE(w.manager.validate(&why)) << why;
}

// ThreadSanitizer runs this one (.ci/run): batches on two threads while other threads query the
// same world.
TEST(Batch, ThreadsWithConcurrentReadersOfTheWorld) {
  World w;
  fillWorld(w, 500, 12, false, true);
  const cube::BodySet<S> body = randomBody(6, 4, false);
  const auto poses = randomStates(64, body.size(), 6);
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  const auto expected = cube::checkStates(w.manager, body, poses, o);
  o.threads = 2;
  std::atomic<bool> stop{false};
  std::atomic<std::size_t> reads{0};
  std::thread reader([&] {
    Object q(std::make_shared<fcl::Sphered>(2));
    q.computeAABB();
    while (!stop.load()) {
      fcl::DefaultCollisionData<S> d;
      w.manager.collide(&q, &d, fcl::DefaultCollisionFunction<S>);
      reads.fetch_add(1);
    }
  });
  // Until the reader has queried during several batches.
  for (int round = 0; round < 3 || (reads.load() < 20 && round < 100000); ++round) {
    const auto got = cube::checkStates(w.manager, body, poses, o);
    for (std::size_t k = 0; k < got.size(); ++k) EXPECT_EQ(got[k].colliding, expected[k].colliding);
  }
  stop.store(true);
  reader.join();
  EXPECT_GT(reads.load(), 0u);
}

}  // namespace
