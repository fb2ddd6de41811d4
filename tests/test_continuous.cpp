// Swept boxes and continuous collision (continuous.h) against brute force over every pair of
// objects: the swept-box pairs against a double loop, the boxes against the poses FCL's motions
// visit, the continuous helper against fcl::continuousCollide on every pair.
//
// Shapes: the scene generators' boxes, spheres and cylinders (primitives and OBBRSS meshes), plus
// halfspaces for the box tests only. fcl::continuousCollide is run with its naive solver (the one
// the helper accepts), which is fcl::collide at sampled times: it answers every pair of these.
// Float: sweptPairs and sweptBox only; FCL 0.7's float continuousCollide does not compile.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/math/motion/screw_motion.h>
#include <fcl/math/motion/translation_motion.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/continuous_collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

#include "cube_collision/continuous.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace {

template <typename S>
using Obj = fcl::CollisionObject<S>;
template <typename S>
using Pairs = std::vector<std::pair<Obj<S>*, Obj<S>*>>;

template <typename S>
fcl::Matrix3<S> randomRotation(std::mt19937& rng, double max_angle) {
  std::normal_distribution<double> g(0, 1);
  fcl::Vector3d axis(g(rng), g(rng), g(rng));
  axis.normalize();
  const double angle = std::uniform_real_distribution<double>(0, max_angle)(rng);
  return fcl::AngleAxis<double>(angle, axis).toRotationMatrix().cast<S>();
}

// A world: a scene's objects (some halfspaces added if asked), registered in a shuffled order
// with some unregistered and registered again, so that registration order is not creation order.
template <typename S>
struct World {
  cube::scenes::Scene<S> scene;
  std::vector<std::unique_ptr<Obj<S>>> extra;
  cube::CubeCollisionManager<S> manager;
  std::vector<Obj<S>*> registered;  // registration order
  double size = 1;

  World(std::size_t n, std::uint32_t seed, bool meshes, cube::scenes::Layout layout,
        bool halfspaces) {
    cube::scenes::SceneOptions o;
    o.n = n;
    o.seed = seed;
    o.meshes = meshes;
    o.layout = layout;
    o.half_extent = 200;
    o.overlaps_per_object = 1.0;
    scene = cube::scenes::makeScene<S>(o);
    size = cube::scenes::typicalSize(o);
    std::vector<Obj<S>*> all = scene.pointers();
    if (halfspaces) {
      for (int k = 0; k < 2; ++k) {
        auto g = std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(S(k), S(1 - k), 0), S(-150));
        extra.push_back(std::make_unique<Obj<S>>(g));
        extra.back()->computeAABB();
        all.push_back(extra.back().get());
      }
    }
    std::mt19937 rng(seed);
    std::shuffle(all.begin(), all.end(), rng);
    manager.registerObjects(all);
    for (std::size_t i = 0; i < all.size(); i += 7) manager.unregisterObject(all[i]);
    for (std::size_t i = 0; i < all.size(); i += 7) manager.registerObject(all[i]);
    EXPECT_TRUE(manager.validate());
    manager.getObjects(registered);
  }

  // Moves a `fraction` of the objects: a translation of up to `reach` typical sizes per axis and,
  // for most, a rotation of up to `max_angle`; some keep their rotation, a few barely turn.
  std::vector<cube::Motion<S>> motions(double fraction, double reach, double max_angle,
                                       std::uint32_t seed) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<cube::Motion<S>> out;
    for (Obj<S>* obj : registered) {
      if (u(rng) >= fraction) continue;
      fcl::Transform3<S> end = obj->getTransform();
      for (int k = 0; k < 3; ++k) end.translation()[k] += S((2 * u(rng) - 1) * reach * size);
      const double kind = u(rng);
      if (kind < 0.7)
        end.linear() = randomRotation<S>(rng, max_angle) * end.linear();
      else if (kind < 0.8)
        end.linear() = randomRotation<S>(rng, 1e-11) * end.linear();  // FCL's no-turn screw
      out.push_back({obj, end});
    }
    return out;
  }
};

template <typename S>
bool overlap(const fcl::AABB<S>& a, const fcl::AABB<S>& b) {
  return a.overlap(b);
}

