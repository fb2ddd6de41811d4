// Ray and region queries (include/cube_collision/spatial_queries.h) as visitors of walkTree over
// the manager's cubes, plus a pass over its unbounded list. Every cube test here is the object
// test applied to the cube's float bounds, in the same double arithmetic: a cube contains its
// objects' boxes and each test is monotone in the bounds (rounding is monotone), so a cube that
// fails cannot hold an object that passes, and the walks return exactly what a loop over every
// object would.

#include "cube_collision/spatial_queries.h"

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "core/walk.h"
#include "pipeline/fcl_narrow.h"

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

// The bisection of the other geometries: a capsule of radius 0 from `from` along the segment,
// stretched to each t asked. Owned by the query (one per call), so queries share nothing.
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

// The closed interval of t, on the whole line o + t d, where the line is inside a convex set;
// empty when lo > hi.
struct Span {
  double lo, hi;
};
constexpr Span kAll{-kInf, kInf};
constexpr Span kEmpty{kInf, -kInf};

Span meet(Span a, Span b) {
  return {a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi};
}

// Within r of the origin, over the first `dims` coordinates (3: a ball, 2: an infinite cylinder
// along z). Solved from the line's closest point to the centre rather than from |o|^2 - r^2, so
// that a distant origin loses no precision in the discriminant; a tangent line gives one point.
Span ball(const double* o, const double* d, double r, int dims) {
  double a = 0, b = 0, oo = 0;
  for (int k = 0; k < dims; ++k) {
    a += d[k] * d[k];
    b += o[k] * d[k];
    oo += o[k] * o[k];
  }
  if (a == 0) return oo <= r * r ? kAll : kEmpty;  // no motion in these coordinates
  const double mid = -b / a;                       // t of the closest point
  double q2 = 0;
  for (int k = 0; k < dims; ++k) {
    const double q = o[k] + mid * d[k];
    q2 += q * q;
  }
  const double gap = r * r - q2;
  if (!(gap >= 0)) return kEmpty;
  const double half = std::sqrt(gap / a);
  return {mid - half, mid + half};
}

// lo <= o + t d <= hi on one coordinate.
Span slab(double o, double d, double lo, double hi) {
  if (d == 0) return lo <= o && o <= hi ? kAll : kEmpty;
  double a = (lo - o) / d, b = (hi - o) / d;  // finite or infinite, never NaN: d != 0
  if (d < 0) std::swap(a, b);
  return {a, b};
}

// The first t in [0, 1] of a span, or kInf.
double firstIn(Span s) {
  s = meet(s, Span{0, 1});
  return s.lo <= s.hi ? s.lo : kInf;
}

// The first t in [0, 1] at which the segment o + t d (in the geometry's frame) is in the closed
// solid, kInf if never; false if the geometry is not one solved here (or its sizes are not
// finite and >= 0), which leaves it to the bisection. FCL 0.7's frames: everything centred on the
// origin; box: `side` full lengths; capsule and cylinder: axis z, from -lz/2 to lz/2; ellipsoid:
// `radii` along x, y, z; plane n.x = d (a surface); halfspace n.x <= d (solid).
template <typename S>
bool exactFirst(const fcl::CollisionGeometry<S>& geo, const double* o, const double* d, double& t) {
  const auto ok = [](double v) { return v >= 0 && v < kInf; };
  switch (geo.getNodeType()) {
    case fcl::GEOM_SPHERE: {
      const double r = static_cast<const fcl::Sphere<S>&>(geo).radius;
      if (!ok(r)) return false;
      t = firstIn(ball(o, d, r, 3));
      return true;
    }
    case fcl::GEOM_ELLIPSOID: {
      // Scaled to the unit ball: t is unchanged by a linear map of the segment.
      const auto& radii = static_cast<const fcl::Ellipsoid<S>&>(geo).radii;
      double so[3], sd[3];
      for (int k = 0; k < 3; ++k) {
        const double r = radii[k];
        if (!(ok(r) && r > 0)) return false;
        so[k] = o[k] / r;
        sd[k] = d[k] / r;
      }
      t = firstIn(ball(so, sd, 1, 3));
      return true;
    }
    case fcl::GEOM_BOX: {
      const auto& side = static_cast<const fcl::Box<S>&>(geo).side;
      Span s = kAll;
      for (int k = 0; k < 3; ++k) {
        const double h = 0.5 * double(side[k]);
        if (!ok(h)) return false;
        s = meet(s, slab(o[k], d[k], -h, h));
      }
      t = firstIn(s);
      return true;
    }
    case fcl::GEOM_CYLINDER: {
      const auto& c = static_cast<const fcl::Cylinder<S>&>(geo);
      const double r = c.radius, h = 0.5 * double(c.lz);
      if (!ok(r) || !ok(h)) return false;
      t = firstIn(meet(ball(o, d, r, 2), slab(o[2], d[2], -h, h)));
      return true;
    }
    case fcl::GEOM_CAPSULE: {
      // A union of convex parts: the cylinder between the end centres and the two end balls;
      // the first t in the union is the first over the parts.
      const auto& c = static_cast<const fcl::Capsule<S>&>(geo);
      const double r = c.radius, h = 0.5 * double(c.lz);
      if (!ok(r) || !ok(h)) return false;
      t = firstIn(meet(ball(o, d, r, 2), slab(o[2], d[2], -h, h)));
      for (const double z : {-h, h}) {
        const double oz[3] = {o[0], o[1], o[2] - z};
        t = std::min(t, firstIn(ball(oz, d, r, 3)));
      }
      return true;
    }
    case fcl::GEOM_HALFSPACE:
    case fcl::GEOM_PLANE: {
      const bool solid = geo.getNodeType() == fcl::GEOM_HALFSPACE;
      const fcl::Vector3<S>& n = solid ? static_cast<const fcl::Halfspace<S>&>(geo).n
                                       : static_cast<const fcl::Plane<S>&>(geo).n;
      const double off = solid ? double(static_cast<const fcl::Halfspace<S>&>(geo).d)
                               : double(static_cast<const fcl::Plane<S>&>(geo).d);
      const double f0 = double(n[0]) * o[0] + double(n[1]) * o[1] + double(n[2]) * o[2] - off;
      const double slope = double(n[0]) * d[0] + double(n[1]) * d[1] + double(n[2]) * d[2];
      if (!std::isfinite(f0) || !std::isfinite(slope)) return false;
      t = kInf;
      if (f0 == 0 || (solid && f0 < 0)) {
        t = 0;
      } else if ((f0 > 0 && slope < 0) || (f0 < 0 && slope > 0)) {
        const double at = -f0 / slope;  // > 0; infinite if slope is tiny
        if (at <= 1) t = at;
      }
      return true;
    }
    default:
      return false;
  }
}

