// The cull of pairs of no table (pair lists, other kinds of manager, FCL's callbacks): the
// records' engine on records built on the fly level by level (pipeline/cull.cpp), against FCL.

#include <gtest/gtest.h>

#include "pipeline/pair_volumes.h"
#include "support/culling_kinds.h"

namespace {

using namespace cullingkinds;

// Pairs of no table (pair lists, other managers, FCL's callbacks) are judged on records built
// on the fly, level by level: the spheres FCL keeps per geometry, then the boxes of the local
// AABBs, then (for a request whose touching pairs may be proved) the balls inside. Every kind,
// planes and halfspaces, a mesh off its frame's centre, random poses near the origin and 1,000
// away: a pair judged apart never collides, one proved touching does, a pair that cannot beat a
// distance or be within a margin is farther than it; planes and halfspaces are always left to
// FCL; and each level decides pairs the one before leaves open (the boxes prove apart pairs whose
// spheres overlap, the balls inside prove pairs touching).
TYPED_TEST(Culling, ObjectsOfNoTableAreJudgedLevelByLevelAsFclAnswers) {
  using S = TypeParam;
  using cube::detail::Answer;
  auto kinds = allKinds<S>();
  auto shifted = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
  fcl::Transform3<S> off = fcl::Transform3<S>::Identity();
  off.translation() = fcl::Vector3<S>(0.7, 0.2, -0.3);
  fcl::generateBVHModel(*shifted, fcl::Box<S>(0.6, 0.3, 0.4), off);
  kinds.emplace_back("mesh off centre", shifted);
  const S tol = defaultTolerance<S>();
  const cube::detail::PairJudge<S> loose(tol, false, true), proving(fcl::CollisionRequest<S>{});
  const cube::detail::PairJudge<S> measuring{fcl::DistanceRequest<S>{}};
  const float rate = cube::detail::volumeMarginRate(tol);
  const auto flat = [](const std::string& k) { return k == "plane" || k == "halfspace"; };
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(-1.4, 1.4), reach(0.0, 0.5);
  std::size_t pairs = 0, by_boxes = 0, proved = 0, not_beating = 0, not_within = 0;
  for (const double offset : {0.0, 1000.0})
    for (const auto& [na, ga] : kinds)
      for (const auto& [nb, gb] : kinds) {
        if (!fclCanCollide(na, nb)) continue;
        fcl::CollisionObject<S> a(ga), b(gb);
        const fcl::Vector3<S> base(S(offset), S(-0.5 * offset), S(0.25 * offset));
        for (int rep = 0; rep < 25; ++rep) {
          a.setTransform(randomRotation<S>(rng), base);
          b.setTransform(randomRotation<S>(rng),
                         base + fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))));
          a.computeAABB();
          b.computeAABB();
          const std::string what = na + " vs " + nb + " at " + std::to_string(offset);
          const bool hit = collides(a, b);
          const Answer without_proofs = loose.collide(a, b), with_proofs = proving.collide(a, b);
          ++pairs;
          if (flat(na) || flat(nb)) {
            EXPECT_EQ(without_proofs, Answer::kComputed) << what;
            EXPECT_EQ(with_proofs, Answer::kComputed) << what;
            continue;
          }
          ASSERT_FALSE(without_proofs == Answer::kApart && hit) << what;
          ASSERT_FALSE(with_proofs == Answer::kApart && hit) << what << " (proofs)";
          ASSERT_FALSE(with_proofs == Answer::kProved && !hit) << what;
          ASSERT_NE(without_proofs, Answer::kProved) << what;
          proved += with_proofs == Answer::kProved;
          cube::detail::VolumeBall<S> ba, bb;
          cube::detail::buildBall(a, ba);
          cube::detail::buildBall(b, bb);
          const auto spheres =
              cube::detail::sphereGap(ba.sphere, ba.scale, bb.sphere, bb.scale, rate);
          if (!(spheres.gap > spheres.margin)) by_boxes += without_proofs == Answer::kApart;
          if (!fclCanMeasure(na, nb)) continue;
          fcl::DistanceResult<S> res;
          const S d = fcl::distance(&a, &b, fcl::DistanceRequest<S>(), res);
          const S best = S(reach(rng)), m = S(reach(rng));
          if (!measuring.mayBeat(a, b, best)) {
            ASSERT_GT(d, best) << what;
            ++not_beating;
          }
          if (!measuring.mayBeWithin(a, b, m)) {
            ASSERT_TRUE(!hit && d > m) << what << " margin " << m;
            ++not_within;
          }
        }
      }
  EXPECT_GT(by_boxes * 20, pairs) << by_boxes << " of " << pairs;
  EXPECT_GT(proved * 200, pairs) << proved << " of " << pairs;
  EXPECT_GT(not_beating * 10, pairs) << not_beating << " of " << pairs;
  EXPECT_GT(not_within * 10, pairs) << not_within << " of " << pairs;
}