// The double loop: every pair with a mover, in registration order, whose boxes overlap.
template <typename S>
Pairs<S> brutePairs(const World<S>& w, const std::vector<cube::Motion<S>>& motions,
                    fcl::CCDMotionType type) {
  const std::size_t n = w.registered.size();
  std::vector<fcl::AABB<S>> box(n);
  std::vector<char> moves(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    box[i] = w.registered[i]->getAABB();
    for (const auto& m : motions)
      if (m.object == w.registered[i]) {
        box[i] = cube::sweptBox(*m.object, m.end, type);
        moves[i] = 1;
      }
  }
  Pairs<S> out;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      if ((moves[i] || moves[j]) && overlap(box[i], box[j]))
        out.emplace_back(w.registered[i], w.registered[j]);
  return out;
}

template <typename S>
class SweptPairs : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(SweptPairs, Scalars);

TYPED_TEST(SweptPairs, EqualBruteForceOnRandomMotions) {
  using S = TypeParam;
  std::size_t checked = 0, found = 0;
  for (const bool meshes : {false, true}) {
    for (const auto layout : {cube::scenes::Layout::uniform, cube::scenes::Layout::clustered}) {
      for (std::uint32_t seed = 1; seed <= 3; ++seed) {
        World<S> w(meshes ? 150 : 400, seed, meshes, layout, /*halfspaces=*/seed == 2);
        for (const auto type : {fcl::CCDM_TRANS, fcl::CCDM_SCREW}) {
          for (const double fraction : {0.0, 0.1, 0.5, 1.0}) {
            const auto motions = w.motions(fraction, 3, M_PI, seed * 31 + 7);
            const Pairs<S> got = cube::sweptPairs(w.manager, motions, type);
            const Pairs<S> want = brutePairs(w, motions, type);
            ASSERT_EQ(got, want) << "seed " << seed << " type " << type << " fraction " << fraction
                                 << " meshes " << meshes;
            ++checked;
            found += got.size();
          }
        }
        ASSERT_TRUE(w.manager.validate());
      }
    }
  }
  EXPECT_EQ(checked, 2u * 2 * 3 * 2 * 4);
  EXPECT_GT(found, 1000u);  // the comparison is not between empty lists
}

// Every pose the FCL motion visits, sampled finely, keeps the geometry's box inside the swept box.
template <typename S>
class SweptBox : public ::testing::Test {};
TYPED_TEST_SUITE(SweptBox, Scalars);

TYPED_TEST(SweptBox, HoldsEveryPoseOfFCLsMotion) {
  using S = TypeParam;
  World<S> w(300, 5, false, cube::scenes::Layout::uniform, false);
  std::mt19937 rng(11);
  std::size_t poses = 0;
  for (const double max_angle : {M_PI, 1e-6, 3.14159}) {
    auto motions = w.motions(1.0, 4, max_angle, 3);
    // Exact half turns and pure translations too.
    for (std::size_t i = 0; i < motions.size(); i += 5) {
      fcl::Vector3<S> axis = fcl::Vector3<S>::Random().normalized();
      motions[i].end.linear() =
          fcl::AngleAxis<S>(S(M_PI), axis).toRotationMatrix() * motions[i].object->getRotation();
    }
    for (std::size_t i = 2; i < motions.size(); i += 5)
      motions[i].end.linear() = motions[i].object->getRotation();
    for (const auto type : {fcl::CCDM_TRANS, fcl::CCDM_SCREW}) {
      for (const auto& m : motions) {
        const fcl::AABB<S> swept = cube::sweptBox(*m.object, m.end, type);
        const fcl::AABB<S>& local = m.object->collisionGeometry()->aabb_local;
        const fcl::Vector3d c = ((local.min_ + local.max_) * 0.5).template cast<double>();
        const fcl::Vector3d e = ((local.max_ - local.min_) * 0.5).template cast<double>();
        const fcl::Transform3d tf1 = m.object->getTransform().template cast<double>();
        const fcl::Transform3d tf2 = m.end.template cast<double>();
        const fcl::MotionBasePtr<double> motion = fcl::getMotionBase(tf1, tf2, type);
        for (int i = 0; i <= 200; ++i) {
          const double t = i / 200.0;
          motion->integrate(t);
          fcl::Transform3d tf;
          motion->getCurrentTransform(tf);
          // The local AABB at this pose, as a world box: it holds the geometry.
          const fcl::Vector3d centre = tf * c;
          const fcl::Vector3d half = tf.linear().cwiseAbs() * e;
          for (int k = 0; k < 3; ++k) {
            ASSERT_LE(double(swept.min_[k]), centre[k] - half[k]) << "t " << t << " type " << type;
            ASSERT_GE(double(swept.max_[k]), centre[k] + half[k]) << "t " << t << " type " << type;
          }
          ++poses;
        }
      }
    }
  }
  EXPECT_GT(poses, 100000u);
  (void)rng;
}

