#pragma once

// Continuous edges' motion bounds (batch.h, "Continuous edges"): the caller's bounds checked, and
// the raise of each link's margin at a state of an edge, from the caller's bounds or from the
// poses (the links' SE(3) bounds, kernels/se3_bounds.h). Private to the library.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/kernels/se3_bounds.h"
#include "queries/body_links.h"

namespace cube {
namespace detail {

// Per link: the largest distance from its frame's origin to a corner of its local AABB (every
// point of the link lies within it).
template <typename S>
std::vector<S> linkReach(const typename BodySet<S>::Links& links) {
  std::vector<S> reach(links.size());
  for (std::size_t l = 0; l < links.size(); ++l) {
    S r2 = 0;
    for (int d = 0; d < 3; ++d) {
      const S far = std::fabs(links.mid_of[d][l]) + links.half_of[d][l];
      r2 += far * far;
    }
    reach[l] = std::sqrt(r2);
  }
  return reach;
}

// Whether v[0 .. n) are all finite and >= 0 (-0 included): one pass without a branch per value
// (a NaN fails both tests), so that a check that reads few states of a long edge pays little for
// its bounds; the offender is sought only where one is found.
template <typename S>
bool allFiniteNonNegative(const S* v, std::size_t n) {
  // Masks of integers: the compiler makes vector compares of this loop for float.
  using Mask = std::conditional_t<sizeof(S) == 8, std::int64_t, std::int32_t>;
  Mask good = -1;
  std::size_t i = 0;
#if defined(__SSE2__)
  if constexpr (std::is_same<S, double>::value) {  // not vectorized by the compiler: two by two
    const __m128d zero = _mm_setzero_pd();
    const __m128d top = _mm_set1_pd(std::numeric_limits<double>::max());
    __m128d g0 = _mm_cmpeq_pd(zero, zero), g1 = g0;
    for (; i + 4 <= n; i += 4) {
      const __m128d x0 = _mm_loadu_pd(v + i), x1 = _mm_loadu_pd(v + i + 2);
      g0 = _mm_and_pd(g0, _mm_and_pd(_mm_cmpge_pd(x0, zero), _mm_cmple_pd(x0, top)));
      g1 = _mm_and_pd(g1, _mm_and_pd(_mm_cmpge_pd(x1, zero), _mm_cmple_pd(x1, top)));
    }
    if (_mm_movemask_pd(_mm_and_pd(g0, g1)) != 3) return false;
  }
#endif
  for (; i < n; ++i) {
    const Mask ge = v[i] >= S(0) ? -1 : 0;
    const Mask le = v[i] <= std::numeric_limits<S>::max() ? -1 : 0;
    good &= ge & le;
  }
  return good != 0;
}

// Throws unless `bounds` holds `expected` finite values >= 0 (and a pointer where it holds any).
template <typename S>
void checkMotionBounds(const MotionBounds<S>& bounds, std::size_t expected, const char* where) {
  if (bounds.size != expected)
    batchError(where, "motion_bounds has " + std::to_string(bounds.size) +
                          " values where the states need " + std::to_string(expected));
  if (bounds.size != 0 && bounds.data == nullptr)
    batchError(where, "motion_bounds has a null pointer");
  if (allFiniteNonNegative(bounds.data, bounds.size)) return;
  for (std::size_t i = 0; i < bounds.size; ++i)
    if (!(bounds.data[i] >= S(0)) || !std::isfinite(bounds.data[i]))
      batchError(where, "motion bound " + std::to_string(i) + " (" +
                            std::to_string(bounds.data[i]) + ") is negative, NaN or infinite");
}

// Link l's margin raise at state k of the edge [begin, end) given bound(j, l) of the interval
// from state j to j + 1: half the larger bound of the intervals state k ends and starts. False
// if a bound is NaN or infinite (from a pose that is).
template <typename S, class Bound>
bool raiseAt(std::size_t n, std::size_t k, std::size_t begin, std::size_t end, const Bound& bound,
             S* extra) {
  S finite = 0;  // x - x: 0 for a finite x, NaN otherwise
  for (std::size_t l = 0; l < n; ++l) {
    S b = 0;
    if (k > begin) {
      const S before = bound(k - 1, l);
      finite += before - before;
      b = before;
    }
    if (k + 1 < end) {
      const S after = bound(k, l);
      finite += after - after;
      b = std::max(b, after);
    }
    extra[l] = S(0.5) * b;
  }
  return finite == S(0);
}

// One thread's memo of the last interval whose links' SE(3) bounds it computed: the state after
// it, checked next in path order, reads them again as its interval before.
template <typename S>
struct RaiseMemo {
  std::vector<S> after;             // per link (sized by the scratch that holds it)
  std::vector<S> before;            // room for the interval before, the same size
  std::size_t interval = SIZE_MAX;  // its first state; SIZE_MAX: none
};

// Raises from the caller's bounds, bounds[k * n + l] for link l from state k to k + 1.
template <typename S>
struct GivenRaise {
  MotionBounds<S> bounds;
  std::size_t n;
  template <class PosesOf>
  void operator()(std::size_t state, std::size_t begin, std::size_t end, S* raise, std::size_t&,
                  const PosesOf&, RaiseMemo<S>&) const {
    raiseAt<S>(
        n, state, begin, end, [&](std::size_t k, std::size_t l) { return bounds.data[k * n + l]; },
        raise);
  }
};

// Raises from the poses of the state and its neighbours in its edge, moving in SE(3) between
// them (as raiseAt: half the larger bound of the intervals the state ends and starts);
// poses_of(k) gives state k's links' poses (only the state's and its neighbours' are asked for,
// the one before only if the memo does not hold its interval).
template <typename S>
struct Se3Raise {
  const std::vector<S> reach;
  template <class PosesOf>
  void operator()(std::size_t state, std::size_t begin, std::size_t end, S* raise, std::size_t& bad,
                  const PosesOf& poses_of, RaiseMemo<S>& memo) const {
    const std::size_t n = reach.size();
    const bool before = state > begin, after = state + 1 < end;
    const bool known = before && memo.interval == state - 1;
    const fcl::Transform3<S>* prev = before && !known ? poses_of(state - 1) : nullptr;
    const fcl::Transform3<S>* cur = poses_of(state);
    const fcl::Transform3<S>* next = after ? poses_of(state + 1) : nullptr;
    // Every link's bounds of the interval before (from the memo where it holds it) and of the one
    // after (into it), each interval's in one pass over the links.
    static_assert(sizeof(fcl::Transform3<S>) == 16 * sizeof(S), "a pose is 16 numbers");
    if (known)
      memo.before.swap(memo.after);
    else if (before)
      se3Bounds(prev->data(), cur->data(), reach.data(), n, memo.before.data());
    if (after) se3Bounds(cur->data(), next->data(), reach.data(), n, memo.after.data());
    const bool finite = raiseAt<S>(
        n, state, begin, end,
        [&](std::size_t k, std::size_t l) {
          return k + 1 == state ? memo.before[l] : memo.after[l];
        },
        raise);
    memo.interval = after ? state : SIZE_MAX;
    if (finite) return;
    // A pose read is NaN or infinite: the first such in pose order (a NaN bound comes from one).
    if (before && prev == nullptr) prev = poses_of(state - 1);
    const fcl::Transform3<S>* near[3] = {prev, cur, next};
    for (std::size_t i = 0; i < 3; ++i) {
      if (near[i] == nullptr) continue;
      for (std::size_t l = 0; l < n; ++l)
        if (!near[i][l].linear().allFinite() || !near[i][l].translation().allFinite()) {
          bad = (state + i - 1) * n + l;
          return;
        }
    }
  }
};

}  // namespace detail
}  // namespace cube