// A query's pairs without records share each object's levels (PairVolumes::fly): built once, in
// whatever order its pairs ask for them (a proof's ball inside before another pair's box gap, a
// distance bound after a collide), they give every pair the verdict and the bound of levels built
// for that pair alone. Objects whose ids share a place in the memo (ids 64 apart) get none
// together, and an object that takes over a place gets its own levels there.
TYPED_TEST(Culling, KeptLevelsJudgeEveryPairAsLevelsBuiltForItAlone) {
  using S = TypeParam;
  using cube::detail::ObjectId;
  auto kinds = allKinds<S>();
  const S tol = defaultTolerance<S>();
  const cube::detail::PairJudge<S> loose(tol, false, true), proving(fcl::CollisionRequest<S>{});
  const cube::detail::PairJudge<S> measuring{fcl::DistanceRequest<S>{}};
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.2, 1.2), reach(0.0, 0.5);
  std::uniform_int_distribution<std::size_t> pick(0, 2 * kinds.size() - 1);
  // Two objects of each kind, close together, object i under id i (fewer than 64 objects).
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  for (int copy = 0; copy < 2; ++copy)
    for (const auto& kind : kinds) {
      objs.push_back(std::make_unique<fcl::CollisionObject<S>>(kind.second));
      objs.back()->setTransform(randomRotation<S>(rng),
                                fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))));
      objs.back()->computeAABB();
    }
  cube::detail::PairVolumes<S> volumes;
  std::size_t judged = 0, shared_place = 0;
  for (int rep = 0; rep < 3000; ++rep) {
    const std::size_t i = pick(rng), j = pick(rng);
    if (i == j) continue;
    // Now and then object i under the id 64 above its neighbour's: the neighbour's place.
    const ObjectId ii = rep % 7 == 0 ? ObjectId((i + 1) % objs.size() + 64) : ObjectId(i);
    const ObjectId jj = ObjectId(j);
    fcl::CollisionObject<S>&a = *objs[i], &b = *objs[j];
    cube::detail::FlyVolumes<S>*fa, *fb;
    volumes.fly(&a, ii, &b, jj, fa, fb);
    if (ii % 64 == jj % 64) {  // one place
      EXPECT_EQ(fa, nullptr);
      EXPECT_EQ(fb, nullptr);
      ++shared_place;
      continue;
    }
    ASSERT_NE(fa, nullptr);
    ASSERT_NE(fb, nullptr);
    ++judged;
    const auto what = ::testing::Message() << "pair " << i << ", " << j << " rep " << rep;
    switch (rep % 3) {  // the judges in turn, so that each meets levels the others built
      case 0:
        EXPECT_EQ(proving.collide(*fa, *fb), proving.collide(a, b)) << what;
        break;
      case 1:
        EXPECT_EQ(loose.collide(*fa, *fb), loose.collide(a, b)) << what;
        break;
      default: {
        const S best = S(reach(rng));
        EXPECT_EQ(measuring.mayBeat(*fa, *fb, best), measuring.mayBeat(a, b, best))
            << what << " best " << best;
      }
    }
  }
  EXPECT_GT(judged, 2000u);
  EXPECT_GT(shared_place, 0u);
}

// The records' float arithmetic squares differences of coordinates: an object whose centre or
// size is beyond kVolumeMaxScale gets no volumes, on the fly as in the tables. A ball of radius
// 1e20 and a unit ball on its surface touch: the pair is left to FCL, by the judge and by
// collidePairs, which finds the contact fcl::collide finds.
TEST(CullingRange, ObjectsOfNoTableBeyondTheRecordsRangeAreLeftToFcl) {
  using S = double;
  const S far = 1e20;
  fcl::CollisionObject<S> big(std::make_shared<fcl::Sphere<S>>(far), fcl::Matrix3<S>::Identity(),
                              fcl::Vector3<S>::Zero());
  fcl::CollisionObject<S> small(std::make_shared<fcl::Sphere<S>>(1), fcl::Matrix3<S>::Identity(),
                                fcl::Vector3<S>(far, 0, 0));
  big.computeAABB();
  small.computeAABB();
  ASSERT_TRUE(collides(big, small));
  cube::detail::VolumeBall<S> ball;
  cube::detail::buildBall(small, ball);
  EXPECT_LT(ball.sphere.r, 0.f) << "no volumes beyond the records range";
  const cube::detail::PairJudge<S> judge{fcl::CollisionRequest<S>{}};
  EXPECT_EQ(judge.collide(big, small), cube::detail::Answer::kComputed);
  const std::vector<cube::ObjectPair<S>> pairs = {{&big, &small}, {&small, &big}};
  for (const auto& r : cube::collidePairs<S>(pairs, fcl::CollisionRequest<S>()))
    EXPECT_TRUE(r.isCollision());
}

}  // namespace
