// The culling in front of the narrow phase (src/pipeline/cull.h) never drops a colliding pair:
// every FCL primitive and meshes, random rotations, and pairs pushed to the exact touching position
// that FCL's own narrow phase finds. Its distance bound never exceeds FCL's distance. And the
// default callbacks, which cull and bound, give the contacts and distances of FCL's narrow phase on
// every pair.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/margins.h"
#include "cube_collision/narrow_phase.h"
#include "cube_collision/queries.h"
#include "pipeline/cull.h"
#include "pipeline/pair_judge.h"
#include "support/plane_brute.h"

namespace {

template <typename S>
class Culling : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Culling, Scalars);

template <typename S>
using Geometry = std::shared_ptr<fcl::CollisionGeometry<S>>;

// One geometry of each kind FCL's narrow phase takes, sizes around 1, with the kind's name.
template <typename S>
std::vector<std::pair<std::string, Geometry<S>>> allKinds() {
  std::vector<std::pair<std::string, Geometry<S>>> out;
  out.emplace_back("box", std::make_shared<fcl::Box<S>>(1.0, 0.4, 0.7));
  out.emplace_back("sphere", std::make_shared<fcl::Sphere<S>>(0.45));
  out.emplace_back("ellipsoid", std::make_shared<fcl::Ellipsoid<S>>(0.6, 0.3, 0.4));
  out.emplace_back("capsule", std::make_shared<fcl::Capsule<S>>(0.25, 0.9));
  out.emplace_back("cone", std::make_shared<fcl::Cone<S>>(0.4, 0.9));
  out.emplace_back("cylinder", std::make_shared<fcl::Cylinder<S>>(0.3, 1.1));
  // A tetrahedron as a convex.
  auto verts = std::make_shared<std::vector<fcl::Vector3<S>>>(std::vector<fcl::Vector3<S>>{
      {0.5, 0, -0.2}, {-0.3, 0.4, -0.2}, {-0.3, -0.4, -0.2}, {0, 0, 0.6}});
  auto faces = std::make_shared<std::vector<int>>(
      std::vector<int>{3, 0, 1, 2, 3, 0, 3, 1, 3, 1, 3, 2, 3, 2, 3, 0});
  out.emplace_back("convex", std::make_shared<fcl::Convex<S>>(verts, 4, faces, true));
  auto mesh = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
  fcl::generateBVHModel(*mesh, fcl::Box<S>(0.8, 0.5, 0.3), fcl::Transform3<S>::Identity());
  out.emplace_back("mesh", mesh);
  auto ball = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
  fcl::generateBVHModel(*ball, fcl::Sphere<S>(0.4), fcl::Transform3<S>::Identity(), 8u, 8u);
  out.emplace_back("mesh sphere", ball);
  out.emplace_back("plane", std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0.2, 0.3, 1), 0.1));
  out.emplace_back("halfspace",
                   std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 1, 0.3), -0.2));
  return out;
}

// FCL 0.7's narrow phase itself crashes on a convex against a plane or a halfspace (libccd's GJK
// is handed a support function that does not exist for them): those pairs are left out.
bool fclCanCollide(const std::string& a, const std::string& b) {
  const auto flat = [](const std::string& k) { return k == "plane" || k == "halfspace"; };
  return !((a == "convex" && flat(b)) || (b == "convex" && flat(a)));
}

// FCL 0.7's fcl::distance crashes the same way on any shape against a plane or a halfspace.
bool fclCanMeasure(const std::string& a, const std::string& b) {
  const auto flat = [](const std::string& k) { return k == "plane" || k == "halfspace"; };
  return !flat(a) && !flat(b);
}

template <typename S>
fcl::Matrix3<S> randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaternion<double> q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q.toRotationMatrix().cast<S>();
}

template <typename S>
bool collides(fcl::CollisionObject<S>& a, fcl::CollisionObject<S>& b) {
  fcl::CollisionRequest<S> req;
  fcl::CollisionResult<S> res;
  return fcl::collide(&a, &b, req, res) > 0;
}

template <typename S>
S defaultTolerance() {
  return S(fcl::CollisionRequest<S>().gjk_tolerance);
}

// The cull the pipeline runs on the object tables' float records (buildVolume, verdictOf): it
// must keep every promise surelyApart and surelyTouching keep.
template <typename S>
cube::detail::Verdict volumeVerdict(const fcl::CollisionObject<S>& a,
                                    const fcl::CollisionObject<S>& b, bool prove) {
  cube::detail::VolumeSphere sa, sb;
  cube::detail::VolumeShape ha, hb;
  cube::detail::buildVolume(a, sa, ha);
  cube::detail::buildVolume(b, sb, hb);
  return cube::detail::verdictOf(sa, ha, sb, hb,
                                 cube::detail::volumeMarginRate(defaultTolerance<S>()), prove);
}

// Random poses: every pair of kinds, rotated at random, centres within a distance where about
// half the pairs collide. A culled pair never collides, and culling removes a good share of the
// pairs that do not (else the test would pass with a cull that never culls).
TYPED_TEST(Culling, NeverDropsACollidingPairOfAnyKind) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.3, 1.3);
  std::size_t apart_pairs = 0, culled = 0, colliding = 0, volume_culled = 0;
  for (const auto& [na, ga] : kinds)
    for (const auto& [nb, gb] : kinds) {
      if (!fclCanCollide(na, nb)) continue;
      fcl::CollisionObject<S> a(ga), b(gb);
      for (int rep = 0; rep < 60; ++rep) {
        a.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng)) * S(0.3));
        b.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng)));
        a.computeAABB();
        b.computeAABB();
        const bool cull = cube::detail::surelyApart(a, b, defaultTolerance<S>());
        const bool hit = collides(a, b);
        const bool volume_cull = volumeVerdict(a, b, false) == cube::detail::Verdict::kApart;
        ASSERT_FALSE(cull && hit) << na << " vs " << nb << " rep " << rep;
        ASSERT_FALSE(volume_cull && hit) << na << " vs " << nb << " rep " << rep << " (records)";
        colliding += hit;
        if (!hit && a.getAABB().overlap(b.getAABB())) {
          ++apart_pairs;
          culled += cull;
          volume_culled += volume_cull;
        }
      }
    }
  EXPECT_GT(colliding, 1000u);
  EXPECT_GT(apart_pairs, 1000u);
  EXPECT_GT(culled * 10, apart_pairs * 3) << culled << " of " << apart_pairs;
  // The records lose only what float rounding and near-parallel edges cost.
  EXPECT_GE(volume_culled * 100, culled * 97) << volume_culled << " against " << culled;
}

