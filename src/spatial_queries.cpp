// Ray and region queries (include/cube_collision/spatial_queries.h) as visitors of walkTree over
// the manager's cubes, plus a pass over its unbounded list. Every cube test here is the object
// test applied to the cube's float bounds, in the same double arithmetic: a cube contains its
// objects' boxes and each test is monotone in the bounds (rounding is monotone), so a cube that
// fails cannot hold an object that passes, and the walks return exactly what a loop over every
// object would.

#include "cube_collision/spatial_queries.h"

#include <fcl/geometry/shape/capsule.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/broadphase.h"
#include "core/walk.h"
#include "fcl_narrow.h"

namespace cube {

namespace {

using detail::Item;
using detail::kNone;
using detail::Node;
using detail::Step;
using detail::View;

constexpr double kInf = std::numeric_limits<double>::infinity();

// The segment as the box test reads it (see raycastObject's contract).
struct Segment {
  double o[3];
  double inv[3];
  bool moves[3];
};

template <typename S>
Segment makeSegment(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to) {
  Segment s;
  for (int k = 0; k < 3; ++k) {
    s.o[k] = double(from[k]);
    const double d = double(to[k]) - double(from[k]);
    s.inv[k] = 1.0 / d;
    // An infinite inverse (no motion, or below 1 / DBL_MAX) would make 0 * inf = NaN below.
    s.moves[k] = std::isfinite(s.inv[k]);
  }
  return s;
}

// Where the segment enters and leaves the closed box [lo, hi], in [0, 1]; false if it misses.
// No NaN can arise: the inverse is finite and non-zero, the origin finite.
template <class T>
inline bool crossBox(const Segment& s, const T* lo, const T* hi, double& enter, double& exit) {
  double tn = 0, tf = 1;
  for (int k = 0; k < 3; ++k) {
    const double l = double(lo[k]), h = double(hi[k]);
    if (!s.moves[k]) {
      if (!(l <= s.o[k] && s.o[k] <= h)) return false;
      continue;
    }
    double a = (l - s.o[k]) * s.inv[k];
    double b = (h - s.o[k]) * s.inv[k];
    // Chosen by the sign, not by min/max, so that an emptied cube (lo > hi) is missed.
    if (s.inv[k] < 0) std::swap(a, b);
    tn = a > tn ? a : tn;
    tf = b < tf ? b : tf;
  }
  enter = tn;
  exit = tf;
  return tn <= tf;
}

void checkFinite(const double* v, const char* what) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(v[k])) throw std::invalid_argument(std::string(what) + " is not finite");
}

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

// Geometries whose fcl::collide against a capsule FCL 0.7 answers (checked in the tests against
// the analytic intersections). Octrees carry occupancy thresholds and costs; triangles and custom
// geometries are untested here.
template <typename S>
bool narrowable(const fcl::CollisionObject<S>& obj) {
  if (obj.collisionGeometry() == nullptr) return false;
  switch (obj.collisionGeometry()->getNodeType()) {
    case fcl::BV_AABB:
    case fcl::BV_OBB:
    case fcl::BV_RSS:
    case fcl::BV_kIOS:
    case fcl::BV_OBBRSS:
    case fcl::BV_KDOP16:
    case fcl::BV_KDOP18:
    case fcl::BV_KDOP24:
    case fcl::GEOM_BOX:
    case fcl::GEOM_SPHERE:
    case fcl::GEOM_ELLIPSOID:
    case fcl::GEOM_CAPSULE:
    case fcl::GEOM_CONE:
    case fcl::GEOM_CYLINDER:
    case fcl::GEOM_CONVEX:
    case fcl::GEOM_PLANE:
    case fcl::GEOM_HALFSPACE:
      return true;
    default:
      return false;
  }
}

// The narrow phase of one query: a capsule of radius 0 from `from` along the segment, stretched
// to each t asked. Owned by the query (one per call), so queries share nothing.
template <typename S>
class Caster {
 public:
  Caster(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to)
      : from_(from),
        d_(to - from),
        len_(double(d_.norm())),
        cap_(std::make_shared<fcl::Capsule<S>>(S(0), S(0))),
        obj_(cap_) {
    rot_.setIdentity();
    // The capsule's axis is its local z.
    if (len_ > 0)
      rot_ = Eigen::Quaternion<S>::FromTwoVectors(fcl::Vector3<S>::UnitZ(), d_ / S(len_))
                 .toRotationMatrix();
  }
  double length() const { return len_; }
  // Whether the part of the segment from t = 0 to t meets the object.
  bool reaches(const fcl::CollisionObject<S>& obj, double t) {
    cap_->lz = S(t * len_);
    cap_->computeLocalAABB();
    obj_.setTransform(rot_, fcl::Vector3<S>(from_ + S(0.5 * t) * d_));
    obj_.computeAABB();
    fcl::CollisionRequest<S> request;
    fcl::CollisionResult<S> result;
    return detail::fclCollide<S>(&obj_, &obj, request, result) > 0;
  }

