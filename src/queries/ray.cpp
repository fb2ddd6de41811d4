// Ray queries (include/cube_collision/spatial_queries.h): raycastFirst and raycastAll as regions
// of the core's search (Broadphase::search: its unbounded list, then its cubes), and raycastObject;
// the exact tests they share are in ray_tests.h. Every cube test here is the object test applied
// to the cube's float bounds, in the same double arithmetic: a cube contains its objects' boxes
// and each test is monotone in the bounds (rounding is monotone), so a cube that fails cannot hold
// an object that passes, and the walks return exactly what a loop over every object would.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/spatial_queries.h"
#include "queries/ray_tests.h"

namespace cube {

namespace {

using detail::crossBox;
using detail::hitOne;
using detail::Item;
using detail::kInf;
using detail::makeSegment;
using detail::Narrow;
using detail::Segment;

template <typename S>
void checkRay(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to, const RayOptions<S>& o) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(double(from[k])))
      throw std::invalid_argument("cube::raycast: `from` is not finite");
    if (!std::isfinite(double(to[k])))
      throw std::invalid_argument("cube::raycast: `to` is not finite");
    if (!std::isfinite(to[k] - from[k]))
      throw std::invalid_argument("cube::raycast: to - from overflows");
  }
  if (!(o.tolerance >= S(0)))
    throw std::invalid_argument("cube::raycast: tolerance is negative or NaN");
}

// One hit before it is made public: t in double as found, and the registration number for ties.
// Hits are ordered by t as published (rounded to S), then by registration: for float, two hits
// a double tells apart may be equal.
template <typename S>
struct Found {
  double t;
  std::uint32_t seq;
  fcl::CollisionObject<S>* obj;
  HitKind kind;
};

template <typename S>
bool earlier(const Found<S>& a, const Found<S>& b) {
  const S ta = S(a.t), tb = S(b.t);
  return ta < tb || (ta == tb && a.seq < b.seq);
}

template <typename S>
RayHit<S> publish(const Found<S>& f, const fcl::Vector3<S>& from, const fcl::Vector3<S>& to) {
  RayHit<S> h;
  h.object = f.obj;
  h.t = S(f.t);
  h.distance = S(f.t * double((to - from).norm()));
  h.point = from + h.t * (to - from);
  h.kind = f.kind;
  return h;
}

// What every ray search shares: the segment, and the narrow phase if asked.
template <typename S>
struct RayQuery {
  Segment seg;
  std::optional<Narrow<S>> narrow_phase;

  RayQuery(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to, const RayOptions<S>& o)
      : seg(makeSegment(from, to)) {
    if (o.narrow_phase) narrow_phase.emplace(from, to, o.tolerance);
  }
  Narrow<S>* narrow() { return narrow_phase ? &*narrow_phase : nullptr; }
  bool test(const Item<S>& it, double bound, const std::uint32_t* seq, Found<S>& f) {
    if (it.obj == nullptr) return false;
    if (!hitOne(seg, it.box.lo, it.box.hi, *it.obj, narrow(), bound, f.t, f.kind)) return false;
    f.seq = seq[it.id];
    f.obj = it.obj;
    return true;
  }
};

// raycastAll: every leaf of the cubes the segment meets, in any order (a region of the core's
// search, Broadphase::search).
template <typename S>
struct AllRegion {
  using State = char;
  static constexpr bool kOrdered = false;
  RayQuery<S>& q;
  std::vector<Found<S>>& out;
  static bool before(State, State) { return false; }
  bool worth(State) const { return true; }
  bool enters(const float* lo, const float* hi, State&) const {
    double a, b;
    return crossBox(q.seg, lo, hi, a, b);
  }
  void leaf(const Item<S>* items, std::uint32_t n, const std::uint32_t* seq) {
    Found<S> f;
    for (std::uint32_t i = 0; i < n; ++i)
      if (q.test(items[i], kInf, seq, f)) out.push_back(f);
  }
};

// raycastFirst: cubes by where the segment enters them, nearest first; a cube entered beyond the
// best hit so far holds nothing nearer (every object's t is at least its box's entry, which is
// at least its cubes'). The search hands over the unbounded list first: planes and the like
// often give a bound that prunes the walk.
template <typename S>
struct FirstRegion {
  using State = double;  // the segment's entry into the cube
  static constexpr bool kOrdered = true;
  RayQuery<S>& q;
  std::optional<Found<S>>& best;
  std::vector<std::pair<double, std::uint32_t>>& order;  // a leaf's objects by entry
  // Beyond this t nothing can beat or tie the best: the next value of S above the best's
  // published t (a t below it may still round to the same S and win on registration order).
  double limit = kInf;