// The pair judge, the one place queries ask about a pair before FCL, never answers against FCL,
// on the records and on the objects, for each of its three questions: a collide's pair proved
// apart does not collide and one proved touching does; a pair that cannot beat a best distance
// has a larger FCL distance; a pair that cannot be within a margin is farther apart than it.
// Every kind, random poses; and each question is settled for a good share of the pairs (else a
// judge that never decides would pass).
TYPED_TEST(Culling, PairJudgeNeverAnswersAgainstFcl) {
  using S = TypeParam;
  using cube::detail::Answer;
  using cube::detail::Records;
  using cube::detail::Verdict;
  const auto kinds = allKinds<S>();
  const fcl::CollisionRequest<S> collide_request;
  const fcl::DistanceRequest<S> distance_request;
  const cube::detail::PairJudge<S> collide_judge(collide_request);
  const cube::detail::PairJudge<S> distance_judge(distance_request);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.5, 1.5), reach(0.0, 0.6);
  std::size_t pairs = 0, apart = 0, proved = 0, not_beating = 0, not_within = 0;
  std::size_t object_apart = 0, object_not_beating = 0, object_not_within = 0;
  for (const auto& [na, ga] : kinds)
    for (const auto& [nb, gb] : kinds) {
      if (!fclCanMeasure(na, nb)) continue;
      fcl::CollisionObject<S> a(ga), b(gb);
      for (int rep = 0; rep < 30; ++rep) {
        a.setTransform(randomRotation<S>(rng), fcl::Vector3<S>::Zero());
        b.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng)));
        a.computeAABB();
        b.computeAABB();
        cube::detail::VolumeSphere sa, sb;
        cube::detail::VolumeShape ha, hb;
        cube::detail::buildVolume(a, sa, ha);
        cube::detail::buildVolume(b, sb, hb);
        const Records ra{&sa, &ha}, rb{&sb, &hb};
        const bool hit = collides(a, b);
        fcl::DistanceResult<S> res;
        const S d = fcl::distance(&a, &b, distance_request, res);
        const S best = S(reach(rng)), m = rep % 3 == 0 ? S(0) : S(reach(rng));
        const std::string what = na + " vs " + nb + " rep " + std::to_string(rep);
        ++pairs;
        const Answer on_records = collide_judge.collide(ra, rb);
        ASSERT_FALSE(on_records == Answer::kApart && hit) << what;
        ASSERT_FALSE(on_records == Answer::kProved && !hit) << what;
        const Answer on_objects = collide_judge.collide(a, b);
        ASSERT_FALSE(on_objects == Answer::kApart && hit) << what << " (objects)";
        ASSERT_FALSE(on_objects == Answer::kProved && !hit) << what << " (objects)";
        apart += on_records == Answer::kApart;
        proved += on_records == Answer::kProved;
        object_apart += on_objects == Answer::kApart;
        if (!distance_judge.mayBeat(ra, rb, best)) {
          ASSERT_GT(d, best) << what;
          ++not_beating;
        }
        if (!distance_judge.mayBeat(a, b, best)) {
          ASSERT_GT(d, best) << what << " (objects)";
          ++object_not_beating;
        }
        const Verdict within = collide_judge.withinMargin(ra, rb, m);
        ASSERT_FALSE(within == Verdict::kApart && (hit || !(d > m))) << what << " margin " << m;
        ASSERT_FALSE(within == Verdict::kTouching && !hit) << what << " margin " << m;
        not_within += within == Verdict::kApart;
        if (!distance_judge.mayBeWithin(a, b, m)) {
          ASSERT_TRUE(!hit && d > m) << what << " margin " << m << " (objects)";
          ++object_not_within;
        }
      }
    }
  EXPECT_GT(pairs, 1500u);
  for (const std::size_t settled :
       {apart, not_beating, not_within, object_apart, object_not_beating, object_not_within})
    EXPECT_GT(settled * 10, pairs) << settled << " of " << pairs;
  // Proofs need inscribed volumes on both sides (none for meshes and convexes) that overlap by
  // more than the margin: rarer.
  EXPECT_GT(proved * 100, pairs) << proved << " of " << pairs;
}

// Slides b along a line, place(t) putting it at t: false if the pair does not collide at t = 0
// or still collides at t = 10 (a plane or halfspace: no touching position this way); otherwise
// bisects [0, 10] down to in (the last position FCL reports contact) and out (the first it does
// not), 10 / 2^50 apart.
template <typename S, class Place>
bool slideToTouching(fcl::CollisionObject<S>& a, fcl::CollisionObject<S>& b, Place&& place,
                     double& in, double& out) {
  place(0);
  if (!collides(a, b)) return false;
  place(10);
  if (collides(a, b)) return false;
  in = 0;
  out = 10;
  for (int k = 0; k < 50; ++k) {
    const double mid = 0.5 * (in + out);
    place(mid);
    (collides(a, b) ? in : out) = mid;
  }
  return true;
}

// Where slideToTouching moves b: rotation rb, at base + t along a random unit direction (drawn
// from rng through n).
template <typename S>
auto slider(fcl::CollisionObject<S>& b, const fcl::Matrix3<S>& rb, const fcl::Vector3<S>& base,
            std::mt19937& rng, std::normal_distribution<double>& n) {
  fcl::Vector3<S> dir(S(n(rng)), S(n(rng)), S(n(rng)));
  dir.normalize();
  return [&b, rb, base, dir](double t) {
    b.setTransform(rb, base + dir * S(t));
    b.computeAABB();
  };
}

