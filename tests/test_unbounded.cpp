// Unbounded and huge objects: planes and halfspaces (AABBs of +-max), rotated or not,
// mixed with boxes, spheres and an OcTree spanning the scene. Every query kind must report what
// fcl::NaiveCollisionManager reports, and objects crossing between the cubes and the unbounded
// list must keep working.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/narrow_phase.h"
#include "cube_collision/queries.h"
#include "support/oracle.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Manager = cube::CubeCollisionManager<S>;
using Base = fcl::BroadPhaseCollisionManager<S>;
using Pair = cube::oracle::Pair<S>;

bool isPlanar(const Object* o) {
  return o->getNodeType() == fcl::GEOM_PLANE || o->getNodeType() == fcl::GEOM_HALFSPACE;
}

using cube::oracle::narrowCollide;
using cube::oracle::narrowDistance;

bool record(Object* a, Object* b, void* d) {
  static_cast<std::vector<Pair>*>(d)->emplace_back(a, b);
  return false;
}

std::vector<Pair> sorted(std::vector<Pair> v) {
  std::sort(v.begin(), v.end());
  return v;
}

std::vector<Object*> objectsOf(const Base& m) {
  std::vector<Object*> out;
  m.getObjects(out);
  return out;
}

// Brute-force candidate pairs (a of `as`, b of `bs`), a != b, as ordered pairs.
std::vector<Pair> brutePairs(const std::vector<Object*>& as, const std::vector<Object*>& bs) {
  std::vector<Pair> out;
  for (auto* a : as)
    for (auto* b : bs)
      if (a != b && a->getAABB().overlap(b->getAABB())) out.emplace_back(a, b);
  std::sort(out.begin(), out.end());
  return out;
}

// Every query kind of `m` (holding `objs`) against brute force and Naive.
void expectLikeNaive(const Manager& m, const std::vector<Object*>& objs,
                     const std::vector<Object*>& queries) {
  std::string why;
  ASSERT_TRUE(m.validate(&why)) << why;
  ASSERT_EQ(objectsOf(m), objs);
  fcl::NaiveCollisionManager<S> naive;
  naive.registerObjects(objs);

  // Self collide: candidates and narrow phase.
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(objs));
  std::vector<Pair> ours, theirs;
  m.collide(&ours, narrowCollide<S>);
  naive.collide(&theirs, narrowCollide<S>);
  EXPECT_EQ(sorted(ours), sorted(theirs));

  // Self distance.
  S a = std::numeric_limits<S>::max(), b = a;
  m.distance(&a, narrowDistance<S>);
  naive.distance(&b, narrowDistance<S>);
  EXPECT_NEAR(a, b, 1e-9);

  for (Object* q : queries) {
    std::vector<Pair> got;
    m.collide(q, &got, record);
    std::vector<Pair> want;
    for (const auto& p : brutePairs(objs, {q})) want.push_back(p);
    EXPECT_EQ(sorted(got), want) << "collide(obj)";
    std::vector<Pair> n_ours, n_theirs;
    m.collide(q, &n_ours, narrowCollide<S>);
    for (const auto& p : want) narrowCollide<S>(p.first, p.second, &n_theirs);
    EXPECT_EQ(sorted(n_ours), sorted(n_theirs)) << "collide(obj) narrow phase";

    S da = std::numeric_limits<S>::max(), db = da;
    m.distance(q, &da, narrowDistance<S>);
    // Naive's distance(obj) also visits q itself (distance 0) when registered: leave it out.
    fcl::NaiveCollisionManager<S> others;
    for (auto* o : objs)
      if (o != q) others.registerObject(o);
    others.distance(q, &db, narrowDistance<S>);
    EXPECT_NEAR(da, db, 1e-9) << "distance(obj)";
  }
}

