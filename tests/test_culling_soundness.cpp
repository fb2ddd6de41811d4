// The culling in front of the narrow phase (src/pipeline/cull.h) and the pair judge never answer
// against FCL: a culled pair never collides (every FCL primitive and meshes, random rotations),
// the judge's verdicts agree with fcl::collide and fcl::distance, and the distance bound never
// exceeds FCL's distance.

#include <gtest/gtest.h>

#include "support/culling_kinds.h"

namespace {

using namespace cullingkinds;

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
        const PairRecords records = poseAtRandom(a, b, rng, u);
        const Records ra = records.a(), rb = records.b();
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

// Within a margin, capsules, cylinders and cones are judged on their own round bounds, not only
// on their boxes: pairs whose oriented boxes come within the margin while the shapes stay
// farther apart than it (a corner of one box past the other's round side) are settled apart,
// and never one that FCL finds within the margin.
TYPED_TEST(Culling, WithinMarginSettlesRoundPairsTheirBoxesLeaveOpen) {
  using S = TypeParam;
  using cube::detail::Verdict;
  const fcl::CollisionRequest<S> request;
  const fcl::DistanceRequest<S> distance_request;
  const cube::detail::PairJudge<S> judge(request);
  std::vector<std::pair<std::string, Geometry<S>>> round;
  for (const auto& kind : allKinds<S>())
    if (kind.first == "capsule" || kind.first == "cone" || kind.first == "cylinder")
      round.push_back(kind);
  ASSERT_EQ(round.size(), 3u);
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(-1.6, 1.6), margin(0.02, 0.15);
  std::size_t boxes_open = 0, settled = 0;
  for (const auto& [na, ga] : round)
    for (const auto& [nb, gb] : round)
      for (int rep = 0; rep < 400; ++rep) {
        fcl::CollisionObject<S> a(ga), b(gb);
        const PairRecords records = poseAtRandom(a, b, rng, u);
        const S m = S(margin(rng));
        const cube::detail::VolumeGap boxes = cube::detail::separationOf(
            records.sa, records.ha, records.sb, records.hb, float(judge.rate()), float(m));
        if (boxes.lower_bound > float(m) + boxes.margin) continue;  // the boxes settle it
        fcl::DistanceResult<S> res;
        const S d = fcl::distance(&a, &b, distance_request, res);
        if (!(d > S(2) * m)) continue;  // only pairs well beyond the margin
        ++boxes_open;
        const Verdict v = judge.withinMargin(records.a(), records.b(), m);
        ASSERT_NE(v, Verdict::kTouching) << na << " vs " << nb << " rep " << rep;
        settled += v == Verdict::kApart;
      }
  // The scene has such pairs, and the round bounds settle most of them.
  ASSERT_GT(boxes_open, 200u);
  EXPECT_GT(settled * 2, boxes_open) << settled << " of " << boxes_open;
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
        const PairRecords records = poseAtRandom(a, b, rng, u);
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
        const float rate = cube::detail::volumeMarginRate(S(req.distance_tolerance));
        for (const float enough : {0.f, std::numeric_limits<float>::infinity()}) {
          const auto gap = cube::detail::separationOf(records.sa, records.ha, records.sb,
                                                      records.hb, rate, enough);
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

}  // namespace