// Pairs at the touching position: b slides towards a along a random direction, and bisection
// with fcl::collide finds where FCL starts to report contact. At that first colliding position,
// and a hair beyond, the pair must not be culled; a little way outside it may be.
// The same far from the origin (1,000 away), where the records' float coordinates round most.
TYPED_TEST(Culling, KeepsPairsAtTheTouchingPosition) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1);
  std::size_t touching = 0, culled_outside = 0, volume_culled_outside = 0;
  for (const double offset : {0.0, 1000.0})
    for (const auto& [na, ga] : kinds)
      for (const auto& [nb, gb] : kinds) {
        if (!fclCanCollide(na, nb)) continue;
        fcl::CollisionObject<S> a(ga), b(gb);
        const fcl::Vector3<S> base(S(offset), S(-0.5 * offset), S(0.25 * offset));
        for (int rep = 0; rep < 8; ++rep) {
          a.setTransform(randomRotation<S>(rng), base);
          a.computeAABB();
          const fcl::Matrix3<S> rb = randomRotation<S>(rng);
          const auto place = slider(b, rb, base, rng, n);
          double in, out;
          if (!slideToTouching(a, b, place, in, out)) continue;
          place(in);
          ASSERT_TRUE(collides(a, b));
          ASSERT_FALSE(cube::detail::surelyApart(a, b, defaultTolerance<S>()))
              << na << " vs " << nb << " at the last colliding position " << in;
          ASSERT_NE(volumeVerdict(a, b, true), cube::detail::Verdict::kApart)
              << na << " vs " << nb << " at the last colliding position " << in << " (records)";
          ++touching;
          place(out + 0.01);
          culled_outside += cube::detail::surelyApart(a, b, defaultTolerance<S>());
          volume_culled_outside += volumeVerdict(a, b, false) == cube::detail::Verdict::kApart;
        }
      }
  EXPECT_GT(touching, 800u);
  EXPECT_GT(culled_outside, 0u);  // outside by 0.01, the tight volumes do separate some pairs
  EXPECT_GT(volume_culled_outside, 0u);
}

// Proofs of contact (surelyTouching, what lets the pipeline skip FCL for a touching pair of
// primitives): wherever they prove a pair touching, FCL reports a contact, with either GJK
// solver and either argument order. Pairs slide from the same centre to where FCL stops
// reporting contact (bisection): at that first free position and beyond, no proof; along the
// way, the proofs are checked against FCL. A geometry FCL treats as not occupied (cost_density
// below threshold_occupied, which FCL's shape collision skips) is never proved touching.
TYPED_TEST(Culling, ProvesContactOnlyWhereFclReportsIt) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(23);
  std::normal_distribution<double> n(0, 1);
  std::size_t proved = 0, checked = 0, volume_proved = 0;
  const auto fclSays = [](fcl::CollisionObject<S>& x, fcl::CollisionObject<S>& y,
                          fcl::GJKSolverType solver) {
    fcl::CollisionRequest<S> req;
    req.gjk_solver_type = solver;
    fcl::CollisionResult<S> res;
    return fcl::collide(&x, &y, req, res) > 0;
  };
  for (const auto& [na, ga] : kinds)
    for (const auto& [nb, gb] : kinds) {
      if (!fclCanCollide(na, nb)) continue;
      fcl::CollisionObject<S> a(ga), b(gb);
      for (int rep = 0; rep < 8; ++rep) {
        a.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(S(n(rng)), S(n(rng)), S(n(rng))));
        a.computeAABB();
        const fcl::Matrix3<S> rb = randomRotation<S>(rng);
        const auto place = slider(b, rb, fcl::Vector3<S>(a.getTranslation()), rng, n);
        double in, out;
        if (!slideToTouching(a, b, place, in, out)) continue;
        for (double t : {out, out + 1e-9, out + 0.01, out + 1.0}) {
          place(t);
          EXPECT_FALSE(cube::detail::surelyTouching(a, b, defaultTolerance<S>()))
              << na << " vs " << nb << " proved touching where FCL reports none, at " << t;
          EXPECT_NE(volumeVerdict(a, b, true), cube::detail::Verdict::kTouching)
              << na << " vs " << nb << " proved touching where FCL reports none, at " << t
              << " (records)";
        }
        for (int k = 0; k <= 40; ++k) {
          place(in * k / 40.0);
          const bool by_records = volumeVerdict(a, b, true) == cube::detail::Verdict::kTouching;
          volume_proved += by_records;
          if (by_records)
            for (const auto solver : {fcl::GST_LIBCCD, fcl::GST_INDEP}) {
              EXPECT_TRUE(fclSays(a, b, solver)) << na << " vs " << nb << " (records)";
              EXPECT_TRUE(fclSays(b, a, solver)) << nb << " vs " << na << " (records)";
            }
          if (!cube::detail::surelyTouching(a, b, defaultTolerance<S>())) continue;
          ++proved;
          for (const auto solver : {fcl::GST_LIBCCD, fcl::GST_INDEP}) {
            ++checked;
            EXPECT_TRUE(fclSays(a, b, solver)) << na << " vs " << nb << " at " << in * k / 40.0;
            EXPECT_TRUE(fclSays(b, a, solver)) << nb << " vs " << na << " at " << in * k / 40.0;
          }
          EXPECT_TRUE(cube::detail::surelyTouching(b, a, defaultTolerance<S>()));
          EXPECT_EQ(cube::detail::verdict(a, b, defaultTolerance<S>(), true),
                    cube::detail::Verdict::kTouching);
          EXPECT_EQ(cube::detail::verdict(a, b, defaultTolerance<S>(), false),
                    cube::detail::Verdict::kUnknown);
        }
        // Not occupied: FCL's shape collision reports nothing, so nothing is proved.
        place(0);
        const S density = ga->cost_density;
        ga->cost_density = S(0.5) * ga->threshold_occupied;
        EXPECT_FALSE(cube::detail::surelyTouching(a, b, defaultTolerance<S>()));
        EXPECT_NE(volumeVerdict(a, b, true), cube::detail::Verdict::kTouching);
        ga->cost_density = density;
      }
    }
  EXPECT_GT(proved, 300u) << "the proofs must be exercised";
  EXPECT_GE(volume_proved * 100, proved * 97) << volume_proved << " against " << proved;
  EXPECT_GT(checked, 0u);
}