// Manager against manager, both directions where the other is a cube manager.
void expectPairsWith(const Manager& m, Base& other, const std::vector<Object*>& objs) {
  if (&other == &m) {
    // With itself: the self-collide pairs, each once.
    std::vector<Pair> got;
    m.collide(&other, &got, record);
    for (auto& p : got) p = cube::oracle::unordered(p.first, p.second);
    EXPECT_EQ(sorted(got), cube::oracle::bruteSelfPairs(objs)) << "collide(itself)";
    return;
  }
  const std::vector<Object*> theirs = objectsOf(other);
  std::vector<Pair> got;
  m.collide(&other, &got, record);
  EXPECT_EQ(sorted(got), brutePairs(objs, theirs)) << "collide(manager)";
  std::vector<Pair> n_ours, n_naive;
  m.collide(&other, &n_ours, narrowCollide<S>);
  fcl::NaiveCollisionManager<S> a, b;
  a.registerObjects(objs);
  b.registerObjects(theirs);
  a.collide(&b, &n_naive, [](Object* x, Object* y, void* d) {
    return x != y && narrowCollide<S>(x, y, d);  // Naive also pairs an object with itself
  });
  EXPECT_EQ(sorted(n_ours), sorted(n_naive)) << "collide(manager) narrow phase";
  S da = std::numeric_limits<S>::max(), db = da;
  m.distance(&other, &da, narrowDistance<S>);
  a.distance(&b, &db, [](Object* x, Object* y, void* d, S& dist) {
    return x != y && narrowDistance<S>(x, y, d, dist);
  });
  EXPECT_NEAR(da, db, 1e-9) << "distance(manager)";
  if (auto* cube = dynamic_cast<Manager*>(&other)) {
    std::vector<Pair> back;
    cube->collide(const_cast<Manager*>(&m), &back, record);
    EXPECT_EQ(sorted(back), brutePairs(theirs, objs)) << "reverse collide(manager)";
    S dr = std::numeric_limits<S>::max();
    cube->distance(const_cast<Manager*>(&m), &dr, narrowDistance<S>);
    EXPECT_NEAR(dr, db, 1e-9) << "reverse distance(manager)";
  }
}

struct Scene {
  std::vector<std::unique_ptr<Object>> owned;
  Object* add(std::shared_ptr<fcl::CollisionGeometry<S>> g, const fcl::Transform3<S>& tf) {
    owned.push_back(std::make_unique<Object>(std::move(g), tf));
    owned.back()->computeAABB();
    return owned.back().get();
  }
  std::vector<Object*> all() const {
    std::vector<Object*> out;
    for (const auto& o : owned) out.push_back(o.get());
    return out;
  }
};

fcl::Transform3<S> pose(double x, double y, double z, double angle = 0,
                        fcl::Vector3<S> axis = fcl::Vector3<S>::UnitZ()) {
  fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
  tf.translation() = fcl::Vector3<S>(x, y, z);
  tf.linear() = Eigen::AngleAxis<S>(angle, axis.normalized()).toRotationMatrix();
  return tf;
}

// Boxes and spheres scattered in [-20, 20]^3, plus planes and halfspaces, axis-aligned and
// rotated, and (optionally) an OcTree of occupied cells along a diagonal of the whole scene.
Scene mixedScene(std::uint32_t seed, int shapes, bool octree) {
  Scene s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-20, 20), size(0.5, 4), ang(0, 3.1);
  for (int i = 0; i < shapes; ++i) {
    const auto tf = pose(u(rng), u(rng), u(rng), ang(rng), fcl::Vector3<S>(u(rng), u(rng), 1));
    if (i % 2)
      s.add(std::make_shared<fcl::Box<S>>(size(rng), size(rng), size(rng)), tf);
    else
      s.add(std::make_shared<fcl::Sphere<S>>(size(rng) / 2), tf);
  }
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 0, 1), 1.5), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(1, 0, 0), -3), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(1, 1, 1).normalized(), 4), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 1, 0), 0),
        pose(2, 5, 0, 0.7, fcl::Vector3<S>(1, 0, 1)));
  s.add(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 0, 1), -15), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, -1, 0), -18), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(1, 0, 0), 0),
        pose(0, 0, 0, 0.4, fcl::Vector3<S>(0, 1, 1)));
  if (octree) {
    auto tree = std::make_shared<octomap::OcTree>(1.0);
    for (double t = -20; t <= 20; t += 1) tree->updateNode(octomap::point3d(t, t, 0), true);
    s.add(std::make_shared<fcl::OcTree<S>>(tree), pose(0, 0, 0));
  }
  return s;
}