TYPED_TEST(SweptBox, TranslationIsTheHullOfTheEndBoxes) {
  using S = TypeParam;
  // An axis-aligned box moving without turning: its swept box is the hull of the two end boxes
  // (up to the rounding pad), whatever rotation the end transform asks for (FCL keeps the start's).
  auto g = std::make_shared<fcl::Box<S>>(S(2), S(4), S(6));
  Obj<S> obj(g);
  fcl::Transform3<S> end = fcl::Transform3<S>::Identity();
  end.translation() = fcl::Vector3<S>(S(10), S(-20), S(5));
  end.linear() = fcl::AngleAxis<S>(S(1), fcl::Vector3<S>::UnitZ()).toRotationMatrix();
  const fcl::AABB<S> b = cube::sweptBox(obj, end, fcl::CCDM_TRANS);
  const S lo[3] = {-1, -22, -3}, hi[3] = {11, 2, 8};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(double(b.min_[k]), double(lo[k]), 1e-4);
    EXPECT_NEAR(double(b.max_[k]), double(hi[k]), 1e-4);
    EXPECT_LE(b.min_[k], lo[k]);
    EXPECT_GE(b.max_[k], hi[k]);
  }
}

// Conservative for collisions: no pair sweptPairs leaves out collides (fcl::collide) at any of
// many times of FCL's motions.
TEST(SweptPairsConservative, NoLeftOutPairCollidesAtAnySampledTime) {
  using S = double;
  std::size_t colliding_listed = 0, left_out = 0;
  for (std::uint32_t seed = 1; seed <= 2; ++seed) {
    World<S> w(120, seed, false, cube::scenes::Layout::clustered, false);
    for (const auto type : {fcl::CCDM_TRANS, fcl::CCDM_SCREW}) {
      const auto motions = w.motions(0.3, 3, M_PI, seed + 100);
      const Pairs<S> listed = cube::sweptPairs(w.manager, motions, type);
      const std::set<std::pair<Obj<S>*, Obj<S>*>> in(listed.begin(), listed.end());
      const std::size_t n = w.registered.size();
      std::vector<fcl::MotionBasePtr<S>> motion(n);
      for (std::size_t i = 0; i < n; ++i) {
        fcl::Transform3d end = w.registered[i]->getTransform();
        bool moves = false;
        for (const auto& m : motions)
          if (m.object == w.registered[i]) end = m.end, moves = true;
        if (moves) motion[i] = fcl::getMotionBase(w.registered[i]->getTransform(), end, type);
      }
      for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = i + 1; j < n; ++j) {
          if (!motion[i] && !motion[j]) continue;
          const bool listed_pair = in.count({w.registered[i], w.registered[j]}) > 0;
          bool collides = false;
          for (int s = 0; s <= 32 && !collides; ++s) {
            fcl::Transform3d ti = w.registered[i]->getTransform();
            fcl::Transform3d tj = w.registered[j]->getTransform();
            if (motion[i]) motion[i]->integrate(s / 32.0), motion[i]->getCurrentTransform(ti);
            if (motion[j]) motion[j]->integrate(s / 32.0), motion[j]->getCurrentTransform(tj);
            fcl::CollisionRequest<S> req;
            fcl::CollisionResult<S> res;
            collides = fcl::collide(w.registered[i]->collisionGeometry().get(), ti,
                                    w.registered[j]->collisionGeometry().get(), tj, req, res) > 0;
          }
          if (!listed_pair) {
            ++left_out;
            ASSERT_FALSE(collides) << "pair " << i << "," << j << " type " << type;
          } else if (collides) {
            ++colliding_listed;
          }
        }
      }
    }
  }
  EXPECT_GT(colliding_listed, 50u);  // the motions do make objects meet
  EXPECT_GT(left_out, 1000u);        // and the swept boxes do leave pairs out
}