// The round bounds (capsules about the axes of spheres, capsules, cylinders and cones, against
// each other and against the other records' boxes) and the inner volumes (capsules and boxes
// inside spheres, boxes, cylinders and capsules) decide only what FCL's narrow phase says: the
// records' verdict is apart only where FCL reports no contact (either solver), touching only where
// it reports one with either solver and argument order. Shapes of assorted proportions (long,
// flat, a cone lower than wide, a capsule of length 0, a convex, an ellipsoid and a mesh against
// the round ones) slide from a common centre to where FCL stops reporting contact and beyond,
// near the origin and 1,000 away (where the float records round most). And each bound decides
// pairs the spheres, boxes and inscribed balls leave to FCL.
TYPED_TEST(Culling, RoundAndInnerBoundsAgreeWithFcl) {
  using S = TypeParam;
  using namespace cube::detail;
  using namespace cube::detail::volume_detail;
  std::vector<std::pair<std::string, Geometry<S>>> shapes = {
      {"sphere", std::make_shared<fcl::Sphere<S>>(0.4)},
      {"box", std::make_shared<fcl::Box<S>>(1.0, 0.3, 0.6)},
      {"flat box", std::make_shared<fcl::Box<S>>(1.2, 1.0, 0.1)},
      {"capsule", std::make_shared<fcl::Capsule<S>>(0.25, 0.9)},
      {"long capsule", std::make_shared<fcl::Capsule<S>>(0.1, 2.0)},
      {"ball capsule", std::make_shared<fcl::Capsule<S>>(0.3, 0.0)},
      {"cylinder", std::make_shared<fcl::Cylinder<S>>(0.3, 1.1)},
      {"disc", std::make_shared<fcl::Cylinder<S>>(0.6, 0.1)},
      {"cone", std::make_shared<fcl::Cone<S>>(0.4, 0.9)},
      {"low cone", std::make_shared<fcl::Cone<S>>(0.6, 0.3)}};
  for (const auto& [name, g] : allKinds<S>())
    if (name == "convex" || name == "ellipsoid" || name == "mesh") shapes.emplace_back(name, g);
  const float rate = volumeMarginRate(defaultTolerance<S>());
  const auto fclSays = [](fcl::CollisionObject<S>& x, fcl::CollisionObject<S>& y,
                          fcl::GJKSolverType solver) {
    fcl::CollisionRequest<S> req;
    req.gjk_solver_type = solver;
    fcl::CollisionResult<S> res;
    return fcl::collide(&x, &y, req, res) > 0;
  };
  const auto isRound = [](const VolumeShape& h) {
    return (h.flags & (kVolumeCapsule | kVolumeCylinder | kVolumeCone)) != 0;
  };
  std::mt19937 rng(31);
  std::normal_distribution<double> n(0, 1);
  std::size_t by_capsules = 0, by_capsule_box = 0, apart_new = 0, meet = 0, touching_new = 0;
  for (const double offset : {0.0, 1000.0})
    for (const auto& [na, ga] : shapes)
      for (const auto& [nb, gb] : shapes) {
        fcl::CollisionObject<S> a(ga), b(gb);
        const fcl::Vector3<S> base(S(offset), S(-0.5 * offset), S(0.25 * offset));
        for (int rep = 0; rep < 6; ++rep) {
          a.setTransform(randomRotation<S>(rng), base);
          a.computeAABB();
          // The first pose of each pair keeps both frames parallel (parallel edges: the inner
          // boxes' test then clamps a centre into the other box).
          const fcl::Matrix3<S> rb =
              rep == 0 ? fcl::Matrix3<S>(a.getRotation()) : randomRotation<S>(rng);
          const auto place = slider(b, rb, base, rng, n);
          double in, out;
          if (!slideToTouching(a, b, place, in, out)) continue;
          std::vector<double> ts;
          for (int k = 0; k <= 12; ++k) ts.push_back(in * k / 12.0);
          for (const double t : {in, out, out + 1e-9, out + 1e-3, out + 0.02, out + 0.1, out + 0.4})
            ts.push_back(t);
          for (const double t : ts) {
            place(t);
            VolumeSphere sa, sb;
            VolumeShape ha, hb;
            buildVolume(a, sa, ha);
            buildVolume(b, sb, hb);
            const std::string what = na + " vs " + nb + " at " + std::to_string(t) +
                                     " (contact up to " + std::to_string(in) + "), offset " +
                                     std::to_string(offset);
            const Verdict v = verdictOf(sa, ha, sb, hb, rate, true);
            EXPECT_EQ(verdictOf(sb, hb, sa, ha, rate, true), v) << what;
            if (v == Verdict::kApart) {
              for (const auto solver : {fcl::GST_LIBCCD, fcl::GST_INDEP})
                EXPECT_FALSE(fclSays(a, b, solver)) << what;
              const VolumeGap old = separationOf(sa, ha, sb, hb, rate, 0.f);
              if (old.lower_bound > old.margin) continue;
              ++apart_new;
              const float m = innerMargin(sa, ha, sb, hb, rate);
              const AxisCapsule oa = outerCapsule(sa, ha), ob = outerCapsule(sb, hb);
              by_capsules +=
                  oa.radius >= 0.f && ob.radius >= 0.f && capsuleGap(sa, ha, oa, sb, hb, ob) > m;
              by_capsule_box +=
                  (isRound(ha) && ob.radius < 0.f && capsuleBoxGap(sa, ha, oa, sb, hb) > m) ||
                  (isRound(hb) && oa.radius < 0.f && capsuleBoxGap(sb, hb, ob, sa, ha) > m);
            }
            if (v == Verdict::kTouching) {
              ++meet;
              for (const auto solver : {fcl::GST_LIBCCD, fcl::GST_INDEP}) {
                EXPECT_TRUE(fclSays(a, b, solver)) << what;
                EXPECT_TRUE(fclSays(b, a, solver)) << what;
              }
              EXPECT_EQ(verdictOf(sa, ha, sb, hb, rate, false), Verdict::kUnknown) << what;
              float gap2 = 0.f;  // the inscribed balls
              for (int k = 0; k < 3; ++k) {
                const float g = (sb.c[k] + hb.inner_z * hb.R[3 * k + 2]) -
                                (sa.c[k] + ha.inner_z * ha.R[3 * k + 2]);
                gap2 += g * g;
              }
              if (std::sqrt(gap2) >= ha.inner_r + hb.inner_r) {
                ++touching_new;
                EXPECT_TRUE(innerVolumesMeet(sa, ha, sb, hb, innerMargin(sa, ha, sb, hb, rate)));
              }
            }
          }
        }
      }
  EXPECT_GT(by_capsules, 200u) << apart_new;
  EXPECT_GT(by_capsule_box, 100u) << apart_new;
  EXPECT_GT(touching_new, 500u) << meet;
}

