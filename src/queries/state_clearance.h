#pragma once

// The clearance of a placed state (StateChecker::clearanceOf and what it calls): the smallest
// distance from any link to the world and, with self pairs, between the links, the pairs the
// records prove no nearer than the best so far left out. Included by state_checker.h only, after
// the class.

#include <cmath>
#include <cstdint>

#include "core/kernels/box_ops.h"

namespace cube {
namespace detail {

template <typename S>
inline bool StateChecker<S>::onWorldNear(Object* w, ObjectId iw, Object*, ObjectId, void* data,
                                         S& best) {
  WorldNear& near = *static_cast<WorldNear*>(data);
  StateChecker& c = *near.checker;
  const VolumeSphere* s;
  const VolumeShape* h;
  c.worldRecords(*w, iw, s, h);
  const Slot& slot = c.linkRecords(near.link);
  const bool stop =
      c.lower(*near.closest, c.object(near.link), slot.sphere, slot.shape, *w, *s, *h);
  best = near.closest->bound();
  return stop;
}

template <typename S>
inline bool StateChecker<S>::lower(Closest<S>& closest, const Object& a, const VolumeSphere& sa,
                                   const VolumeShape& ha, const Object& b, const VolumeSphere& sb,
                                   const VolumeShape& hb) {
  if (!distance_judge_.mayBeat(Records{&sa, &ha}, Records{&sb, &hb}, closest.bound())) return false;
  closest.add(pairDistance(a, b));
  return closest.done();
}

template <typename S>
inline S StateChecker<S>::clearanceOf(bool self) {
  fcl::DistanceResult<S> result;  // the distance alone: no nearest points are kept
  Closest<S> closest(result);
  const std::size_t n = links_.size();
  for (std::size_t l = 0; l < n && !closest.done(); ++l) {
    if (world_.size() == 0) break;
    typename Broadphase<S>::Probe p = probe(l);
    p.margin = S(0);
    WorldNear near{this, std::uint32_t(l), &closest};
    S bound = closest.bound();  // the walk's, lowered by onWorldNear
    world_.distance(p, &near, DistanceFn<S>(&StateChecker::onWorldNear), bound, nullptr);
  }
  for (std::size_t i = 0; self && i < n && !closest.done(); ++i)
    for (std::uint32_t k = links_.after_at[i]; k < links_.after_at[i + 1] && !closest.done(); ++k) {
      const std::uint32_t j = links_.after[k];
      if (std::sqrt(boxGap2(rateBox(i), rateBox(j))) >= double(closest.bound())) continue;
      const Slot& x = linkRecords(std::uint32_t(i));
      const Slot& y = linkRecords(j);
      lower(closest, object(std::uint32_t(i)), x.sphere, x.shape, object(j), y.sphere, y.shape);
    }
  return closest.bound();
}

}  // namespace detail
}  // namespace cube