  double bound() const { return limit; }
  static bool before(State x, State y) { return x < y; }
  bool worth(State entry) const { return entry <= bound(); }
  bool enters(const float* lo, const float* hi, State& entry) const {
    double exit;
    return crossBox(q.seg, lo, hi, entry, exit) && entry <= bound();
  }
  void offer(const Item<S>& it, const std::uint32_t* seq) {
    Found<S> f;
    if (q.test(it, bound(), seq, f) && (!best || earlier(f, *best))) {
      best = f;
      limit = double(std::nextafter(S(f.t), std::numeric_limits<S>::infinity()));
    }
  }
  void leaf(const Item<S>* items, std::uint32_t n, const std::uint32_t* seq) {
    if (!q.narrow_phase) {  // box hits are cheap: no order needed
      for (std::uint32_t i = 0; i < n; ++i) offer(items[i], seq);
      return;
    }
    // The narrow phase costs more (the bisection much more): nearest boxes first, so that the
    // bound prunes the others.
    order.clear();
    for (std::uint32_t i = 0; i < n; ++i) {
      double a, b;
      if (items[i].obj != nullptr && crossBox(q.seg, items[i].box.lo, items[i].box.hi, a, b))
        order.emplace_back(a, i);
    }
    std::sort(order.begin(), order.end());
    for (const auto& [entry, i] : order) {
      if (entry > bound()) break;
      offer(items[i], seq);
    }
  }
};

// The core's search of the region, under the filter's bits if any.
template <typename S, class R>
void search(const CubeCollisionManager<S>& manager, R& region,
            const std::optional<QueryFilter>& filter) {
  if (!filter) return detail::coreOf(manager).search(region);
  const detail::Filter bits{filter->category, filter->mask};
  detail::coreOf(manager).search(region, &bits);
}

}  // namespace

template <typename S>
std::optional<RayHit<S>> raycastObject(const fcl::CollisionObject<S>& obj, const fcl::AABB<S>& box,
                                       const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                       const RayOptions<S>& options) {
  checkRay(from, to, options);
  const Segment seg = makeSegment(from, to);
  std::optional<Narrow<S>> narrow;
  if (options.narrow_phase) narrow.emplace(from, to, options.tolerance);
  S lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = box.min_[k];
    hi[k] = box.max_[k];
  }
  Found<S> f{0, 0, const_cast<fcl::CollisionObject<S>*>(&obj), HitKind::box};
  if (!hitOne(seg, lo, hi, obj, narrow ? &*narrow : nullptr, kInf, f.t, f.kind))
    return std::nullopt;
  return publish(f, from, to);
}

template <typename S>
std::optional<RayHit<S>> raycastFirst(const CubeCollisionManager<S>& manager,
                                      const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                      const RayOptions<S>& options,
                                      std::optional<QueryFilter> filter) {
  checkRay(from, to, options);
  RayQuery<S> q(from, to, options);
  std::optional<Found<S>> best;
  std::vector<std::pair<double, std::uint32_t>> order;
  FirstRegion<S> r{q, best, order};
  search(manager, r, filter);
  if (!best) return std::nullopt;
  return publish(*best, from, to);
}

template <typename S>
std::vector<RayHit<S>> raycastAll(const CubeCollisionManager<S>& manager,
                                  const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                  const RayOptions<S>& options, std::optional<QueryFilter> filter) {
  checkRay(from, to, options);
  RayQuery<S> q(from, to, options);
  std::vector<Found<S>> found;
  AllRegion<S> r{q, found};
  search(manager, r, filter);
  std::sort(found.begin(), found.end(), earlier<S>);
  std::vector<RayHit<S>> out;
  out.reserve(found.size());
  for (const Found<S>& h : found) out.push_back(publish(h, from, to));
  return out;
}

#define CUBE_RAY_INSTANTIATE(S)                                                                    \
  template std::optional<RayHit<S>> raycastFirst<S>(                                               \
      const CubeCollisionManager<S>&, const fcl::Vector3<S>&, const fcl::Vector3<S>&,              \
      const RayOptions<S>&, std::optional<QueryFilter>);                                           \
  template std::vector<RayHit<S>> raycastAll<S>(const CubeCollisionManager<S>&,                    \
                                                const fcl::Vector3<S>&, const fcl::Vector3<S>&,    \
                                                const RayOptions<S>&, std::optional<QueryFilter>); \
  template std::optional<RayHit<S>> raycastObject<S>(                                              \
      const fcl::CollisionObject<S>&, const fcl::AABB<S>&, const fcl::Vector3<S>&,                 \
      const fcl::Vector3<S>&, const RayOptions<S>&);

CUBE_RAY_INSTANTIATE(double)
CUBE_RAY_INSTANTIATE(float)

}  // namespace cube