// The default callbacks cull: collideAll on a cube manager gives exactly the contacts of
// fcl::collide over every pair (all contacts requested), on scenes of every kind, but for the
// pairs FCL 0.7 answers wrongly (a cylinder or cone against a plane or halfspace), whose truth
// comes from the geometry.
TYPED_TEST(Culling, CollideAllEqualsBruteForceNarrowPhase) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  for (int i = 0; i < 160; ++i) {
    const auto& kind = kinds[std::size_t(i) % kinds.size()];
    if (kind.first == "convex") continue;  // see fclCanCollide: the scene has planes
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        kind.second, randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng))));
    objs.back()->computeAABB();
  }
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 30;
  all.enable_contact = true;
  std::size_t expected = 0, colliding_pairs = 0;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      fcl::CollisionResult<S> r;
      // A cylinder or cone against a plane or halfspace: one contact where the geometry says
      // they meet (FCL 0.7 answers some of these pairs wrongly; queries.h).
      const auto round = [](fcl::NODE_TYPE t) {
        return t == fcl::GEOM_CYLINDER || t == fcl::GEOM_CONE;
      };
      const fcl::NODE_TYPE ti = objs[i]->getNodeType(), tj = objs[j]->getNodeType();
      const std::size_t c =
          (round(ti) && cube::brute::planar(tj)) || (round(tj) && cube::brute::planar(ti))
              ? std::size_t(cube::brute::touch(*objs[i], *objs[j]))
              : fcl::collide(objs[i].get(), objs[j].get(), all, r);
      expected += c;
      colliding_pairs += c > 0;
    }
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  const fcl::CollisionResult<S> got = cube::collideAll<S>(m, all);
  EXPECT_EQ(got.numContacts(), expected);
  EXPECT_GT(colliding_pairs, 100u);
}

// The tight volumes' bound, less its margin, never exceeds FCL's own distance: every kind, at
// random poses from touching to well apart. And it is close enough to matter: for most pairs
// a few object sizes apart it is at least half the distance.
TYPED_TEST(Culling, SeparationIsALowerBoundOnFclDistance) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::size_t checked = 0, informative = 0, records_informative = 0;
  for (const auto& [na, ga] : kinds)
    for (const auto& [nb, gb] : kinds) {
      if (!fclCanMeasure(na, nb)) continue;
      fcl::CollisionObject<S> a(ga), b(gb);
      for (int rep = 0; rep < 40; ++rep) {
        a.setTransform(randomRotation<S>(rng), fcl::Vector3<S>::Zero());
        b.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng)));
        a.computeAABB();
        b.computeAABB();
        fcl::DistanceRequest<S> req;
        fcl::DistanceResult<S> res;
        const S d = fcl::distance(&a, &b, req, res);
        if (!(d > 0)) continue;
        const auto sep = cube::detail::separation(a, b, S(req.distance_tolerance));
        ASSERT_LE(sep.lower_bound - sep.margin, d) << na << " vs " << nb << " rep " << rep;
        ++checked;
        informative += sep.lower_bound >= d / 2;
        // The same from the float records (the pipeline's bound), with the boxes looked at
        // (enough 0) and without (enough infinite).
        cube::detail::VolumeSphere sa, sb;
        cube::detail::VolumeShape ha, hb;
        cube::detail::buildVolume(a, sa, ha);
        cube::detail::buildVolume(b, sb, hb);
        const float rate = cube::detail::volumeMarginRate(S(req.distance_tolerance));
        for (const float enough : {0.f, std::numeric_limits<float>::infinity()}) {
          const auto gap = cube::detail::separationOf(sa, ha, sb, hb, rate, enough);
          ASSERT_LE(double(gap.lower_bound) - double(gap.margin), double(d))
              << na << " vs " << nb << " rep " << rep << " (records)";
          if (enough > 0.f) records_informative += gap.lower_bound >= d / 2;
        }
      }
    }
  EXPECT_GT(checked, 2000u);
  EXPECT_GT(informative * 2, checked) << informative << " of " << checked;
  EXPECT_GE(records_informative * 100, informative * 97)
      << records_informative << " against " << informative;
}

// The default distance callback skips pairs the bound rules out: minimumDistance on a cube
// manager, self and against an object, equals the minimum of fcl::distance over every pair.
TYPED_TEST(Culling, MinimumDistanceEqualsBruteForceNarrowPhase) {
  using S = TypeParam;
  auto kinds = allKinds<S>();
  kinds.erase(
      std::remove_if(kinds.begin(), kinds.end(),
                     [](const auto& k) { return k.first == "plane" || k.first == "halfspace"; }),
      kinds.end());  // see fclCanMeasure
  std::mt19937 rng(9);
  int apart_scenes = 0;  // scenes where no two objects touch, so that the search ran its course
  for (int scene = 0; scene < 6; ++scene) {
    std::uniform_real_distribution<double> u(-9.0, 9.0);
    std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
    for (int i = 0; i < 50; ++i) {
      objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
          kinds[std::size_t(i + scene) % kinds.size()].second, randomRotation<S>(rng),
          fcl::Vector3<S>(u(rng), u(rng), u(rng))));
      objs.back()->computeAABB();
    }
    fcl::DistanceRequest<S> req;
    S self_min = std::numeric_limits<S>::max(), query_min = std::numeric_limits<S>::max();
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        fcl::DistanceResult<S> r;
        const S d = fcl::distance(objs[i].get(), objs[j].get(), req, r);
        if (j + 1 == objs.size())
          query_min = std::min(query_min, d);  // the last object is the query
        else
          self_min = std::min(self_min, d);
      }
    cube::CubeCollisionManager<S> m;
    std::vector<fcl::CollisionObject<S>*> ptrs;
    for (std::size_t i = 0; i + 1 < objs.size(); ++i) ptrs.push_back(objs[i].get());
    m.registerObjects(ptrs);
    // FCL's distance for one pair can differ in the last digits with what the result already
    // holds (a mesh's traversal is pruned by it): equal within FCL's own tolerance.
    const S tol = S(req.distance_tolerance) * (S(1) + std::abs(self_min));
    EXPECT_NEAR(cube::minimumDistance<S>(m, req).min_distance, self_min, tol) << "scene " << scene;
    EXPECT_NEAR(cube::minimumDistance<S>(m, objs.back().get(), req).min_distance, query_min, tol)
        << "scene " << scene;
    apart_scenes += self_min > 0;
  }
  EXPECT_GE(apart_scenes, 3);
}