// The helper equals fcl::continuousCollide over every pair with a mover, in the helper's order.
TEST(ContinuousCollideAll, EqualsFCLOverEveryPair) {
  using S = double;
  std::size_t contacts = 0, later = 0, runs = 0;
  for (const bool meshes : {false, true}) {
    for (std::uint32_t seed = 1; seed <= 2; ++seed) {
      World<S> w(meshes ? 60 : 150, seed, meshes, cube::scenes::Layout::clustered, false);
      for (const auto type : {fcl::CCDM_TRANS, fcl::CCDM_SCREW}) {
        for (const std::size_t iterations : {10u, 40u}) {
          fcl::ContinuousCollisionRequest<S> request;
          request.ccd_motion_type = type;
          request.num_max_iterations = iterations;
          const auto motions = w.motions(0.3, 3, M_PI, seed * 7 + 1);
          const std::size_t n = w.registered.size();
          std::vector<const fcl::Transform3d*> end(n, nullptr);
          for (std::size_t i = 0; i < n; ++i)
            for (const auto& m : motions)
              if (m.object == w.registered[i]) end[i] = &m.end;
          std::vector<cube::ContinuousContact> want;
          for (std::size_t i = 0; i < n; ++i) {
            for (std::size_t j = i + 1; j < n; ++j) {
              if (!end[i] && !end[j]) continue;
              Obj<S>* a = w.registered[i];
              Obj<S>* b = w.registered[j];
              fcl::ContinuousCollisionResult<S> r;
              fcl::continuousCollide(a, end[i] ? *end[i] : a->getTransform(), b,
                                     end[j] ? *end[j] : b->getTransform(), request, r);
              if (r.is_collide)
                want.push_back({a, b, r.time_of_contact, r.contact_tf1, r.contact_tf2});
            }
          }
          std::stable_sort(want.begin(), want.end(), [](const auto& x, const auto& y) {
            return x.time_of_contact < y.time_of_contact;
          });
          const auto got = cube::continuousCollideAll(w.manager, motions, request);
          ASSERT_EQ(got.size(), want.size()) << "seed " << seed << " type " << type;
          for (std::size_t k = 0; k < got.size(); ++k) {
            EXPECT_EQ(got[k].a, want[k].a);
            EXPECT_EQ(got[k].b, want[k].b);
            EXPECT_EQ(got[k].time_of_contact, want[k].time_of_contact);
            EXPECT_TRUE(got[k].tf_a.matrix() == want[k].tf_a.matrix());
            EXPECT_TRUE(got[k].tf_b.matrix() == want[k].tf_b.matrix());
            if (got[k].time_of_contact > 0) ++later;
          }
          const auto first = cube::continuousCollideAll(w.manager, motions, request, true);
          ASSERT_EQ(first.size(), want.empty() ? 0u : 1u);
          if (!want.empty()) {
            EXPECT_EQ(first[0].a, want[0].a);
            EXPECT_EQ(first[0].b, want[0].b);
            EXPECT_EQ(first[0].time_of_contact, want[0].time_of_contact);
          }
          contacts += got.size();
          ++runs;
        }
      }
      EXPECT_TRUE(w.manager.validate());
    }
  }
  EXPECT_EQ(runs, 2u * 2 * 2 * 2);
  EXPECT_GT(contacts, 100u);
  EXPECT_GT(later, 20u);  // contacts that happen during the motion, not at its start
}

template <typename S>
class ContinuousBadInput : public ::testing::Test {};
TYPED_TEST_SUITE(ContinuousBadInput, Scalars);