// The narrow phase of one query: the segment in double for the exact tests, and the bisection's
// capsule, made on first use only (most scenes need none).
template <typename S>
class Narrow {
 public:
  Narrow(const fcl::Vector3<S>& from, const fcl::Vector3<S>& to, S tolerance)
      : from_(from), to_(to) {
    for (int k = 0; k < 3; ++k) {
      o_[k] = double(from[k]);
      d_[k] = double(to[k]) - double(from[k]);
    }
    // As the bisection's capsule measures it.
    const double len = double((to - from).norm());
    tol_t_ = len > 0 ? double(tolerance) / len : kInf;
  }
  double tolT() const { return tol_t_; }
  Caster<S>& caster() {
    if (!caster_) caster_.emplace(from_, to_);
    return *caster_;
  }
  // exactFirst on the object's geometry, the segment taken into its frame.
  bool exact(const fcl::CollisionObject<S>& obj, double& t) const {
    const fcl::Transform3<S>& tf = obj.getTransform();
    double rel[3], lo[3], ld[3];
    for (int k = 0; k < 3; ++k) rel[k] = o_[k] - double(tf.translation()[k]);
    for (int j = 0; j < 3; ++j) {  // R^T: the object's axes are R's columns
      lo[j] = ld[j] = 0;
      for (int k = 0; k < 3; ++k) {
        const double r = double(tf.linear()(k, j));
        lo[j] += r * rel[k];
        ld[j] += r * d_[k];
      }
    }
    return exactFirst(*obj.collisionGeometry(), lo, ld, t);
  }

 private:
  fcl::Vector3<S> from_, to_;
  double o_[3], d_[3];
  double tol_t_;
  std::optional<Caster<S>> caster_;
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

// How far past the box's exit (in t) an exact hit may fall and still count (hitOne's contract in
// spatial_queries.h): far above the few ulps by which the box's and the exact test's formulas
// differ, far below anything a caller could see as a distance.
constexpr double kExitRounding = 1e-9;

// The narrow phase of hitOne, given where the segment enters and leaves the object's box. Kept
// out of line: the box test it follows is the walk's inner loop, and stays small.
template <typename S>
[[gnu::noinline]] bool narrowHit(const fcl::CollisionObject<S>& obj, Narrow<S>& narrow,
                                 double enter, double exit, double bound, double& t) {
  double first;
  if (narrow.exact(obj, first)) {
    // The answer the bisection converges to: no hit unless the segment meets the object by the
    // box's exit, and never before the box's entry. The object lies in its box, so an exact hit
    // past the exit is rounding: the two compute the crossing of a box of zero thickness (an
    // axis-aligned plane's) by different formulas, a few ulps apart.
    if (first > exit + kExitRounding) return false;
    t = first > enter ? (first < exit ? first : exit) : enter;
    return true;
  }
  Caster<S>& caster = narrow.caster();
  if (!caster.reaches(obj, exit)) return false;
  double a = enter, b = exit;  // a: no contact yet (or enter), b: contact
  if (caster.reaches(obj, a)) b = a;
  while (b - a > narrow.tolT()) {
    if (a > bound) return false;
    const double mid = a + (b - a) * 0.5;
    if (!(mid > a && mid < b)) break;  // as close as double can say
    (caster.reaches(obj, mid) ? b : a) = mid;
  }
  t = b;
  return true;
}

// The per-object test of raycastObject. `bound`: a hit beyond it is of no interest (the walk's
// best so far), and the bisection may give up once it is passed; the t returned otherwise does
// not depend on `bound`, so a pruned walk finds the same t as a loop over every object.
template <typename S, class T>
bool hitOne(const Segment& s, const T* lo, const T* hi, const fcl::CollisionObject<S>& obj,
            Narrow<S>* narrow, double bound, double& t, HitKind& kind) {
  double enter, exit;
  if (!crossBox(s, lo, hi, enter, exit) || enter > bound) return false;
  if (narrow == nullptr || !narrowable(obj)) {
    t = enter;
    kind = HitKind::box;
    return true;
  }
  kind = HitKind::narrow_phase;
  return narrowHit(obj, *narrow, enter, exit, bound, t);
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
  const detail::Scene<S> scene = detail::coreOf(manager).scene();
  std::vector<std::pair<std::uint32_t, fcl::CollisionObject<S>*>> found;
  RegionVisitor<S, Pred> v{scene.cubes, pred, found, detail::coreOf(manager).table()};
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
