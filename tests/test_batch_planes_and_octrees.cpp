// The batch against world objects FCL 0.7 answers apart or wrongly: tilted planes and halfspaces
// (the exact gap, plane_brute.h), cylinders and cones over planes, and octrees (FCL's distance).

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

}  // namespace