TEST(Unbounded, PlanesAndHalfspacesStayOutOfTheCubes) {
  Scene s = mixedScene(1, 40, false);
  Manager m;
  m.registerObjects(s.all());
  EXPECT_EQ(::cube::detail::coreOf(m).unboundedItems().size(), 7u);
  for (const auto& it : ::cube::detail::coreOf(m).unboundedItems()) EXPECT_TRUE(isPlanar(it.obj));
  // The cubes stay the size of the bounded scene, not of the planes.
  const auto& root =
      ::cube::detail::coreOf(m).tree().nodes()[::cube::detail::coreOf(m).tree().root()];
  for (int k = 0; k < 3; ++k) EXPECT_LT(root.hi[k] - root.lo[k], 100.f);
  expectLikeNaive(m, s.all(), s.all());
}

class MixedScenes : public ::testing::TestWithParam<std::uint32_t> {};

TEST_P(MixedScenes, EveryQueryKindLikeNaive) {
  const bool octree = GetParam() % 2 == 0;
  Scene s = mixedScene(GetParam(), 60, octree);
  Scene extra = mixedScene(GetParam() + 100, 20, false);
  for (int leaf_size : {1, 4}) {
    cube::Config config;
    config.leaf_size = leaf_size;
    Manager m(config);
    // Registered one by one: the incremental path must sort planes out too.
    for (auto* o : s.all()) m.registerObject(o);
    expectLikeNaive(m, s.all(), extra.all());

    // Other managers, made of the extra objects and some of ours.
    std::vector<Object*> mix = extra.all();
    for (std::size_t i = 0; i < s.owned.size(); i += 3) mix.push_back(s.owned[i].get());
    fcl::NaiveCollisionManager<S> naive;
    naive.registerObjects(mix);
    fcl::DynamicAABBTreeCollisionManager<S> dyn;
    for (auto* o : mix) dyn.registerObject(o);
    Manager cube;
    cube.registerObjects(mix);
    {
      SCOPED_TRACE("vs Naive");
      expectPairsWith(m, naive, s.all());
    }
    {
      SCOPED_TRACE("vs DynamicAABBTree");
      expectPairsWith(m, dyn, s.all());
    }
    {
      SCOPED_TRACE("vs cube");
      expectPairsWith(m, cube, s.all());
    }
    expectPairsWith(m, m, s.all());
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, MixedScenes, ::testing::Range<std::uint32_t>(1, 7));

TEST(Unbounded, ObjectsCrossBetweenCubesAndUnboundedList) {
  Scene s = mixedScene(7, 30, false);
  std::vector<Object*> objs = s.all();
  for (auto policy :
       {cube::UpdatePolicy::automatic, cube::UpdatePolicy::refit, cube::UpdatePolicy::rebuild}) {
    cube::Config config;
    config.update_policy = policy;
    Manager m(config);
    m.registerObjects(objs);
    const std::size_t planes = std::count_if(objs.begin(), objs.end(), isPlanar);
    std::mt19937 rng(3);
    for (int round = 0; round < 12; ++round) {
      // A few boxes jump beyond the unbounded limit (1e16 > 1e15), others come back.
      std::vector<Object*> moved;
      for (int i = 0; i < 4; ++i) {
        Object* o = s.owned[rng() % 30].get();
        const bool far = rng() % 2;
        o->setTranslation(far ? fcl::Vector3<S>(1e16, 0, 0)
                              : fcl::Vector3<S>(double(rng() % 40) - 20, 0, 0));
        o->computeAABB();
        moved.push_back(o);
      }
      switch (round % 3) {
        case 0:
          for (auto* o : moved) m.update(o);
          break;
        case 1:
          m.update(moved);
          break;
        default:
          m.update();
      }
      std::size_t far_count = 0;
      for (std::size_t i = 0; i < 30; ++i) far_count += s.owned[i]->getAABB().max_[0] > 1e15;
      EXPECT_EQ(::cube::detail::coreOf(m).unboundedItems().size(), planes + far_count);
      expectLikeNaive(m, objs, {s.owned[0].get(), s.owned[31].get()});
      // And in and out of the manager altogether.
      m.unregisterObject(moved[0]);
      objs.erase(std::find(objs.begin(), objs.end(), moved[0]));
      expectLikeNaive(m, objs, {});
      m.registerObject(moved[0]);
      objs.push_back(moved[0]);
      expectLikeNaive(m, objs, {});
    }
  }
}

// Cylinders and cones over a plane or halfspace whose normal is n (unit), placed `count` at a
// time on a grid in the plane (spacing 12: only shape-plane pairs meet) their lowest points -1 .. 2
// off it, tilted at random, each with its own geometry (contacts name geometries).
struct RoundShapes {
  std::vector<std::unique_ptr<Object>> shapes;
  std::unique_ptr<Object> flat;
};

RoundShapes roundShapesOver(bool halfspace, bool cones, const fcl::Vector3<S>& n, S d,
                            std::uint32_t seed, int count) {
  RoundShapes out;
  if (halfspace)
    out.flat = std::make_unique<Object>(std::make_shared<fcl::Halfspace<S>>(n, d));
  else
    out.flat = std::make_unique<Object>(std::make_shared<fcl::Plane<S>>(n, d));
  out.flat->computeAABB();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> radius(0.2, 1.0), length(0.5, 3.0), off(-1.0, 2.0);
  std::normal_distribution<double> g;
  const fcl::Vector3<S> e1 = n.unitOrthogonal(), e2 = n.cross(e1);
  const int side = int(std::ceil(std::sqrt(double(count))));
  for (int i = 0; i < count; ++i) {
    const double r = radius(rng), lz = length(rng);
    std::shared_ptr<fcl::CollisionGeometry<S>> geo;
    if (cones)
      geo = std::make_shared<fcl::Cone<S>>(r, lz);
    else
      geo = std::make_shared<fcl::Cylinder<S>>(r, lz);
    const fcl::Matrix3<S> R =
        fcl::Quaternion<S>(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    // The centre `off` plus the shape's reach below it off the plane: the lowest point is then
    // within -1 .. 2 of the plane, across FCL's wrong band of up to lz / 2.
    const fcl::Vector3<S> axis = R.col(2);
    const S an = axis.dot(n);
    const S reach = std::abs(an) * S(lz / 2) + S(r) * std::sqrt(std::max(S(0), 1 - an * an));
    const fcl::Vector3<S> centre =
        n * d + e1 * S(12 * (i % side)) + e2 * S(12 * (i / side)) + n * (S(off(rng)) + reach);
    out.shapes.push_back(std::make_unique<Object>(geo, R, centre));
    out.shapes.back()->computeAABB();
  }
  return out;
}

// The lowest point of a shape along n: a cylinder's centre . n - |axis . n| h/2 - r sqrt(1 -
// (axis . n)^2); a cone's the lower of its apex (centre + axis h/2) and that of its base rim
// (centre - axis h/2). The highest: the lowest along -n, negated.
S lowestAlong(const Object& o, const fcl::Vector3<S>& n) {
  const fcl::Vector3<S> c = o.getTranslation(), axis = o.getRotation().col(2);
  const S an = axis.dot(n), rim = std::sqrt(std::max(S(0), 1 - an * an));
  if (o.getNodeType() == fcl::GEOM_CYLINDER) {
    const auto& k = static_cast<const fcl::Cylinder<S>&>(*o.collisionGeometry());
    return c.dot(n) - std::abs(an) * k.lz / 2 - k.radius * rim;
  }
  const auto& k = static_cast<const fcl::Cone<S>&>(*o.collisionGeometry());
  return std::min((c + axis * (k.lz / 2)).dot(n), (c - axis * (k.lz / 2)).dot(n) - k.radius * rim);
}

// FCL 0.7's yes/no cylinder-plane test projects lz where lz/2 belongs, and its cone-halfspace
// test takes a cone whose apex points into the halfspace for one lying on its side: the library
// answers these pairs from the geometry (queries.h). 4,000 tilted cylinders and cones over the
// plane z = 0 and the halfspace z <= 0, and over a tilted plane 1000 units from the origin,
// through collideAll (with and without contact geometry), collidePairs and the default collision
// callback, against the lowest and highest points along the normal; with contacts, the depth,
// normal and position FCL's contact-computing tests give where they are right.
TEST(Unbounded, CylindersAndConesAgainstPlanesGetTheTrueAnswer) {
  const fcl::Vector3<S> tilted = fcl::Vector3<S>(1, -2, 2).normalized();
  std::size_t hits = 0, misses = 0;
  for (const bool halfspace : {false, true})
    for (const bool cones : {false, true})
      for (const bool far : {false, true}) {
        const fcl::Vector3<S> n = far ? tilted : fcl::Vector3<S>(0, 0, 1);
        const S d = far ? S(1000) : S(0);
        const RoundShapes scene =
            roundShapesOver(halfspace, cones, n, d, 5 + halfspace + 2 * cones, 4000);
        const std::string what = std::string(cones ? "cones" : "cylinders") +
                                 (halfspace ? " / halfspace" : " / plane") + (far ? " far" : "");
        // The truth for each shape: touching, and the contact's depth and normal from the shape.
        std::map<const fcl::CollisionGeometry<S>*, std::size_t> index;
        std::vector<bool> truth;
        std::vector<S> lo, hi;
        for (std::size_t i = 0; i < scene.shapes.size(); ++i) {
          const Object& o = *scene.shapes[i];
          index[o.collisionGeometry().get()] = i;
          lo.push_back(lowestAlong(o, n) - d);
          hi.push_back(-lowestAlong(o, -n) - d);
          truth.push_back(halfspace ? lo[i] <= 0 : lo[i] <= 0 && hi[i] >= 0);
          hits += truth[i];
          misses += !truth[i];
        }
        Manager m;
        m.registerObject(scene.flat.get());
        for (const auto& o : scene.shapes) m.registerObject(o.get());
        m.setup();
        for (const bool contact : {false, true}) {
          fcl::CollisionRequest<S> req(100000, contact);
          const auto check = [&](const fcl::CollisionResult<S>& r, const char* how) {
            std::vector<bool> got(truth.size(), false);
            for (std::size_t k = 0; k < r.numContacts(); ++k) {
              const fcl::Contact<S>& c = r.getContact(k);
              const bool shape_first = c.o1 != scene.flat->collisionGeometry().get();
              const std::size_t i = index.at(shape_first ? c.o1 : c.o2);
              got[i] = true;
              if (!contact || !truth[i]) continue;
              // Pushed out through the nearer side: the halfspace's boundary, or the plane's
              // side that needs the lesser push.
              const bool push_up = halfspace || -lo[i] <= hi[i];
              const S depth = push_up ? -lo[i] : hi[i];
              if (!halfspace && std::abs(-lo[i] - hi[i]) < 1e-9) continue;  // a tie: either side
              const fcl::Vector3<S> from_shape = push_up ? fcl::Vector3<S>(-n) : n;
              EXPECT_NEAR(c.penetration_depth, depth, 1e-9) << what << " " << how << " " << i;
              EXPECT_NEAR(
                  (c.normal - (shape_first ? from_shape : fcl::Vector3<S>(-from_shape))).norm(), 0,
                  1e-9)
                  << what << " " << how << " " << i;
              // On the plane; a halfspace's half the depth below its boundary.
              const S at = n.dot(c.pos) - d;
              EXPECT_NEAR(at, halfspace ? lo[i] / 2 : S(0), 1e-8) << what << " " << how << " " << i;
            }
            std::size_t wrong = 0;
            for (std::size_t i = 0; i < truth.size(); ++i) wrong += got[i] != truth[i];
            EXPECT_EQ(wrong, 0u) << what << " " << how << (contact ? " with contacts" : "");
          };
          check(cube::collideAll<S>(m, req), "collideAll");
          fcl::CollisionResult<S> merged;
          for (const auto& r : cube::collidePairs<S>(cube::overlappingPairs<S>(m), req))
            for (std::size_t k = 0; k < r.numContacts(); ++k) merged.addContact(r.getContact(k));
          check(merged, "collidePairs");
          cube::CollisionData<S> data;
          data.request = req;
          m.collide(&data, cube::defaultCollisionCallback<S>);
          check(data.result, "default callback");
        }
      }
  EXPECT_GT(hits, 4000u);
  EXPECT_GT(misses, 4000u);
}

TEST(Unbounded, OnlyUnboundedObjects) {
  Scene s;
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 0, 1), 0), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 0, 1), 5), pose(0, 0, 0));
  s.add(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 1, 1).normalized(), 0),
        pose(0, 0, 0));
  Manager m;
  m.registerObjects(s.all());
  EXPECT_EQ(::cube::detail::coreOf(m).unboundedItems().size(), 3u);
  expectLikeNaive(m, s.all(), s.all());
  Manager empty;
  expectPairsWith(m, empty, s.all());
  expectPairsWith(empty, m, {});
}