// FCL 0.7's fcl::distance crashes on a plane or a halfspace (a null support function in
// libccd): the library answers such a pair with its exact distance in closed form (queries.h).
// Every kind, an octree too, against planes and halfspaces at random tilts (in the geometry and
// in the object's pose) about 1000 units from the origin, through minimumDistance (self, object
// query, with a cache), the default distance callback and contactsWithinMargin, against the
// brute force of support/plane_brute.h: -1 for a pair that meets, else the gap, with the nearest
// points on the plane and at the object's extreme, as far apart as the distance.
TYPED_TEST(Culling, DistanceToPlanesAndHalfspacesIsExactForEveryKind) {
  using S = TypeParam;
  auto kinds = allKinds<S>();
  kinds.erase(
      std::remove_if(kinds.begin(), kinds.end(),
                     [](const auto& k) { return k.first == "plane" || k.first == "halfspace"; }),
      kinds.end());
  auto tree = std::make_shared<octomap::OcTree>(0.25);
  for (const auto& p : {octomap::point3d(0.1f, 0.2f, 0.3f), octomap::point3d(-0.6f, 0.1f, 0.0f),
                        octomap::point3d(0.3f, -0.5f, 0.6f), octomap::point3d(0.0f, 0.4f, -0.7f)})
    tree->updateNode(p, true);
  kinds.emplace_back("octree", std::make_shared<fcl::OcTree<S>>(tree));
  const double tol = std::is_same<S, float>::value ? 2e-3 : 1e-8;
  const S margin = S(0.75);
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0), height(-2.0, 4.0);
  const auto unit = [&] { return fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))).normalized(); };
  std::size_t apart = 0, meeting = 0, within = 0;
  for (int rep = 0; rep < 30; ++rep)
    for (const bool solid : {false, true})
      for (const auto& [name, geo] : kinds) {
        const fcl::Vector3<S> local_n = unit();
        const S local_d = S(5 * u(rng));
        Geometry<S> pg;
        if (solid)
          pg = std::make_shared<fcl::Halfspace<S>>(local_n, local_d);
        else
          pg = std::make_shared<fcl::Plane<S>>(local_n, local_d);
        fcl::CollisionObject<S> pl(
            pg, randomRotation<S>(rng),
            fcl::Vector3<S>(S(600 + 9 * u(rng)), S(-700 + 9 * u(rng)), S(500 + 9 * u(rng))));
        Eigen::Vector3d n;
        double d;
        cube::brute::boundary(pl, n, d);
        // The object about `height` from the plane (either side of a plane), near its foot.
        const Eigen::Vector3d foot = n * d + Eigen::Vector3d(u(rng), u(rng), u(rng)).cross(n);
        const double side = !solid && u(rng) < 0 ? -1 : 1;
        fcl::CollisionObject<S> obj(geo, randomRotation<S>(rng),
                                    (foot + side * height(rng) * n).template cast<S>());
        pl.computeAABB();
        obj.computeAABB();
        const double want = cube::brute::distance(pl, obj);
        const double gap = cube::brute::gap(pl, obj);
        if (std::abs(gap) < 10 * tol || std::abs(gap - double(margin)) < 10 * tol) continue;
        (want > 0 ? apart : meeting) += 1;
        const std::string what =
            name + (solid ? " / halfspace" : " / plane") + " rep " + std::to_string(rep);

        // The pair as a manager's self query, and the object as a query against the plane.
        fcl::DistanceRequest<S> req(true);
        for (const bool plane_first : {true, false}) {
          cube::CubeCollisionManager<S> m;
          m.registerObject(plane_first ? &pl : &obj);
          m.registerObject(plane_first ? &obj : &pl);
          m.setup();
          const fcl::DistanceResult<S> r = cube::minimumDistance<S>(m, req);
          ASSERT_NEAR(r.min_distance, want, tol) << what;
          if (want > 0) {
            // Which point is the plane's: the one on the geometry of the plane.
            const bool pl_is_o1 = r.o1 == pg.get();
            const Eigen::Vector3d on_plane =
                r.nearest_points[pl_is_o1 ? 0 : 1].template cast<double>();
            const Eigen::Vector3d on_obj =
                r.nearest_points[pl_is_o1 ? 1 : 0].template cast<double>();
            EXPECT_NEAR(n.dot(on_plane) - d, 0, tol) << what;
            EXPECT_NEAR(std::abs(n.dot(on_obj) - d), want, tol) << what;
            EXPECT_NEAR((on_obj - on_plane).norm(), want, tol) << what;
          }
          cube::NarrowPhaseCache<S> cache;
          cube::NarrowPhaseOptions<S> cached;
          cached.cache = &cache;
          EXPECT_NEAR(cube::minimumDistance<S>(m, req, cached).min_distance, want, tol) << what;
          cube::DistanceData<S> data;
          data.request = req;
          m.distance(&data, cube::defaultDistanceCallback<S>);
          EXPECT_NEAR(data.result.min_distance, want, tol) << what;

          // Within a margin: listed when the gap is at most the margin, with the distance.
          m.setMargin(&obj, margin);
          const auto near = cube::contactsWithinMargin<S>(m, req, 1);
          ASSERT_EQ(near.size(), gap <= double(margin) ? 1u : 0u) << what;
          if (!near.empty()) {
            EXPECT_EQ(near[0].colliding, want < 0) << what;
            if (want > 0) {
              EXPECT_NEAR(near[0].distance, want, tol) << what;
            }
            within += want > 0;
          }
        }
        cube::CubeCollisionManager<S> planes;
        planes.registerObject(&pl);
        planes.setup();
        EXPECT_NEAR(cube::minimumDistance<S>(planes, &obj, req).min_distance, want, tol) << what;
      }
  EXPECT_GT(apart, 100u);
  EXPECT_GT(meeting, 100u);
  EXPECT_GT(within, 20u);
}

