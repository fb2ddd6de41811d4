// Ray queries (include/cube_collision/spatial_queries.h): raycastFirst and raycastAll as visitors
// of walkTree over the manager's cubes, plus a pass over its unbounded list, and raycastObject;
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
#include "core/walk.h"
#include "cube_collision/spatial_queries.h"
#include "queries/ray_tests.h"

namespace cube {

namespace {

using detail::crossBox;
using detail::hitOne;
using detail::Item;
using detail::kInf;
using detail::kNone;
using detail::makeSegment;
using detail::Narrow;
using detail::Node;
using detail::Segment;
using detail::Step;
using detail::View;

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

// What every ray walk shares: the segment, the narrow phase if asked, the ids' registration
// numbers.
template <typename S>
struct RayQuery {
  Segment seg;
  std::optional<Narrow<S>> narrow_phase;
  const detail::ObjectTable<S>& table;

  RayQuery(const CubeCollisionManager<S>& m, const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
           const RayOptions<S>& o)
      : seg(makeSegment(from, to)), table(detail::coreOf(m).table()) {
    if (o.narrow_phase) narrow_phase.emplace(from, to, o.tolerance);
  }
  Narrow<S>* narrow() { return narrow_phase ? &*narrow_phase : nullptr; }
  bool test(const Item<S>& it, double bound, Found<S>& f) {
    if (it.obj == nullptr) return false;
    if (!hitOne(seg, it.box.lo, it.box.hi, *it.obj, narrow(), bound, f.t, f.kind)) return false;
    f.seq = table.seq(it.id);
    f.obj = it.obj;
    return true;
  }
};

// raycastAll: every cube the segment meets, in any order.
template <typename S>
struct AllVisitor {
  using State = char;
  static constexpr bool kOrdered = false;
  const View<S>& tree;
  RayQuery<S>& q;
  std::vector<Found<S>>& out;
  static bool before(State, State) { return false; }
  bool keep(State) const { return true; }
  bool enter(std::uint32_t child, int, State, State&) const {
    const Node& n = tree.nodes[child];
    double a, b;
    return crossBox(q.seg, n.lo, n.hi, a, b);
  }
  Step at(std::uint32_t cube, State) {
    const Node& n = tree.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    Found<S> f;
    for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
      if (q.test(tree.items[i], kInf, f)) out.push_back(f);
    return Step::skip;
  }
};

// raycastFirst: cubes by where the segment enters them, nearest first; a cube entered beyond the
// best hit so far holds nothing nearer (every object's t is at least its box's entry, which is
// at least its cubes').
template <typename S>
struct FirstVisitor {
  using State = double;  // the segment's entry into the cube
  static constexpr bool kOrdered = true;
  const View<S>& tree;
  RayQuery<S>& q;
  std::optional<Found<S>>& best;
  std::vector<std::pair<double, std::uint32_t>>& order;  // a leaf's objects by entry
  // Beyond this t nothing can beat or tie the best: the next value of S above the best's
  // published t (a t below it may still round to the same S and win on registration order).
  double limit = kInf;

  double bound() const { return limit; }
  static bool before(State x, State y) { return x < y; }
  bool keep(State entry) const { return entry <= bound(); }
  bool enter(std::uint32_t child, int, State, State& entry) const {
    const Node& n = tree.nodes[child];
    double exit;
    return crossBox(q.seg, n.lo, n.hi, entry, exit) && entry <= bound();
  }
  void offer(const Item<S>& it) {
    Found<S> f;
    if (q.test(it, bound(), f) && (!best || earlier(f, *best))) {
      best = f;
      limit = double(std::nextafter(S(f.t), std::numeric_limits<S>::infinity()));
    }
  }
  Step at(std::uint32_t cube, State) {
    const Node& n = tree.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    if (!q.narrow_phase) {  // box hits are cheap: no order needed
      for (std::uint32_t i = n.first; i < n.first + n.count; ++i) offer(tree.items[i]);
      return Step::skip;
    }
    // The narrow phase costs more (the bisection much more): nearest boxes first, so that the
    // bound prunes the others.
    order.clear();
    for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
      double a, b;
      if (tree.items[i].obj != nullptr &&
          crossBox(q.seg, tree.items[i].box.lo, tree.items[i].box.hi, a, b))
        order.emplace_back(a, i);
    }
    std::sort(order.begin(), order.end());
    for (const auto& [entry, i] : order) {
      if (entry > bound()) break;
      offer(tree.items[i]);
    }
    return Step::skip;
  }
};

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
                                      const RayOptions<S>& options) {
  checkRay(from, to, options);
  RayQuery<S> q(manager, from, to, options);
  const detail::Scene<S> scene = detail::coreOf(manager).scene();
  std::optional<Found<S>> best;
  std::vector<std::pair<double, std::uint32_t>> order;
  FirstVisitor<S> v{scene.cubes, q, best, order};
  // The unbounded objects first: planes and the like often give a bound that prunes the walk.
  for (std::uint32_t i = 0; i < scene.unbounded.slots; ++i) v.offer(scene.unbounded.items[i]);
  if (scene.cubes.root != kNone) {
    const Node& root = scene.cubes.nodes[scene.cubes.root];
    double entry, exit;
    if (crossBox(q.seg, root.lo, root.hi, entry, exit) && entry <= v.bound())
      detail::walkTree(scene.cubes.nodes, scene.cubes.root, entry, v);
  }
  if (!best) return std::nullopt;
  return publish(*best, from, to);
}

template <typename S>
std::vector<RayHit<S>> raycastAll(const CubeCollisionManager<S>& manager,
                                  const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                  const RayOptions<S>& options) {
  checkRay(from, to, options);
  RayQuery<S> q(manager, from, to, options);
  const detail::Scene<S> scene = detail::coreOf(manager).scene();
  std::vector<Found<S>> found;
  AllVisitor<S> v{scene.cubes, q, found};
  if (scene.cubes.root != kNone) {
    const Node& root = scene.cubes.nodes[scene.cubes.root];
    double entry, exit;
    if (crossBox(q.seg, root.lo, root.hi, entry, exit))
      detail::walkTree(scene.cubes.nodes, scene.cubes.root, char{}, v);
  }
  Found<S> f;
  for (std::uint32_t i = 0; i < scene.unbounded.slots; ++i)
    if (q.test(scene.unbounded.items[i], kInf, f)) found.push_back(f);
  std::sort(found.begin(), found.end(), earlier<S>);
  std::vector<RayHit<S>> out;
  out.reserve(found.size());
  for (const Found<S>& h : found) out.push_back(publish(h, from, to));
  return out;
}

#define CUBE_RAY_INSTANTIATE(S)                                                                    \
  template std::optional<RayHit<S>> raycastFirst<S>(const CubeCollisionManager<S>&,                \
                                                    const fcl::Vector3<S>&,                        \
                                                    const fcl::Vector3<S>&, const RayOptions<S>&); \
  template std::vector<RayHit<S>> raycastAll<S>(const CubeCollisionManager<S>&,                    \
                                                const fcl::Vector3<S>&, const fcl::Vector3<S>&,    \
                                                const RayOptions<S>&);                             \
  template std::optional<RayHit<S>> raycastObject<S>(                                              \
      const fcl::CollisionObject<S>&, const fcl::AABB<S>&, const fcl::Vector3<S>&,                 \
      const fcl::Vector3<S>&, const RayOptions<S>&);

CUBE_RAY_INSTANTIATE(double)
CUBE_RAY_INSTANTIATE(float)

}  // namespace cube
