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

}  // namespace

template <typename S>
Verdict verdictOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                        float rate, bool prove) {
  VolumeBall<S> ba, bb;
  buildBall(a, ba);
  buildBall(b, bb);
  if (!(ba.sphere.r >= 0.f) || !(bb.sphere.r >= 0.f)) return Verdict::kUnknown;
  const SphereGap s = sphereGap(ba.sphere, ba.scale, bb.sphere, bb.scale, rate);
  if (s.gap > s.margin) return Verdict::kApart;
  if (!prove && ba.exact && bb.exact) return Verdict::kUnknown;  // the spheres were exact
  VolumeShape ha, hb;
  if (!buildBox(ba, ha) || !buildBox(bb, hb)) return Verdict::kUnknown;
  const VolumeGap g = separationPastSpheres(s, ba.sphere, ha, bb.sphere, hb, 0.f);
  if (g.lower_bound > g.margin) return Verdict::kApart;
  if (!prove || !buildInner(ba, ha) || !buildInner(bb, hb)) return Verdict::kUnknown;
  return innerBallsMeet(ba.sphere, ha, bb.sphere, hb, rate) ? Verdict::kTouching
                                                            : Verdict::kUnknown;
}

template <typename S>
VolumeGap separationOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                             float rate, float enough) {
  VolumeBall<S> ba, bb;
  buildBall(a, ba);
  buildBall(b, bb);
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
  VolumeShape ha, hb;
  if (!buildBox(ba, ha) || !buildBox(bb, hb)) return {s.gap, s.margin};
  return separationPastSpheres(s, ba.sphere, ha, bb.sphere, hb, enough);
}

template Verdict verdictOnTheFly<double>(const fcl::CollisionObject<double>&,
                                         const fcl::CollisionObject<double>&, float, bool);
template Verdict verdictOnTheFly<float>(const fcl::CollisionObject<float>&,
                                        const fcl::CollisionObject<float>&, float, bool);
template VolumeGap separationOnTheFly<double>(const fcl::CollisionObject<double>&,
                                              const fcl::CollisionObject<double>&, float, float);
template VolumeGap separationOnTheFly<float>(const fcl::CollisionObject<float>&,
                                             const fcl::CollisionObject<float>&, float, float);

}  // namespace detail
}  // namespace cube