// Two planes or halfspaces are apart only when parallel: facing halfspaces and parallel planes
// get their gap, any tilt between them meets (-1), through minimumDistance.
TYPED_TEST(Culling, DistanceBetweenPlanesIsTheGapWhenParallel) {
  using S = TypeParam;
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double tol = std::is_same<S, float>::value ? 2e-3 : 1e-8;
  for (int rep = 0; rep < 40; ++rep) {
    const fcl::Vector3<S> n = fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))).normalized();
    const S d1 = S(1000 + 3 * u(rng)), gap = S(2 + u(rng));
    const fcl::Matrix3<S> R = randomRotation<S>(rng);
    // Each in its own frame: R^T n in a frame rotated by R is n in the world.
    const fcl::Vector3<S> ln = R.transpose() * n;
    const auto posed = [&](Geometry<S> g) {
      auto o = std::make_unique<fcl::CollisionObject<S>>(g, R, fcl::Vector3<S>::Zero());
      o->computeAABB();
      return o;
    };
    struct Case {
      Geometry<S> a, b;
      double want;
    };
    const fcl::Vector3<S> tilted = (ln + fcl::Vector3<S>(S(0.3), S(-0.2), S(0.1))).normalized();
    const std::vector<Case> cases = {
        // Parallel planes: n . x = d1 and n . x = d1 + gap (one written with -n).
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Plane<S>>(-ln, -d1 - gap),
         double(gap)},
        // A plane above a halfspace n . x <= d1 - gap, and one inside it.
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Halfspace<S>>(ln, d1 - gap),
         double(gap)},
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Halfspace<S>>(ln, d1 + gap),
         -1},
        // Facing halfspaces n . x <= d1 and -n . x <= -(d1 + gap); same-facing ones meet.
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(-ln, -d1 - gap), double(gap)},
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(ln, d1 + gap), -1},
        // Tilted: they cross.
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Plane<S>>(tilted, d1), -1},
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(-tilted, -d1 - gap), -1},
    };
    for (std::size_t c = 0; c < cases.size(); ++c)
      for (const bool swap : {false, true}) {
        auto a = posed(cases[c].a), b = posed(cases[c].b);
        cube::CubeCollisionManager<S> m;
        m.registerObject(swap ? b.get() : a.get());
        m.registerObject(swap ? a.get() : b.get());
        m.setup();
        const fcl::DistanceResult<S> r = cube::minimumDistance<S>(m, fcl::DistanceRequest<S>(true));
        ASSERT_NEAR(r.min_distance, cases[c].want, tol) << "case " << c << " rep " << rep;
        if (cases[c].want > 0) {
          EXPECT_NEAR((r.nearest_points[0] - r.nearest_points[1]).norm(), cases[c].want, tol);
        }
      }
  }
}

// FCL 0.7's fcl::collide crashes on a convex polytope against a plane: the library answers such
// a pair from the polytope's vertices (fcl_narrow.h). collideAll and the default callback, with
// convexes among planes (one tilted, through the scene), equal brute force: a convex meets a
// plane where its vertices lie on both sides (checked here from the vertices), fcl::collide for
// every other pair; the contact's normal is the plane's and its depth the lesser push.
TYPED_TEST(Culling, ConvexAgainstPlaneAnsweredFromTheVertices) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  const auto& convex_geo = std::find_if(kinds.begin(), kinds.end(), [](const auto& k) {
                             return k.first == "convex";
                           })->second;
  const auto& tetra = static_cast<const fcl::Convex<S>&>(*convex_geo);
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  const fcl::Vector3<S> normals[2] = {fcl::Vector3<S>(0, 0, 1),
                                      fcl::Vector3<S>(1, 2, 2).normalized()};
  for (const auto& n : normals)
    objs.push_back(
        std::make_unique<fcl::CollisionObject<S>>(std::make_shared<fcl::Plane<S>>(n, S(0.3))));
  for (int i = 0; i < 60; ++i)  // each object its own geometry: contacts name the objects
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        std::make_shared<fcl::Convex<S>>(
            std::make_shared<std::vector<fcl::Vector3<S>>>(tetra.getVertices()), 4,
            std::make_shared<std::vector<int>>(tetra.getFaces()), true),
        randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng))));
  for (auto& o : objs) o->computeAABB();
  // Brute force over every pair: plane-convex from the vertices, the rest (convex pairs, the two
  // planes) FCL's.
  fcl::CollisionRequest<S> req;
  req.num_max_contacts = 100000;
  req.enable_contact = true;
  using Key = std::pair<const void*, const void*>;
  std::set<Key> want;
  std::map<Key, S> depth;
  const auto key = [](const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b) {
    const void* x = a->collisionGeometry().get();
    const void* y = b->collisionGeometry().get();
    return x < y ? Key{x, y} : Key{y, x};
  };
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      if (i < 2 && j >= 2) {
        const auto& pl = static_cast<const fcl::Plane<S>&>(*objs[i]->collisionGeometry());
        S lo = std::numeric_limits<S>::max(), hi = -lo;
        for (const auto& v : tetra.getVertices()) {
          const S sd = pl.n.dot(objs[j]->getTransform() * v) - pl.d;
          lo = std::min(lo, sd);
          hi = std::max(hi, sd);
        }
        if (lo <= 0 && hi >= 0) {
          want.insert(key(objs[i].get(), objs[j].get()));
          depth[key(objs[i].get(), objs[j].get())] = std::min(-lo, hi);
        }
        continue;
      }
      fcl::CollisionResult<S> r;  // the query's request: FCL's two planes give no contact with it
      if (fcl::collide(objs[i].get(), objs[j].get(), req, r) > 0)
        want.insert(key(objs[i].get(), objs[j].get()));
    }
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  const fcl::CollisionResult<S> all = cube::collideAll<S>(m, req);
  std::set<Key> got;
  for (std::size_t c = 0; c < all.numContacts(); ++c) {
    const auto& ct = all.getContact(c);
    const Key k = ct.o1 < ct.o2 ? Key{ct.o1, ct.o2} : Key{ct.o2, ct.o1};
    got.insert(k);
    const auto d = depth.find(k);
    if (d != depth.end()) {
      EXPECT_NEAR(ct.penetration_depth, d->second, 1e-4);
    }
  }
  EXPECT_EQ(got, want);
  int plane_pairs = 0;
  for (const auto& k : want) plane_pairs += depth.count(k) != 0;
  EXPECT_GT(plane_pairs, 5);
  cube::CollisionData<S> data;
  data.request = req;
  m.collide(&data, cube::defaultCollisionCallback<S>);
  std::set<Key> by_callback;
  for (std::size_t c = 0; c < data.result.numContacts(); ++c) {
    const auto& ct = data.result.getContact(c);
    by_callback.insert(ct.o1 < ct.o2 ? Key{ct.o1, ct.o2} : Key{ct.o2, ct.o1});
  }
  EXPECT_EQ(by_callback, want);
}