TYPED_TEST(ContinuousBadInput, ThrowsAndChangesNothing) {
  using S = TypeParam;
  World<S> w(50, 3, false, cube::scenes::Layout::uniform, false);
  Obj<S> stranger(std::make_shared<fcl::Box<S>>(S(1), S(1), S(1)));
  auto good = w.motions(0.5, 2, M_PI, 9);
  ASSERT_GE(good.size(), 2u);
  const auto before = cube::sweptPairs(w.manager, good);
  const auto nan = std::numeric_limits<S>::quiet_NaN();
  const auto expectThrow = [&](std::vector<cube::Motion<S>> motions) {
    EXPECT_THROW(cube::sweptPairs(w.manager, motions), std::invalid_argument);
    EXPECT_THROW(cube::sweptPairs(w.manager, motions, fcl::CCDM_SCREW), std::invalid_argument);
  };
  auto m = good;
  m[1].object = nullptr;
  expectThrow(m);
  m = good;
  m[1].object = &stranger;
  expectThrow(m);
  m = good;
  m.push_back(good[0]);
  expectThrow(m);
  m = good;
  m[1].end.translation()[2] = nan;
  expectThrow(m);
  m = good;
  m[0].end.linear()(1, 1) = std::numeric_limits<S>::infinity();
  expectThrow(m);
  {  // a NaN current transform
    Obj<S>* obj = good[0].object;
    const fcl::Transform3<S> saved = obj->getTransform();
    fcl::Transform3<S> bad = saved;
    bad.translation()[0] = nan;
    obj->setTransform(bad);
    expectThrow(good);
    EXPECT_THROW(cube::sweptBox(*obj, good[0].end), std::invalid_argument);
    obj->setTransform(saved);
  }
  for (const auto type : {fcl::CCDM_LINEAR, fcl::CCDM_SPLINE}) {
    EXPECT_THROW(cube::sweptPairs(w.manager, good, type), std::invalid_argument);
    EXPECT_THROW(cube::sweptBox(*good[0].object, good[0].end, type), std::invalid_argument);
  }
  // Nothing changed: same answer, a valid manager.
  EXPECT_EQ(cube::sweptPairs(w.manager, good), before);
  EXPECT_TRUE(w.manager.validate());
  std::vector<Obj<S>*> now;
  w.manager.getObjects(now);
  EXPECT_EQ(now, w.registered);
}

// FCL 0.7's yes/no cylinder-plane test projects lz where lz/2 belongs, and its cone-halfspace
// test takes a cone whose apex points into the halfspace for one lying on its side: the library
// samples such pairs at FCL's times with the true test (continuous.h). 4,000 tilted cylinders
// (and cones) on a grid over the plane z = 0 or the halfspace z <= 0, and over a tilted plane
// 1000 units from the origin, each translated along the normal from 0.5 .. 2.5 off it to
// -0.3 .. 1.0 off it: the first sampled time t = i / (n - 1) at which the lowest point along the
// normal (a cylinder's centre . n - |axis . n| h/2 - r sqrt(1 - (axis . n)^2); a cone's lower of
// its apex and its base rim's lowest point) is at or below the plane (and, for a plane, the
// highest at or above it), against continuousCollideAll.
TEST(ContinuousCollideAll, CylindersAndConesAgainstPlanesSampledWithTheTrueTest) {
  using S = double;
  std::size_t contacts = 0, free = 0;
  for (const bool halfspace : {false, true})
    for (const bool cones : {false, true})
      for (const bool far : {false, true}) {
        const fcl::Vector3d n = far ? fcl::Vector3d(1, -2, 2).normalized() : fcl::Vector3d(0, 0, 1);
        const double d = far ? 1000 : 0;
        std::shared_ptr<fcl::CollisionGeometryd> flat_geo;
        if (halfspace)
          flat_geo = std::make_shared<fcl::Halfspaced>(n, d);
        else
          flat_geo = std::make_shared<fcl::Planed>(n, d);
        Obj<S> flat(flat_geo);
        flat.computeAABB();
        cube::CubeCollisionManagerd m;
        m.registerObject(&flat);
        std::mt19937 rng(61 + 2 * halfspace + cones);
        std::uniform_real_distribution<double> radius(0.2, 1.0), length(0.5, 3.0), start(0.5, 2.5),
            stop(-0.3, 1.0);
        std::normal_distribution<double> g;
        const fcl::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
        std::vector<std::unique_ptr<Obj<S>>> shapes;
        std::vector<cube::Motion<double>> motions;
        // Each shape's lowest and highest point along n relative to its centre.
        std::vector<double> low, high, c0, c1;
        for (int i = 0; i < 4000; ++i) {
          const double r = radius(rng), h = length(rng);
          std::shared_ptr<fcl::CollisionGeometryd> geo;
          if (cones)
            geo = std::make_shared<fcl::Coned>(r, h);
          else
            geo = std::make_shared<fcl::Cylinderd>(r, h);
          const fcl::Matrix3d R =
              fcl::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
          const double an = R.col(2).dot(n), rim = r * std::sqrt(std::max(0.0, 1 - an * an));
          low.push_back(cones ? std::min(an * h / 2, -an * h / 2 - rim)
                              : -std::abs(an) * h / 2 - rim);
          high.push_back(cones ? std::max(an * h / 2, -an * h / 2 + rim)
                               : std::abs(an) * h / 2 + rim);
          // Centre heights over the plane at the start and the end.
          c0.push_back(start(rng) - low.back());
          c1.push_back(stop(rng) - low.back());
          const fcl::Vector3d foot = n * d + e1 * (12.0 * (i % 64)) + e2 * (12.0 * (i / 64));
          shapes.push_back(std::make_unique<Obj<S>>(geo, R, foot + n * c0.back()));
          shapes.back()->computeAABB();
          m.registerObject(shapes.back().get());
          fcl::Transform3d end = shapes.back()->getTransform();
          end.translation() = foot + n * c1.back();
          motions.push_back({shapes.back().get(), end});
        }
        m.setup();
        fcl::ContinuousCollisionRequestd req;
        const std::size_t samples =
            std::min(req.num_max_iterations, std::size_t(std::ceil(1 / req.toc_err)));
        std::map<const Obj<S>*, double> got;
        for (const auto& c : cube::continuousCollideAll(m, motions, req))
          got[c.a == &flat ? c.b : c.a] = c.time_of_contact;
        std::size_t wrong = 0;
        for (std::size_t i = 0; i < shapes.size(); ++i) {
          double want = -1;  // no contact
          bool near_zero = false;
          for (std::size_t k = 0; k < samples && want < 0; ++k) {
            const double t = double(k) / double(samples - 1);
            const double c = c0[i] + t * (c1[i] - c0[i]);
            near_zero |= std::abs(c + low[i]) < 1e-9 || std::abs(c + high[i]) < 1e-9;
            if (halfspace ? c + low[i] <= 0 : (c + low[i] <= 0 && c + high[i] >= 0)) want = t;
          }
          if (near_zero) continue;
          const auto it = got.find(shapes[i].get());
          const double have = it == got.end() ? -1 : it->second;
          wrong += have != want;
          (want >= 0 ? contacts : free) += 1;
        }
        EXPECT_EQ(wrong, 0u) << (cones ? "cones" : "cylinders")
                             << (halfspace ? " / halfspace" : " / plane") << (far ? " far" : "");
      }
  EXPECT_GT(contacts, 4000u);
  EXPECT_GT(free, 4000u);
}

