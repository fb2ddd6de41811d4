#pragma once

// What the narrow-phase pipeline's files (collide_stream.cpp, distance_search.cpp,
// narrow_phase.cpp) share: how a pair was answered, when threads pay, and the steps of answering
// one pair without the cache (cache.h holds those with it). When threads pay: thread_policy.h.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/contact.h>

#include <cstddef>
#include <cstdint>

#include "core/thread_policy.h"
#include "cube_collision/narrow_phase.h"
#include "pipeline/cull.h"

namespace cube {
namespace detail {

/// How a pair was answered: proved apart or touching by the pair judge (pair_judge.h), found in
/// the cache, or by FCL.
enum class Answer : std::uint8_t { kApart, kProved, kCached, kComputed };

// Work, the unit of thread_policy.h's thresholds, is counted in candidate pairs of shapes: the
// cull and, for some of them, FCL's call. A pair with a mesh or an octree counts kHeavyPairWork
// (its FCL call walks two hierarchies: orders of magnitude dearer than a shape pair's).
constexpr std::size_t kHeavyPairWork = 64;
// A pair of shapes that FCL 0.7 answers with libccd's GJK rather than in closed form (see
// workOf): several times a closed form's call.
constexpr std::size_t kGjkPairWork = 6;

inline void addStats(NarrowPhaseStats* out, const NarrowPhaseStats& s) {
  if (out == nullptr) return;
  out->candidate_pairs += s.candidate_pairs;
  out->culled += s.culled;
  out->proved += s.proved;
  out->cached += s.cached;
  out->narrow_calls += s.narrow_calls;
}

// Culling and caching leave requests with costs or a cached GJK guess alone: an octree's cost
// sources come from cells its box does not bound, and a guess is carried from pair to pair.
template <typename S>
bool plainRequest(const fcl::CollisionRequest<S>& request) {
  return !request.enable_cost && !request.enable_cached_gjk_guess;
}

// A verdict of the tight volumes as an answer: kComputed for a pair FCL must answer.
inline Answer answerOf(Verdict v) {
  switch (v) {
    case Verdict::kApart:
      return Answer::kApart;
    case Verdict::kTouching:
      return Answer::kProved;
    case Verdict::kUnknown:
      break;
  }
  return Answer::kComputed;
}

// The one contact FCL's shape collision gives a touching pair when the request asks for no
// contact geometry (position, normal and depth left as FCL leaves them: unset).
template <typename S>
fcl::Contact<S> provedContact(const ObjectPair<S>& pair) {
  return fcl::Contact<S>(pair.first->collisionGeometry().get(),
                         pair.second->collisionGeometry().get(), fcl::Contact<S>::NONE,
                         fcl::Contact<S>::NONE);
}

// Counts one answer of a kind.
inline void count(NarrowPhaseStats& stats, Answer kind) {
  switch (kind) {
    case Answer::kApart:
      ++stats.culled;
      return;
    case Answer::kProved:
      ++stats.proved;
      return;
    case Answer::kCached:
      ++stats.cached;
      return;
    case Answer::kComputed:
      ++stats.narrow_calls;
      return;
  }
}

// What a pair handed to the threads costs, in thread_policy.h's unit (a candidate pair of
// shapes): a pair with a mesh or an octree counts kHeavyPairWork. The objects' geometries are
// read for their types (a cache miss on the calling thread for a pair not yet called).
template <typename S>
std::size_t workOf(const ObjectPair<S>& pair) {
  const auto heavy = [](const fcl::CollisionObject<S>* o) {
    const fcl::OBJECT_TYPE t = o->getObjectType();
    return t == fcl::OT_BVH || t == fcl::OT_OCTREE;
  };
  return heavy(pair.first) || heavy(pair.second) ? kHeavyPairWork : 1;
}

// workOf from the two objects' records (VolumeShape::flags), without touching the geometries,
// and finer: FCL 0.7's libccd solver answers a sphere with a sphere, box, capsule or cylinder,
// and a box with a box, in closed form (planes and halfspaces have no records); any other pair of
// shapes runs GJK and counts kGjkPairWork.
inline std::size_t workOf(std::uint32_t flags_a, std::uint32_t flags_b) {
  if (((flags_a | flags_b) & kVolumeHeavy) != 0) return kHeavyPairWork;
  const auto closed = [](std::uint32_t x, std::uint32_t y) {
    return (x & kVolumeSphere) != 0 && (y & (kVolumeSphere | kVolumeBox | kVolumeRound)) != 0;
  };
  if (closed(flags_a, flags_b) || closed(flags_b, flags_a)) return 1;
  return (flags_a & flags_b & kVolumeBox) != 0 ? 1 : kGjkPairWork;
}

}  // namespace detail
}  // namespace cube
