// The culling at the touching position FCL's own narrow phase finds (bisection with fcl::collide):
// pairs there are kept, proofs of contact hold only where FCL reports contact, and the round and
// inner bounds decide only what FCL says.

#include <gtest/gtest.h>

#include "support/culling_kinds.h"

namespace {

using namespace cullingkinds;

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

}  // namespace