 private:
  fcl::Vector3<S> from_, d_;
  double len_;
  fcl::Matrix3<S> rot_;
  std::shared_ptr<fcl::Capsule<S>> cap_;
  fcl::CollisionObject<S> obj_;
};

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

// The per-object test of raycastObject. `bound`: a hit beyond it is of no interest (the walk's
// best so far), and the bisection may give up once it is passed; the t returned otherwise does
// not depend on `bound`, so a pruned walk finds the same t as a loop over every object.
template <typename S, class T>
bool hitOne(const Segment& s, const T* lo, const T* hi, const fcl::CollisionObject<S>& obj,
            Caster<S>* caster, double tol_t, double bound, double& t, HitKind& kind) {
  double enter, exit;
  if (!crossBox(s, lo, hi, enter, exit) || enter > bound) return false;
  if (caster == nullptr || !narrowable(obj)) {
    t = enter;
    kind = HitKind::box;
    return true;
  }
  if (!caster->reaches(obj, exit)) return false;
  kind = HitKind::narrow_phase;
  double a = enter, b = exit;  // a: no contact yet (or enter), b: contact
  if (caster->reaches(obj, a)) b = a;
  while (b - a > tol_t) {
    if (a > bound) return false;
    const double mid = a + (b - a) * 0.5;
    if (!(mid > a && mid < b)) break;  // as close as double can say
    (caster->reaches(obj, mid) ? b : a) = mid;
  }
  t = b;
  return true;
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
  std::optional<Caster<S>> caster;
  double tol_t;
  const detail::ObjectTable<S>& table;

  RayQuery(const CubeCollisionManager<S>& m, const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
           const RayOptions<S>& o)
      : seg(makeSegment(from, to)), tol_t(0), table(m.core().table()) {
    if (o.narrow_phase) {
      caster.emplace(from, to);
      tol_t = caster->length() > 0 ? double(o.tolerance) / caster->length() : kInf;
    }
  }
  Caster<S>* narrow() { return caster ? &*caster : nullptr; }
  bool test(const Item<S>& it, double bound, Found<S>& f) {
    if (it.obj == nullptr) return false;
    if (!hitOne(seg, it.box.lo, it.box.hi, *it.obj, narrow(), tol_t, bound, f.t, f.kind))
      return false;
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
    if (!q.caster) {  // box hits are cheap: no order needed
      for (std::uint32_t i = n.first; i < n.first + n.count; ++i) offer(tree.items[i]);
      return Step::skip;
    }
    // The narrow phase is dear: nearest boxes first, so that the bound prunes the others.
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

// Region queries: cubes and boxes through one predicate on (lo, hi).
template <typename S, class Pred>
struct RegionVisitor {
  using State = char;
  static constexpr bool kOrdered = false;
  const View<S>& tree;
  const Pred& pred;
  std::vector<std::pair<std::uint32_t, fcl::CollisionObject<S>*>>& out;
  const detail::ObjectTable<S>& table;
  static bool before(State, State) { return false; }
  bool keep(State) const { return true; }
  bool enter(std::uint32_t child, int, State, State&) const {
    const Node& n = tree.nodes[child];
    return pred(n.lo, n.hi);
  }
  Step at(std::uint32_t cube, State) {
    const Node& n = tree.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    for (std::uint32_t i = n.first; i < n.first + n.count; ++i) offer(tree.items[i]);
    return Step::skip;
  }
  void offer(const Item<S>& it) {
    if (it.obj != nullptr && pred(it.box.lo, it.box.hi)) out.emplace_back(table.seq(it.id), it.obj);
  }
};

template <typename S, class Pred>
std::vector<fcl::CollisionObject<S>*> region(const CubeCollisionManager<S>& manager,
                                             const Pred& pred) {
  const detail::Scene<S> scene = manager.core().scene();
  std::vector<std::pair<std::uint32_t, fcl::CollisionObject<S>*>> found;
  RegionVisitor<S, Pred> v{scene.cubes, pred, found, manager.core().table()};
  if (scene.cubes.root != kNone) {
    const Node& root = scene.cubes.nodes[scene.cubes.root];
    if (pred(root.lo, root.hi)) detail::walkTree(scene.cubes.nodes, scene.cubes.root, char{}, v);
  }
  for (std::uint32_t i = 0; i < scene.unbounded.slots; ++i) v.offer(scene.unbounded.items[i]);
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<fcl::CollisionObject<S>*> out;
  out.reserve(found.size());
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

// The closed box overlap, in double.
struct InBox {
  double lo[3], hi[3];
  template <class T>
  bool operator()(const T* l, const T* h) const {
    return (double(l[0]) <= hi[0]) & (lo[0] <= double(h[0])) & (double(l[1]) <= hi[1]) &
           (lo[1] <= double(h[1])) & (double(l[2]) <= hi[2]) & (lo[2] <= double(h[2]));
  }
};

// The distance from a point to a box within r (see objectsNear's contract).
struct Near {
  double p[3];
  double r;
  template <class T>
  bool operator()(const T* l, const T* h) const {
    if (r == kInf) return true;
    double g[3];
    for (int k = 0; k < 3; ++k) {
      const double below = double(l[k]) - p[k], above = p[k] - double(h[k]);
      double gap = below > above ? below : above;
      gap = gap > 0 ? gap : 0;
      if (gap > r) return false;
      g[k] = gap;
    }
    if (r <= 1e150) return g[0] * g[0] + g[1] * g[1] + g[2] * g[2] <= r * r;
    for (double& x : g) x /= r;
    return g[0] * g[0] + g[1] * g[1] + g[2] * g[2] <= 1.0;
  }
};

}  // namespace

template <typename S>
std::optional<RayHit<S>> raycastObject(const fcl::CollisionObject<S>& obj, const fcl::AABB<S>& box,
                                       const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                       const RayOptions<S>& options) {
  checkRay(from, to, options);
  const Segment seg = makeSegment(from, to);
  std::optional<Caster<S>> caster;
  double tol_t = 0;
  if (options.narrow_phase) {
    caster.emplace(from, to);
    tol_t = caster->length() > 0 ? double(options.tolerance) / caster->length() : kInf;
  }
  S lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = box.min_[k];
    hi[k] = box.max_[k];
  }
  Found<S> f{0, 0, const_cast<fcl::CollisionObject<S>*>(&obj), HitKind::box};
  if (!hitOne(seg, lo, hi, obj, caster ? &*caster : nullptr, tol_t, kInf, f.t, f.kind))
    return std::nullopt;
  return publish(f, from, to);
}

template <typename S>
std::optional<RayHit<S>> raycastFirst(const CubeCollisionManager<S>& manager,
                                      const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                      const RayOptions<S>& options) {
  checkRay(from, to, options);
  RayQuery<S> q(manager, from, to, options);
  const detail::Scene<S> scene = manager.core().scene();
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
  const detail::Scene<S> scene = manager.core().scene();
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

template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsInBox(const CubeCollisionManager<S>& manager,
                                                   const fcl::AABB<S>& box) {
  InBox pred;
  for (int k = 0; k < 3; ++k) {
    pred.lo[k] = double(box.min_[k]);
    pred.hi[k] = double(box.max_[k]);
    if (std::isnan(pred.lo[k]) || std::isnan(pred.hi[k]))
      throw std::invalid_argument("cube::objectsInBox: the box has a NaN bound");
    if (pred.lo[k] > pred.hi[k])
      throw std::invalid_argument("cube::objectsInBox: the box's min exceeds its max");
  }
  return region(manager, pred);
}

template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsNear(const CubeCollisionManager<S>& manager,
                                                  const fcl::Vector3<S>& point, S radius) {
  Near pred;
  for (int k = 0; k < 3; ++k) pred.p[k] = double(point[k]);
  checkFinite(pred.p, "cube::objectsNear: the point");
  pred.r = double(radius);
  if (!(pred.r >= 0)) throw std::invalid_argument("cube::objectsNear: radius is negative or NaN");
  return region(manager, pred);
}

#define CUBE_SPATIAL_INSTANTIATE(S)                                                                \
  template std::optional<RayHit<S>> raycastFirst<S>(const CubeCollisionManager<S>&,                \
                                                    const fcl::Vector3<S>&,                        \
                                                    const fcl::Vector3<S>&, const RayOptions<S>&); \
  template std::vector<RayHit<S>> raycastAll<S>(const CubeCollisionManager<S>&,                    \
                                                const fcl::Vector3<S>&, const fcl::Vector3<S>&,    \
                                                const RayOptions<S>&);                             \
  template std::optional<RayHit<S>> raycastObject<S>(                                              \
      const fcl::CollisionObject<S>&, const fcl::AABB<S>&, const fcl::Vector3<S>&,                 \
      const fcl::Vector3<S>&, const RayOptions<S>&);                                               \
  template std::vector<fcl::CollisionObject<S>*> objectsInBox<S>(const CubeCollisionManager<S>&,   \
                                                                 const fcl::AABB<S>&);             \
  template std::vector<fcl::CollisionObject<S>*> objectsNear<S>(const CubeCollisionManager<S>&,    \
                                                                const fcl::Vector3<S>&, S);

CUBE_SPATIAL_INSTANTIATE(double)
CUBE_SPATIAL_INSTANTIATE(float)

}  // namespace cube