TEST(ContinuousBadInput, RefusedRequests) {
  World<double> w(50, 4, false, cube::scenes::Layout::uniform, false);
  const auto good = w.motions(0.5, 2, M_PI, 9);
  const auto before = cube::continuousCollideAll(w.manager, good);
  const auto refused = [&](const fcl::ContinuousCollisionRequest<double>& r) {
    EXPECT_THROW(cube::continuousCollideAll(w.manager, good, r), std::invalid_argument);
  };
  for (const auto solver :
       {fcl::CCDC_CONSERVATIVE_ADVANCEMENT, fcl::CCDC_RAY_SHOOTING, fcl::CCDC_POLYNOMIAL_SOLVER}) {
    fcl::ContinuousCollisionRequest<double> r;
    r.ccd_solver_type = solver;
    refused(r);
  }
  for (const auto type : {fcl::CCDM_LINEAR, fcl::CCDM_SPLINE}) {
    fcl::ContinuousCollisionRequest<double> r;
    r.ccd_motion_type = type;
    refused(r);
  }
  for (const double toc : {0.0, -1.0, 1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    fcl::ContinuousCollisionRequest<double> r;
    r.toc_err = toc;
    refused(r);
  }
  for (const std::size_t it : {0u, 1u}) {
    fcl::ContinuousCollisionRequest<double> r;
    r.num_max_iterations = it;
    refused(r);
  }
  auto m = good;
  m[0].object = nullptr;
  EXPECT_THROW(cube::continuousCollideAll(w.manager, m), std::invalid_argument);
  const auto after = cube::continuousCollideAll(w.manager, good);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t k = 0; k < after.size(); ++k) {
    EXPECT_EQ(after[k].a, before[k].a);
    EXPECT_EQ(after[k].time_of_contact, before[k].time_of_contact);
  }
  EXPECT_TRUE(w.manager.validate());
}

}  // namespace