// A user's callback that runs the narrow phase, counting its calls.
template <typename S>
struct UserNarrow {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  std::size_t calls = 0;
  UserNarrow() {
    request.num_max_contacts = 1 << 30;
    request.enable_contact = true;
  }
  static bool fn(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    auto& u = *static_cast<UserNarrow*>(d);
    ++u.calls;
    fcl::collide(a, b, u.request, u.result);
    return false;
  }
};

template <typename S>
void cullPairsKnob(std::size_t mine_n, std::size_t n) {
  SCOPED_TRACE(std::to_string(n) + " objects");
  auto kinds = allKinds<S>();
  kinds.erase(std::remove_if(kinds.begin(), kinds.end(),
                             [](const auto& k) {
                               return k.first == "convex" || k.first == "plane" ||
                                      k.first == "halfspace";
                             }),
              kinds.end());  // never culled, they would only dilute the count
  std::mt19937 rng(21);
  // The density of 200 objects in a cube of side 6.
  const double half = 3.0 * std::cbrt(double(n) / 200.0);
  std::uniform_real_distribution<double> u(-half, half);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  for (std::size_t i = 0; i < n; ++i) {
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        kinds[i % kinds.size()].second, randomRotation<S>(rng),
        fcl::Vector3<S>(u(rng), u(rng), u(rng))));
    objs.back()->computeAABB();
  }
  std::vector<fcl::CollisionObject<S>*> mine, theirs;
  for (std::size_t i = 0; i < objs.size(); ++i)
    (i < mine_n ? mine : theirs).push_back(objs[i].get());
  fcl::CollisionObject<S>* query = theirs.back();
  theirs.pop_back();
  cube::Config on;
  on.cull_pairs = true;
  cube::CubeCollisionManager<S> off_m, on_m(on), other;
  fcl::NaiveCollisionManager<S> naive;
  off_m.registerObjects(mine);
  on_m.registerObjects(mine);
  naive.registerObjects(mine);
  naive.setup();
  other.registerObjects(theirs);

  UserNarrow<S> a, b, c;
  off_m.collide(&a, &UserNarrow<S>::fn);
  on_m.collide(&b, &UserNarrow<S>::fn);
  naive.collide(&c, &UserNarrow<S>::fn);
  EXPECT_EQ(b.result.numContacts(), a.result.numContacts());
  EXPECT_EQ(b.result.numContacts(), c.result.numContacts());
  EXPECT_EQ(a.calls, cube::overlappingPairs<S>(off_m).size());
  EXPECT_LT(b.calls * 10, a.calls * 8) << b.calls << " of " << a.calls;  // a fifth or more culled
  EXPECT_GT(a.result.numContacts(), 50u);

  UserNarrow<S> qa, qb;
  off_m.collide(query, &qa, &UserNarrow<S>::fn);
  on_m.collide(query, &qb, &UserNarrow<S>::fn);
  EXPECT_EQ(qb.result.numContacts(), qa.result.numContacts());
  EXPECT_LE(qb.calls, qa.calls);

  UserNarrow<S> ma, mb;
  off_m.collide(&other, &ma, &UserNarrow<S>::fn);
  on_m.collide(&other, &mb, &UserNarrow<S>::fn);
  EXPECT_EQ(mb.result.numContacts(), ma.result.numContacts());
  EXPECT_LT(mb.calls, ma.calls);
}

// Config::cull_pairs: self, object and manager-against-manager collides give a user callback
// that runs fcl::collide the same contacts as without the knob and as fcl::NaiveCollisionManager,
// in fewer calls; without it the callback sees every pair whose boxes overlap. Managers of 170
// and 30 objects (volumes built from the objects) and of 350 and 350 (read from the tables,
// kVolumeMinObjects).
TYPED_TEST(Culling, CullPairsKnobKeepsANarrowPhaseCallbacksContacts) {
  for (const std::size_t mine_n : {std::size_t(170), std::size_t(350)})
    cullPairsKnob<TypeParam>(mine_n, mine_n == 170 ? 200 : 700);
}

// The records' float arithmetic squares differences of coordinates: an object whose centre or
// size is beyond kVolumeMaxScale gets no volumes and its pairs go to FCL. A ball of radius 1e20
// and a unit ball centred on its surface touch; collideAll on a manager that keeps records (300
// more unit balls, apart from everything) finds every contact brute force with fcl::collide finds.
TEST(CullingRange, PairsBeyondTheRecordsRangeAreLeftToFcl) {
  using S = double;
  const S far = 1e20;
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  const auto ball = [&](S r, const fcl::Vector3<S>& at) {
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(std::make_shared<fcl::Sphere<S>>(r),
                                                             fcl::Matrix3<S>::Identity(), at));
    objs.back()->computeAABB();
    return objs.back().get();
  };
  fcl::CollisionObject<S>* big = ball(far, fcl::Vector3<S>::Zero());
  fcl::CollisionObject<S>* small = ball(1, fcl::Vector3<S>(far, 0, 0));
  for (int i = 0; i < 300; ++i) ball(1, fcl::Vector3<S>(S(3 * i), 3 * far, 0));
  ASSERT_TRUE(collides(*big, *small));
  cube::detail::VolumeSphere sphere;
  cube::detail::VolumeShape shape;
  cube::detail::buildVolume(*small, sphere, shape);
  EXPECT_LT(sphere.r, 0.f) << "no volumes beyond the records range";
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 20;
  std::size_t expected = 0;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      fcl::CollisionResult<S> r;
      expected += fcl::collide(objs[i].get(), objs[j].get(), all, r);
    }
  ASSERT_GT(expected, 0u);
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  m.setup();
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(), expected);
}

}  // namespace