// The callback order after the first setup() depends on the live registrations alone
// (docs/guarantees.md, point 11): a manager that had a plane registered and removed before
// its first setup() calls back in the same order as one that never had it, for a self-collide,
// an object query and a manager query (a removal used to leave the unbounded
// list in swap order).
TEST(Unbounded, OrderAfterTheFirstSetupIgnoresRemovedObjects) {
  Scene s = mixedScene(38, 300, false);
  Scene extra;
  Object* gone =
      extra.add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 1, 0), 2), pose(0, 0, 0));
  Object* probe = extra.add(std::make_shared<fcl::Box<S>>(8, 8, 8), pose(1, 2, 1.5));
  const auto calls = [&](const Manager& m) {
    struct Rec {
      std::vector<Pair> seen;
      static bool fn(Object* a, Object* b, void* d) {
        static_cast<Rec*>(d)->seen.emplace_back(a, b);
        return false;
      }
    } r;
    m.collide(&r, &Rec::fn);
    m.collide(probe, &r, &Rec::fn);
    Manager other;
    other.registerObject(probe);
    m.collide(&other, &r, &Rec::fn);
    return r.seen;
  };
  for (const bool batch : {false, true}) {
    Manager plain, churned;
    std::vector<Object*> with = s.all();
    with.insert(with.begin(), gone);  // registered first: the front of the unbounded list
    if (batch) {
      plain.registerObjects(s.all());
      churned.registerObjects(with);
    } else {
      for (Object* o : s.all()) plain.registerObject(o);
      for (Object* o : with) churned.registerObject(o);
    }
    churned.unregisterObject(gone);
    plain.setup();
    churned.setup();
    std::string why;
    ASSERT_TRUE(churned.validate(&why)) << why;
    ASSERT_GE(::cube::detail::coreOf(plain).unboundedItems().size(), 3u);
    const auto a = calls(plain), b = calls(churned);
    ASSERT_GT(a.size(), 300u);
    EXPECT_TRUE(a == b) << "batch " << batch << ": the call orders differ";
  }
}

}  // namespace
