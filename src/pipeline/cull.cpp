// The cull for objects of no table (cull.h: verdictOnTheFly, separationOnTheFly): the records'
// engine on records built per pair, level by level (core/volume.h: the sphere, the box, the ball
// inside), each only for the pairs the last leaves open.

#include "pipeline/cull.h"

#include <limits>

namespace cube {
namespace detail {

namespace {

// The radius of the ball about the centre of an object's box that the box holds (a sphere's
// own), from its sphere-level record: how far the box may reach beyond the centres' line.
template <typename S>
float smallestReach(const VolumeBall<S>& ball) {
  if (ball.exact) return ball.sphere.r;
  const fcl::AABB<S>& local = ball.geometry->aabb_local;
  return float(S(0.5) * (local.max_ - local.min_).minCoeff());
}

// An object's levels built for one pair alone: each level read at most once, so built when read,
// with no note of it (FlyVolumes' interface, for the same verdicts).
template <typename S>
struct PairLevels {
  VolumeBall<S> ball;
  VolumeShape shape;
  explicit PairLevels(const fcl::CollisionObject<S>& o) { buildBall(o, ball); }
  bool hasBox() { return buildBox(ball, shape); }
  bool hasInner() { return buildInner(ball, shape); }
};

// The verdict and the bound on two objects' levels (PairLevels or FlyVolumes), each level
// built only where the one before leaves the pair open.
template <class Levels>
[[gnu::always_inline]] inline Verdict verdictOnLevels(Levels& a, Levels& b, float rate,
                                                      bool prove) {
  const auto &ba = a.ball, &bb = b.ball;
  if (!(ba.sphere.r >= 0.f) || !(bb.sphere.r >= 0.f)) return Verdict::kUnknown;
  const SphereGap s = sphereGap(ba.sphere, ba.scale, bb.sphere, bb.scale, rate);
  if (s.gap > s.margin) return Verdict::kApart;
  if (!prove && ba.exact && bb.exact) return Verdict::kUnknown;  // the spheres were exact
  if (!a.hasBox() || !b.hasBox()) return Verdict::kUnknown;
  const VolumeGap g = separationPastSpheres(s, ba.sphere, a.shape, bb.sphere, b.shape, 0.f);
  if (g.lower_bound > g.margin) return Verdict::kApart;
  if (!prove || !a.hasInner() || !b.hasInner()) return Verdict::kUnknown;
  return innerBallsMeet(ba.sphere, a.shape, bb.sphere, b.shape, rate) ? Verdict::kTouching
                                                                      : Verdict::kUnknown;
}

template <class Levels>
[[gnu::always_inline]] inline VolumeGap separationOnLevels(Levels& a, Levels& b, float rate,
                                                           float enough) {
  const auto &ba = a.ball, &bb = b.ball;
  if (!(ba.sphere.r >= 0.f) || !(bb.sphere.r >= 0.f))
    return {-std::numeric_limits<float>::infinity(), 0.f};
  const SphereGap s = sphereGap(ba.sphere, ba.scale, bb.sphere, bb.scale, rate);
  if ((ba.exact && bb.exact) || s.gap > enough + s.margin) return {s.gap, s.margin};
  // Each box holds the ball of its smallest half extent: where those balls' gap cannot clear
  // enough, neither can the boxes' (separationOf's own test), and they are not built.
  if (enough < std::numeric_limits<float>::infinity() &&
      !(s.centres - smallestReach(ba) - smallestReach(bb) > enough + s.margin))
    return {s.gap, s.margin};
  // separationOf reads no more than the boxes.
  if (!a.hasBox() || !b.hasBox()) return {s.gap, s.margin};
  return separationPastSpheres(s, ba.sphere, a.shape, bb.sphere, b.shape, enough);
}

}  // namespace

template <typename S>
Verdict verdictOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                        float rate, bool prove) {
  PairLevels<S> la(a), lb(b);
  return verdictOnLevels(la, lb, rate, prove);
}

template <typename S>
Verdict verdictOnTheFly(FlyVolumes<S>& a, FlyVolumes<S>& b, float rate, bool prove) {
  return verdictOnLevels(a, b, rate, prove);
}

template <typename S>
VolumeGap separationOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                             float rate, float enough) {
  PairLevels<S> la(a), lb(b);
  return separationOnLevels(la, lb, rate, enough);
}

template <typename S>
VolumeGap separationOnTheFly(FlyVolumes<S>& a, FlyVolumes<S>& b, float rate, float enough) {
  return separationOnLevels(a, b, rate, enough);
}

template Verdict verdictOnTheFly<double>(const fcl::CollisionObject<double>&,
                                         const fcl::CollisionObject<double>&, float, bool);
template Verdict verdictOnTheFly<float>(const fcl::CollisionObject<float>&,
                                        const fcl::CollisionObject<float>&, float, bool);
template VolumeGap separationOnTheFly<double>(FlyVolumes<double>&, FlyVolumes<double>&, float,
                                              float);
template VolumeGap separationOnTheFly<float>(FlyVolumes<float>&, FlyVolumes<float>&, float, float);
template Verdict verdictOnTheFly<double>(FlyVolumes<double>&, FlyVolumes<double>&, float, bool);
template Verdict verdictOnTheFly<float>(FlyVolumes<float>&, FlyVolumes<float>&, float, bool);
template VolumeGap separationOnTheFly<double>(const fcl::CollisionObject<double>&,
                                              const fcl::CollisionObject<double>&, float, float);
template VolumeGap separationOnTheFly<float>(const fcl::CollisionObject<float>&,
                                             const fcl::CollisionObject<float>&, float, float);

}  // namespace detail
}  // namespace cube
