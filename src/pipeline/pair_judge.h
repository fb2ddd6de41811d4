#pragma once

// The pair judge: the one place that decides a candidate pair before FCL, for every query. A
// collide asks whether the pair is apart, proved touching, or needs FCL; a distance search
// whether the pair can beat the best distance so far; a query within margins whether the pair can
// be within the margins' sum. The judge reads the pair's records: the object tables', or built
// for an object of no table (PairVolumes), or, for a pair without records, built on the fly
// (cull.h: level by level, the spheres first, each level only where the last leaves it open).
// Queries differ by what they do with its answers, not by how a pair is decided.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/distance_request.h>

#include <cfloat>
#include <limits>

#include "core/volume.h"
#include "pipeline/answers.h"
#include "pipeline/cull.h"

namespace cube {
namespace detail {

/// An object's records as the judge reads them (buildVolume): the object table's, or built for
/// an object of no table.
struct Records {
  const VolumeSphere* sphere;
  const VolumeShape* shape;
};

/// Decides candidate pairs for one request. The margins of its bounds come from FCL's tolerance
/// for the answers it stands in for (separation, volumeMarginRate), so that what it decides is
/// what FCL would answer. Const: any number of threads at once.
template <typename S>
class PairJudge {
 public:
  using Object = fcl::CollisionObject<S>;

  /// `tolerance`: FCL's (gjk_tolerance or distance_tolerance) for the answers judged; `prove`:
  /// touching pairs may be proved (the request's answer for them is known without FCL,
  /// provable()); `cull`: false leaves every pair of a collide to FCL.
  PairJudge(S tolerance, bool prove, bool cull)
      : rate_(volumeMarginRate(tolerance)), prove_(prove), cull_(cull) {}
  /// A collide request's judge: culls unless it has costs or a cached GJK guess (plainRequest),
  /// proves where provable(request).
  explicit PairJudge(const fcl::CollisionRequest<S>& request)
      : PairJudge(S(request.gjk_tolerance), provable(request), plainRequest(request)) {}
  /// A distance request's judge.
  explicit PairJudge(const fcl::DistanceRequest<S>& request)
      : PairJudge(S(request.distance_tolerance), false, true) {}

  /// Whether the judge may answer a collide's pair (else every pair is kComputed).
  bool culls() const { return cull_; }
  /// The margin of its record bounds per unit of scale (volumeMarginRate of the tolerance): how
  /// much a box must grow for the records' margin to stay inside it.
  float rate() const { return rate_; }

  // ---- A collide: kApart, kProved or kComputed (FCL must answer).

  /// On the pair's records: verdictOf. For a judge that culls() (its callers look the records
  /// up only then: no test per pair here).
  Answer collide(const Records& a, const Records& b) const {
    return answerOf(verdictOf(*a.sphere, *a.shape, *b.sphere, *b.shape, rate_, prove_));
  }
  /// The cheaper part of collide on records (looseVerdictOf): what a cache lookup goes after.
  Answer collideLoose(const Records& a, const Records& b) const {
    return answerOf(looseVerdictOf(*a.sphere, *a.shape, *b.sphere, *b.shape, rate_, prove_));
  }
  /// The rest of collide on records (tightVerdictOf), for a pair collideLoose left kComputed.
  Answer collideTight(const Records& a, const Records& b) const {
    return answerOf(tightVerdictOf(*a.sphere, *a.shape, *b.sphere, *b.shape, rate_, prove_));
  }
  /// On records built on the fly, for a pair without records (verdictOnTheFly).
  Answer collide(const Object& a, const Object& b) const {
    if (!cull_) return Answer::kComputed;
    return answerOf(verdictOnTheFly(a, b, rate_, prove_));
  }
  /// On records built on the fly and kept (PairVolumes::fly), building the levels it reads.
  Answer collide(FlyVolumes<S>& a, FlyVolumes<S>& b) const {
    if (!cull_) return Answer::kComputed;
    return answerOf(verdictOnTheFly(a, b, rate_, prove_));
  }

  // ---- A distance search: false when FCL's distance of the pair would exceed `best`, the
  // smallest distance so far (which the pair then leaves as it is).

  /// On the pair's records: separationOf's bound, less its margin, against best.
  bool mayBeat(const Records& a, const Records& b, S best) const {
    if (anyBeats(best)) return true;
    const VolumeGap g =
        separationOf(*a.sphere, *a.shape, *b.sphere, *b.shape, rate_, enoughOf(best));
    return !(double(g.lower_bound) - double(g.margin) > double(best));
  }
  /// On records built on the fly, for a pair without records (separationOnTheFly).
  bool mayBeat(const Object& a, const Object& b, S best) const {
    if (anyBeats(best)) return true;
    const VolumeGap g = separationOnTheFly(a, b, rate_, enoughOf(best));
    return !(double(g.lower_bound) - double(g.margin) > double(best));
  }
  /// On records built on the fly and kept (PairVolumes::fly), building the levels it reads.
  bool mayBeat(FlyVolumes<S>& a, FlyVolumes<S>& b, S best) const {
    if (anyBeats(best)) return true;
    const VolumeGap g = separationOnTheFly(a, b, rate_, enoughOf(best));
    return !(double(g.lower_bound) - double(g.margin) > double(best));
  }

  // ---- Within a margin: whether the pair can be within `m` (>= 0, the sum of the objects'
  // margins) of each other, touching included.

  /// On the pair's records: kApart when it cannot (its bound beats m, with room for rounding m
  /// to a float); kTouching when the pair is proved touching (needs `prove`); else kUnknown.
  /// For m = 0, collide's verdict on the records.
  Verdict withinMargin(const Records& a, const Records& b, S m) const {
    const VolumeSphere &sa = *a.sphere, &sb = *b.sphere;
    const VolumeShape &ha = *a.shape, &hb = *b.shape;
    if (m == S(0)) return verdictOf(sa, ha, sb, hb, rate_, prove_);
    const float within = float(m);
    const float beyond = within + 4.f * FLT_EPSILON * within;  // m's rounding to a float
    const VolumeGap gap = separationOf(sa, ha, sb, hb, rate_, within);
    if (gap.lower_bound > beyond + gap.margin) return Verdict::kApart;
    if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return Verdict::kUnknown;  // no volumes: no bound
    if (prove_ && ha.inner_r > 0.f && hb.inner_r > 0.f && innerBallsMeet(sa, ha, sb, hb, rate_))
      return Verdict::kTouching;
    // The round shapes' bounds, farther than the margin: kApart; or the inner volumes' proof.
    return tightVerdictOf(sa, ha, sb, hb, rate_, prove_, beyond);
  }
  /// On records built on the fly, for a pair without records: false when their bound beats m
  /// (as withinMargin's kApart).
  bool mayBeWithin(const Object& a, const Object& b, S m) const {
    const float within = float(m);
    const VolumeGap gap = separationOnTheFly(a, b, rate_, within);
    return !(gap.lower_bound > within + gap.margin + 4.f * FLT_EPSILON * within);
  }

 private:
  // A best beyond floats (FCL's results start at the largest S: a search's first pairs) or NaN:
  // the pair goes to FCL without reading the records (a bound that overflowed floats must not
  // cull it).
  static bool anyBeats(S best) { return !(double(best) < double(FLT_MAX)); }
  // A distance as separationOf's `enough` (infinite beyond floats).
  static float enoughOf(S best) {
    const double within = double(best);
    return within >= double(FLT_MAX) ? std::numeric_limits<float>::infinity() : float(within);
  }

  float rate_;
  bool prove_;
  bool cull_;
};

}  // namespace detail
}  // namespace cube
