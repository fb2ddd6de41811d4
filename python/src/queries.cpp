// The manager's queries: collision and distance (trimesh's calls), rays and regions, and the
// private hooks that drive a backend with a Python callback per pair (the benchmark's emulation
// of trimesh over python-fcl). Each query converts its input with the GIL, then releases it and
// holds the manager's lock shared while C++ runs, and builds Python objects after.

#include <cube_collision/margins.h>
#include <cube_collision/queries.h>
#include <cube_collision/spatial_queries.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <pybind11/stl.h>

#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>

#include "manager.h"

namespace cubepy {

namespace {

constexpr const char* kExternal = "__external";  // trimesh's name for a query geometry
const double kInf = std::numeric_limits<double>::infinity();

using ObjPtr = fcl::CollisionObjectd*;

std::string nameOf(const fcl::CollisionObjectd* o) {
  const Entry* e = Manager::entryOf(o);
  return e ? e->name : kExternal;
}

// Asks for the cache line at p (a read soon): no effect on what the program does.
inline void prefetch(const void* p) {
  __builtin_prefetch(p);
}

// Where an object's user data lies: the last member of FCL 0.7's CollisionObject.
inline const void* userDataLine(const fcl::CollisionObjectd* o) {
  return reinterpret_cast<const char*>(o) + sizeof(fcl::CollisionObjectd) - sizeof(void*);
}

// A name in a result: an entry's (read under the manager's lock, which keeps the entry), or
// kExternal for null (the query geometry). nameStr orders, pyName is what Python gets.
const std::string& nameStr(const Entry* e) {
  static const std::string external = kExternal;
  return e ? e->name : external;
}
py::object pyName(const Entry* e) {
  return e ? e->pyname : py::str(kExternal);
}

/// Shared locks on one or two managers (in address order), taken with the GIL released.
struct ReadLocks {
  std::shared_lock<std::shared_mutex> a, b;
  ReadLocks(const Manager& x, const Manager* y = nullptr) {
    const Manager* first = &x;
    const Manager* second = y == &x ? nullptr : y;
    if (second && second < first) std::swap(first, second);
    a = std::shared_lock(first->mutex);
    if (second) b = std::shared_lock(second->mutex);
  }
};

struct ContactRow {
  const Entry *a, *b;  // null: the query geometry
  fcl::Vector3d pos, normal;
  double depth;
};

struct CollideOut {
  bool any = false;
  // Colliding pairs, one row each (null: the query geometry). The entries live while the query
  // holds the manager's lock: results are built before it lets go (collideQuery).
  std::vector<std::pair<const Entry*, const Entry*>> pairs;
  std::vector<ContactRow> contacts;
};

// What a collision query is asked for.
struct Want {
  bool names = false, data = false;
  int max_contacts = 1;
  bool anyOnly() const { return !names && !data; }
  /// Per pair: names need one contact (the narrow phase stops there), data every contact.
  fcl::CollisionRequestd pairRequest() const {
    fcl::CollisionRequestd r;
    r.num_max_contacts = data ? static_cast<std::size_t>(max_contacts) : 1;
    r.enable_contact = data;
    return r;
  }
};

void record(CollideOut& out, const Want& want, ObjPtr a, ObjPtr b, const fcl::CollisionResultd& r) {
  out.any = true;
  if (want.anyOnly()) return;
  const Entry *na = Manager::entryOf(a), *nb = Manager::entryOf(b);
  if (want.data)
    for (std::size_t k = 0; k < r.numContacts(); ++k) {
      const auto& c = r.getContact(k);
      out.contacts.push_back({na, nb, c.pos, c.normal, c.penetration_depth});
    }
  out.pairs.emplace_back(na, nb);
}

// A pair closer than its margins but apart: a row with the midpoint of the nearest points, the
// direction from a to b and the gap as a negative depth.
void recordNear(CollideOut& out, const Want& want, ObjPtr a, ObjPtr b, double distance,
                const fcl::Vector3d& pa, const fcl::Vector3d& pb) {
  out.any = true;
  if (want.anyOnly()) return;
  const Entry *na = Manager::entryOf(a), *nb = Manager::entryOf(b);
  if (want.data) {
    fcl::Vector3d n = pb - pa;
    const double len = n.norm();
    n = len > 0 ? fcl::Vector3d(n / len) : fcl::Vector3d::Zero();
    out.contacts.push_back({na, nb, (pa + pb) / 2, n, -distance});
  }
  out.pairs.emplace_back(na, nb);
}

// The cube backend: the pipeline on the candidate pairs (filter bits and ignored pairs applied by
// the walk). Does anything collide: collideAll's early stop. Names or data: each candidate pair
// answered on its own (first contact only for names), on the pipeline's threads.
CollideOut cubeCollide(const Manager& m, ObjPtr query, const Manager* other, const Want& want) {
  CollideOut out;
  cube::NarrowPhaseOptions<double> opt;
  opt.threads = m.threads();
  const auto& c = *m.cube();
  if (want.anyOnly()) {
    fcl::CollisionResultd r = query   ? cube::collideAll(c, query, {}, opt)
                              : other ? cube::collideAll(c, other->broadphase(), {}, opt)
                                      : cube::collideAll(c, {}, opt);
    out.any = r.isCollision();
    return out;
  }
  const bool meshes = m.meshes() > 0 || (other && other->meshes() > 0) ||
                      (query && query->collisionGeometry()->getObjectType() == fcl::OT_BVH);
  if (!want.data && !meshes) {
    // Names among shapes: one pass of the pipeline over every candidate pair, culled on the
    // manager's per-object volumes and proved touching where inscribed balls overlap. FCL gives a
    // colliding shape pair one contact without enable_contact, and the pipeline lists the pairs
    // that gave one (options.colliding) as the walk handed them: (object here, object there or
    // the query). Meshes would list every touching triangle pair here: they take the per-pair
    // path below, stopping at each pair's first contact.
    fcl::CollisionRequestd all;
    all.num_max_contacts = std::numeric_limits<std::size_t>::max();
    std::vector<cube::ObjectPair<double>> hit;
    opt.colliding = &hit;
    fcl::CollisionResultd r = query   ? cube::collideAll(c, query, all, opt)
                              : other ? cube::collideAll(c, other->broadphase(), all, opt)
                                      : cube::collideAll(c, all, opt);
    out.any = r.isCollision();
    out.pairs.reserve(hit.size());
    for (std::size_t i = 0; i < hit.size(); ++i) {
      // Each object's user data (its entry, FCL 0.7's last member) is a cache miss: asked for
      // 8 pairs ahead (a prefetch of the wrong line would cost time, never change a result).
      if (i + 8 < hit.size()) {
        prefetch(userDataLine(hit[i + 8].first));
        prefetch(userDataLine(hit[i + 8].second));
      }
      out.pairs.emplace_back(Manager::entryOf(hit[i].first), Manager::entryOf(hit[i].second));
    }
    return out;
  }
  std::vector<cube::ObjectPair<double>> pairs = query ? cube::overlappingPairs(c, query)
                                                : other
                                                    ? cube::overlappingPairs(c, other->broadphase())
                                                    : cube::overlappingPairs(c);
  std::vector<fcl::CollisionResultd> results = cube::collidePairs(pairs, want.pairRequest(), opt);
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (results[i].isCollision()) record(out, want, pairs[i].first, pairs[i].second, results[i]);
  return out;
}

// The cube backend with margins: contactsWithinMargin (self or one object), then the contacts of
// the colliding pairs if asked.
CollideOut cubeMargins(const Manager& m, ObjPtr query, const Want& want) {
  CollideOut out;
  const auto& c = *m.cube();
  auto near = query ? cube::contactsWithinMargin(c, query, fcl::DistanceRequestd(true), m.threads())
                    : cube::contactsWithinMargin(c, fcl::DistanceRequestd(true), m.threads());
  std::vector<cube::ObjectPair<double>> colliding;
  std::vector<std::size_t> where;
  for (std::size_t i = 0; i < near.size(); ++i)
    if (near[i].colliding && want.data) {
      colliding.emplace_back(near[i].a, near[i].b);
      where.push_back(i);
    }
  std::vector<fcl::CollisionResultd> results;
  if (!colliding.empty()) {
    cube::NarrowPhaseOptions<double> opt;
    opt.threads = m.threads();
    results = cube::collidePairs(colliding, want.pairRequest(), opt);
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < near.size(); ++i) {
    const auto& n = near[i];
    if (n.colliding) {
      fcl::CollisionResultd empty;
      record(out, want, n.a, n.b, k < where.size() && where[k] == i ? results[k++] : empty);
    } else {
      recordNear(out, want, n.a, n.b, n.distance, n.nearest_points[0], n.nearest_points[1]);
    }
    if (want.anyOnly()) break;
  }
  return out;
}

// Filter bits (and, within one manager, ignored pairs): may a and b pair?
bool pairAllowed(const Manager& self, const Manager* other, const Entry* a, const Entry* b) {
  if (!other) return self.allowed(a, b);
  const std::uint64_t ca = a ? a->category : 1, ma = a ? a->mask : ~std::uint64_t(0);
  const std::uint64_t cb = b ? b->category : 1, mb = b ? b->mask : ~std::uint64_t(0);
  return (ca & mb) != 0 && (cb & ma) != 0;
}

// The FCL backend: FCL's manager calls this per candidate pair; FCL's narrow phase in C++, as
// FCL's default callback does, with the pair rules and margins asked here.
struct FclCollide {
  const Manager* self;
  const Manager* other;  // manager against manager: bits only between the two
  Want want;
  fcl::CollisionRequestd request;
  bool margins;
  CollideOut out;

  bool allowed(const Entry* a, const Entry* b) const { return pairAllowed(*self, other, a, b); }

  static bool callback(ObjPtr o1, ObjPtr o2, void* data) {
    auto& c = *static_cast<FclCollide*>(data);
    const Entry* a = Manager::entryOf(o1);
    const Entry* b = Manager::entryOf(o2);
    if (!c.allowed(a, b)) return false;
    fcl::CollisionResultd r;
    fcl::collide(o1, o2, c.request, r);
    if (r.isCollision()) {
      record(c.out, c.want, o1, o2, r);
      return c.want.anyOnly();
    }
    if (c.margins) {
      const double sum = c.self->marginOf(a) + c.self->marginOf(b);
      if (sum > 0) {
        fcl::DistanceResultd d;
        fcl::distance(o1, o2, fcl::DistanceRequestd(true), d);
        if (d.min_distance <= sum) {
          recordNear(c.out, c.want, o1, o2, d.min_distance, d.nearest_points[0],
                     d.nearest_points[1]);
          return c.want.anyOnly();
        }
      }
    }
    return false;
  }
};

CollideOut fclCollide(const Manager& m, ObjPtr query, const Manager* other, const Want& want,
                      bool margins) {
  FclCollide c{&m,      other, want, want.anyOnly() ? fcl::CollisionRequestd() : want.pairRequest(),
               margins, {}};
  if (query)
    m.broadphase().collide(query, &c, &FclCollide::callback);
  else if (other)
    m.broadphase().collide(&other->broadphase(), &c, &FclCollide::callback);
  else
    m.broadphase().collide(&c, &FclCollide::callback);
  return std::move(c.out);
}

void swapSides(CollideOut& o) {
  for (auto& p : o.pairs) std::swap(p.first, p.second);
  for (auto& c : o.contacts) {
    std::swap(c.a, c.b);
    c.normal = -c.normal;
  }
}

// A cube manager and an FCL-backend one. The cube manager's walk knows the bits of its own
// objects only (those of another kind of manager are query objects with the default bits there),
// and FCL's tree static_casts another manager to its own type: each object of the cube manager
// is asked of the FCL tree instead, the pair rules checked per pair with both objects' bits.
// Pairs come as (FCL side, cube side).
CollideOut mixedCollide(const Manager& fcl_side, const Manager& cube_side, const Want& want) {
  const fcl::CollisionRequestd request =
      want.anyOnly() ? fcl::CollisionRequestd() : want.pairRequest();
  FclCollide c{&fcl_side, &cube_side, want, request, false, {}};
  for (const Entry* e : cube_side.ordered()) {
    fcl_side.broadphase().collide(e->obj.get(), &c, &FclCollide::callback);
    if (c.out.any && want.anyOnly()) break;
  }
  return std::move(c.out);
}

CollideOut collide(const Manager& m, ObjPtr query, const Manager* other, const Want& want) {
  if (other) {
    if (m.isCube() != other->isCube()) {
      CollideOut o = m.isCube() ? mixedCollide(*other, m, want) : mixedCollide(m, *other, want);
      if (m.isCube()) swapSides(o);
      return o;
    }
    return m.isCube() ? cubeCollide(m, nullptr, other, want)
                      : fclCollide(m, nullptr, other, want, false);
  }
  if (m.anyMargin())
    return m.isCube() ? cubeMargins(m, query, want) : fclCollide(m, query, nullptr, want, true);
  return m.isCube() ? cubeCollide(m, query, nullptr, want)
                    : fclCollide(m, query, nullptr, want, false);
}

py::object contactsDict(const std::vector<ContactRow>& rows) {
  const auto n = static_cast<py::ssize_t>(rows.size());
  py::list names;
  py::array_t<double> points({n, py::ssize_t(3)}), normals({n, py::ssize_t(3)}), depths(n);
  auto p = points.mutable_unchecked<2>();
  auto q = normals.mutable_unchecked<2>();
  auto d = depths.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& r = rows[i];
    names.append(py::make_tuple(pyName(r.a), pyName(r.b)));
    for (int k = 0; k < 3; ++k) {
      p(i, k) = r.pos[k];
      q(i, k) = r.normal[k];
    }
    d(i) = r.depth;
  }
  py::module_ np = py::module_::import("numpy");
  py::dict out;
  out["names"] = np.attr("array")(names, py::arg("dtype") = "object").attr("reshape")(-1, 2);
  out["points"] = points;
  out["normals"] = normals;
  out["depths"] = depths;
  return out;
}

enum class Kind { internal, single, other };

py::object collideReturn(const CollideOut& o, const Want& want, Kind kind) {
  if (want.anyOnly()) return py::bool_(o.any);
  py::list items;
  items.append(py::bool_(o.any));
  if (want.names) {
    // CPython's own calls, and each entry and its name fetched ahead: every one is a cache miss
    // (a third of this loop's time for 3,135 pairs among 10,000 objects).
    const py::str external(kExternal);
    const auto name = [&](const Entry* e) { return e ? e->pyname.ptr() : external.ptr(); };
    py::set names;
    const std::size_t n = o.pairs.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (i + 16 < n) {
        prefetch(o.pairs[i + 16].first);
        prefetch(o.pairs[i + 16].second);
      }
      if (i + 8 < n) {
        prefetch(name(o.pairs[i + 8].first));
        prefetch(name(o.pairs[i + 8].second));
      }
      const Entry *a = o.pairs[i].first, *b = o.pairs[i].second;
      if (kind == Kind::internal && nameStr(b) < nameStr(a)) std::swap(a, b);
      const py::object key =
          kind == Kind::single
              ? py::reinterpret_borrow<py::object>(name(a))
              : py::reinterpret_steal<py::object>(PyTuple_Pack(2, name(a), name(b)));
      if (!key) throw py::error_already_set();
      // A tuple of two str can hold no reference cycle: untracked, as CPython's collector would
      // leave it after its first pass, so the collections these allocations set off (one per
      // 700) do not walk the tuples made so far (a third of the set's time for 3,135 pairs).
      if (kind != Kind::single) PyObject_GC_UnTrack(key.ptr());
      if (PySet_Add(names.ptr(), key.ptr()) != 0) throw py::error_already_set();
    }
    items.append(names);
  }
  if (want.data) items.append(contactsDict(o.contacts));
  return py::tuple(items);
}

// A collide query: `run` with the GIL released under the managers' read locks, then the result
// built with the GIL while the locks still keep the entries it names. Python code that runs in
// between (a __del__ on an allocation) may not change a manager, which would wait for these
// locks: refused as from a query's callback (noCallback).
template <class Run>
py::object collideQuery(const Manager& m, const Manager* other, const Want& w, Kind kind,
                        Run&& run) {
  CollideOut o;
  std::optional<ReadLocks> lock;
  {
    py::gil_scoped_release nogil;
    lock.emplace(m, other);
    o = run();
  }
  CallbackScope refuse;
  return collideReturn(o, w, kind);
}

Want want(bool names, bool data, int max_contacts) {
  if (max_contacts < 1) throw py::value_error("max_contacts must be >= 1");
  return {names, data, max_contacts};
}

// Distances.
struct DistOut {
  double distance = kInf;
  std::string a, b;
  fcl::Vector3d pa = fcl::Vector3d::Zero(), pb = fcl::Vector3d::Zero();
  intptr_t ba = -1, bb = -1;  // FCL's primitive indices (b1, b2) in the order of a, b
  bool found = false;
};

struct FclDistance {
  const Manager* self;
  const Manager* other;
  fcl::DistanceRequestd request;
  fcl::DistanceResultd best;
  ObjPtr o1 = nullptr, o2 = nullptr;

  static bool callback(ObjPtr a, ObjPtr b, void* data, double& dist) {
    auto& c = *static_cast<FclDistance*>(data);
    const Entry* ea = Manager::entryOf(a);
    const Entry* eb = Manager::entryOf(b);
    if (a == b || !pairAllowed(*c.self, c.other, ea, eb)) return false;
    fcl::DistanceResultd r;
    fcl::distance(a, b, c.request, r);
    if (r.min_distance < c.best.min_distance) {
      c.best = r;
      c.o1 = a;
      c.o2 = b;
    }
    dist = c.best.min_distance;
    return dist <= 0;
  }
};

// Names the objects of a cube pipeline's result, whose o1 / o2 name geometries: each FCL geometry
// belongs to one object of its manager (add_object copies a geometry added twice).
DistOut nameResult(const fcl::DistanceResultd& r, const Manager& m,
                   const fcl::CollisionGeometryd* query, const Manager* other) {
  DistOut out;
  if (r.o1 == nullptr || !(r.min_distance < std::numeric_limits<double>::max())) return out;
  out.found = true;
  out.distance = r.min_distance;
  out.pa = r.nearest_points[0];
  out.pb = r.nearest_points[1];
  out.ba = r.b1;
  out.bb = r.b2;
  const Entry* a = nullptr;
  const Entry* b = nullptr;
  bool swapped = false;
  if (query) {
    if (r.o2 == query) {
      a = m.byGeometry(r.o1);
    } else {
      a = m.byGeometry(r.o2);
      swapped = true;
    }
  } else {
    const Manager& mb = other ? *other : m;
    a = m.byGeometry(r.o1);
    b = mb.byGeometry(r.o2);
    if (!(a && b)) {
      a = m.byGeometry(r.o2);
      b = mb.byGeometry(r.o1);
      swapped = true;
    }
  }
  if (swapped) {
    std::swap(out.pa, out.pb);
    std::swap(out.ba, out.bb);
  }
  out.a = a ? a->name : "?";
  out.b = query ? kExternal : (b ? b->name : "?");
  return out;
}

DistOut fromFcl(const FclDistance& c) {
  DistOut out;
  if (c.o1) {
    out.found = true;
    out.distance = c.best.min_distance;
    out.a = nameOf(c.o1);
    out.b = nameOf(c.o2);
    out.pa = c.best.nearest_points[0];
    out.pb = c.best.nearest_points[1];
    out.ba = c.best.b1;
    out.bb = c.best.b2;
  }
  return out;
}

// A cube manager and an FCL-backend one, as mixedCollide: each object of the cube manager asked
// of the FCL tree with the best distance so far (which prunes), both objects' bits checked per
// pair. Names and points come as (FCL side, cube side).
DistOut mixedDistance(const Manager& fcl_side, const Manager& cube_side, bool points) {
  FclDistance c{&fcl_side, &cube_side, fcl::DistanceRequestd(points), {}, nullptr, nullptr};
  for (const Entry* e : cube_side.ordered()) {
    fcl_side.broadphase().distance(e->obj.get(), &c, &FclDistance::callback);
    if (c.o1 && c.best.min_distance <= 0) break;
  }
  return fromFcl(c);
}

// The smallest distance from one object of m to the others: a distance query with the object
// itself. The cube manager never pairs a registered object with itself and applies its bits and
// ignored pairs (the pipeline, as the other distance queries); FCL's tree pairs it with itself,
// which the callback skips, asking the pair rules per pair.
DistOut distanceFrom(const Manager& m, const Entry& e, bool points) {
  fcl::DistanceRequestd request(points);
  if (m.isCube()) {
    cube::NarrowPhaseOptions<double> opt;
    opt.threads = m.threads();
    fcl::DistanceResultd r = cube::minimumDistance(*m.cube(), e.obj.get(), request, opt);
    DistOut out = nameResult(r, m, e.obj->collisionGeometry().get(), nullptr);
    if (out.found) out.b = e.name;  // nameResult names the query object as trimesh's external
    return out;
  }
  FclDistance c{&m, nullptr, request, {}, nullptr, nullptr};
  m.broadphase().distance(e.obj.get(), &c, &FclDistance::callback);
  return fromFcl(c);
}

DistOut distance(const Manager& m, ObjPtr query, const Manager* other, bool points) {
  fcl::DistanceRequestd request(points);
  if (other && m.isCube() != other->isCube()) {
    if (!m.isCube()) return mixedDistance(m, *other, points);
    DistOut o = mixedDistance(*other, m, points);
    std::swap(o.a, o.b);
    std::swap(o.pa, o.pb);
    std::swap(o.ba, o.bb);
    return o;
  }
  if (m.isCube()) {
    cube::NarrowPhaseOptions<double> opt;
    opt.threads = m.threads();
    const auto& c = *m.cube();
    fcl::DistanceResultd r = query   ? cube::minimumDistance(c, query, request, opt)
                             : other ? cube::minimumDistance(c, other->broadphase(), request, opt)
                                     : cube::minimumDistance(c, request, opt);
    return nameResult(r, m, query ? query->collisionGeometry().get() : nullptr, other);
  }
  FclDistance c{&m, other, request, {}, nullptr, nullptr};
  if (query)
    m.broadphase().distance(query, &c, &FclDistance::callback);
  else if (other)
    m.broadphase().distance(&other->broadphase(), &c, &FclDistance::callback);
  else
    m.broadphase().distance(&c, &FclDistance::callback);
  return fromFcl(c);
}

py::object distanceReturn(const DistOut& o, bool names, bool data, Kind kind) {
  if (!names && !data) return py::float_(o.distance);
  py::list items;
  items.append(py::float_(o.distance));
  if (names) {
    if (!o.found)
      items.append(py::none());
    else if (kind == Kind::single)
      items.append(py::str(o.a));
    else if (kind == Kind::internal)
      items.append(o.a < o.b ? py::make_tuple(o.a, o.b) : py::make_tuple(o.b, o.a));
    else
      items.append(py::make_tuple(o.a, o.b));
  }
  if (data) {
    py::dict d;
    d["distance"] = o.distance;
    if (o.found) {
      d["names"] = py::make_tuple(o.a, o.b);
      py::array_t<double> pts({2, 3});
      auto p = pts.mutable_unchecked<2>();
      for (int k = 0; k < 3; ++k) {
        p(0, k) = o.pa[k];
        p(1, k) = o.pb[k];
      }
      d["points"] = pts;
    } else {
      d["names"] = py::none();
      d["points"] = py::none();
    }
    items.append(d);
  }
  return py::tuple(items);
}

// Rays and regions. The FCL backend loops over every object with the same per-object test
// (cube::raycastObject on the object's box, grown by its margin as the cube manager's is).
// A query's filter bits (none: every object) against each object's, as in
// cube::QueryFilter.
using Bits = std::optional<std::pair<std::uint64_t, std::uint64_t>>;

std::optional<cube::QueryFilter> queryFilter(const Bits& bits) {
  if (!bits) return std::nullopt;
  return cube::QueryFilter{bits->first, bits->second};
}

bool lets(const Entry& e, const Bits& bits) {
  return !bits || ((e.category & bits->second) != 0 && (bits->first & e.mask) != 0);
}

struct Ray {
  std::string name;
  double t, distance;
  fcl::Vector3d point;
};

std::vector<Ray> rayAll(const Manager& m, const fcl::Vector3d& from, const fcl::Vector3d& to,
                        const cube::RayOptions<double>& opt, bool first_only, const Bits& bits) {
  std::vector<Ray> out;
  auto add = [&](const cube::RayHit<double>& h) {
    out.push_back({nameOf(h.object), h.t, h.distance, h.point});
  };
  if (m.isCube()) {
    if (first_only) {
      if (auto h = cube::raycastFirst(*m.cube(), from, to, opt, queryFilter(bits))) add(*h);
    } else {
      for (const auto& h : cube::raycastAll(*m.cube(), from, to, opt, queryFilter(bits))) add(h);
    }
    return out;
  }
  std::vector<std::pair<cube::RayHit<double>, std::uint64_t>> hits;
  for (const Entry* e : m.ordered()) {
    if (!lets(*e, bits)) continue;
    if (auto h = cube::raycastObject<double>(*e->obj, e->obj->getAABB(), from, to, opt))
      hits.emplace_back(*h, e->seq);
  }
  std::stable_sort(hits.begin(), hits.end(),
                   [](const auto& x, const auto& y) { return x.first.t < y.first.t; });
  if (first_only && hits.size() > 1) hits.resize(1);
  for (const auto& h : hits) add(h.first);
  return out;
}

std::vector<std::string> region(const Manager& m, const fcl::AABBd* box, const fcl::Vector3d* point,
                                double radius, const Bits& bits) {
  std::vector<std::string> out;
  if (m.isCube()) {
    const auto objs = box ? cube::objectsInBox(*m.cube(), *box, queryFilter(bits))
                          : cube::objectsNear(*m.cube(), *point, radius, queryFilter(bits));
    for (auto* o : objs) out.push_back(nameOf(o));
    return out;
  }
  for (const Entry* e : m.ordered()) {
    if (!lets(*e, bits)) continue;
    const fcl::AABBd& b = e->obj->getAABB();
    bool in = true;
    if (box) {
      for (int k = 0; k < 3; ++k) in = in && b.min_[k] <= box->max_[k] && box->min_[k] <= b.max_[k];
    } else {
      double sum = 0;
      for (int k = 0; k < 3; ++k) {
        const double gap = std::max({b.min_[k] - (*point)[k], (*point)[k] - b.max_[k], 0.0});
        in = in && gap <= radius;
        sum += gap * gap;
      }
      in = in && (std::isinf(radius) || sum <= radius * radius);
    }
    if (in) out.push_back(e->name);
  }
  return out;
}

fcl::Vector3d vec3(const double* d) {
  return {d[0], d[1], d[2]};
}

// The private hooks: a Python callable per candidate pair, as python-fcl's manager calls
// trimesh's callback, with a new Python object per side per call as python-fcl makes.
struct Handle {
  std::string name;
  ObjPtr obj;
  py::object geometry;  // the Geometry the object was added with (python-fcl: its userData)
};

Handle handleOf(ObjPtr o) {
  const Entry* e = Manager::entryOf(o);
  return {nameOf(o), o, e ? py::cast(e->geometry) : py::none()};
}

// Every exception of the callback (a Python one, or a result of the wrong type) is kept and
// stops the walk: none crosses the broadphase, whose walk is left as it would be after a stop.
struct PyDrive {
  py::function fn;
  const char* what;
  std::exception_ptr error;

  template <class Call>
  static bool guarded(void* data, Call&& call) {
    auto& d = *static_cast<PyDrive*>(data);
    try {
      return call(d);
    } catch (const py::cast_error& e) {
      d.error = std::make_exception_ptr(py::type_error(
          std::string(d.what) + ": the callback returned the wrong type (" + e.what() + ")"));
    } catch (...) {
      d.error = std::current_exception();
    }
    return true;
  }
  static bool collideCb(ObjPtr a, ObjPtr b, void* data) {
    return guarded(data, [&](PyDrive& d) { return d.fn(handleOf(a), handleOf(b)).cast<bool>(); });
  }
  static bool distanceCb(ObjPtr a, ObjPtr b, void* data, double& dist) {
    return guarded(data, [&](PyDrive& d) {
      py::tuple r = d.fn(handleOf(a), handleOf(b));
      const double got = r[1].cast<double>();
      const bool stop = r[0].cast<bool>();
      dist = got;
      return stop;
    });
  }
  /// Runs a hook's walk on m with the thread marked as in a callback (restored on every exit),
  /// then rethrows what a callback raised.
  template <class Walk>
  void run(const Manager& m, const Manager* other, Walk&& walk) {
    {
      ReadLocks lock(m, other);
      CallbackScope scope;
      walk();
    }
    if (error) std::rethrow_exception(error);
  }
};

// What a query of the python-fcl layer (cube_collision.fcl) pairs the manager's objects with:
// none (among themselves), another manager, or a (geometry, transform) tuple (a query object,
// not registered: its user data is null, its name "__external").
struct Target {
  const Manager* other = nullptr;
  GeometryPtr geometry;
  std::unique_ptr<Object> query;
};

Target targetOf(const Manager& m, py::handle target, const char* what) {
  Target t;
  if (target.is_none()) return t;
  if (py::isinstance<Manager>(target)) {
    const Manager* o = target.cast<const Manager*>();
    if (o->isCube() != m.isCube())
      throw py::value_error(std::string(what) + ": both managers must have the same backend");
    t.other = o == &m ? nullptr : o;
    return t;
  }
  if (!py::isinstance<py::tuple>(target) || py::len(target) != 2)
    throw py::type_error(std::string(what) +
                         ": target must be None, a CollisionManager or (geometry, transform)");
  py::tuple tup = py::reinterpret_borrow<py::tuple>(target);
  t.geometry = geometryOf(tup[0]);
  t.query = std::make_unique<Object>(t.geometry->fcl, transform(tup[1]));
  return t;
}

// python-fcl's request objects (cube_collision.fcl's CollisionRequest / DistanceRequest, or any
// object with their attributes), read as python-fcl's collide() and distance() read them.
fcl::CollisionRequestd collisionRequestOf(py::handle r) {
  const auto n = r.attr("num_max_contacts").cast<long long>();
  if (n < 1) throw py::value_error("num_max_contacts must be >= 1");
  fcl::CollisionRequestd req(static_cast<std::size_t>(n), r.attr("enable_contact").cast<bool>(),
                             r.attr("num_max_cost_sources").cast<std::size_t>(),
                             r.attr("enable_cost").cast<bool>(),
                             r.attr("use_approximate_cost").cast<bool>());
  req.gjk_solver_type = static_cast<fcl::GJKSolverType>(r.attr("gjk_solver_type").cast<int>());
  return req;
}

fcl::DistanceRequestd distanceRequestOf(py::handle r) {
  fcl::DistanceRequestd req(r.attr("enable_nearest_points").cast<bool>());
  req.enable_signed_distance =
      py::getattr(r, "enable_signed_distance", py::bool_(false)).cast<bool>();
  req.gjk_solver_type = static_cast<fcl::GJKSolverType>(r.attr("gjk_solver_type").cast<int>());
  return req;
}

// A python-fcl Contact (contact_type called as Contact(o1, o2, b1, b2, normal, pos,
// penetration_depth)) from FCL's contact between the objects whose FCL geometry is ga (Python
// geometry pa) and the other (pb). Without enable_contact FCL leaves normal and pos unset: zeros.
py::object makeContact(py::handle contact_type, const fcl::Contactd& c,
                       const fcl::CollisionGeometryd* ga, py::handle pa, py::handle pb,
                       bool positions) {
  const bool a_first = c.o1 == ga;
  const fcl::Vector3d zero = fcl::Vector3d::Zero();
  return contact_type(a_first ? pa : pb, a_first ? pb : pa, c.b1, c.b2,
                      toArray(positions ? c.normal : zero), toArray(positions ? c.pos : zero),
                      c.penetration_depth);
}

}  // namespace

void bindManagerQueries(ManagerClass& cls) {
  cls.def(
         "in_collision_internal",
         [](const Manager& m, bool names, bool data, int max_contacts) {
           const Want w = want(names, data, max_contacts);
           return collideQuery(m, nullptr, w, Kind::internal,
                               [&] { return collide(m, nullptr, nullptr, w); });
         },
         py::arg("return_names") = false, py::arg("return_data") = false,
         py::arg("max_contacts") = 100000, R"doc(
Does any pair of objects collide (filter bits and ignored pairs applied; with margins, or come
closer than margin(a) + margin(b))? As trimesh: returns is_collision, plus (return_names) the set
of colliding pairs as sorted (name, name) tuples, plus (return_data) the contacts as a dict of
arrays: 'names' (n, 2) object, 'points' (n, 3), 'normals' (n, 3) (from the first to the second
name), 'depths' (n,), up to max_contacts per pair (FCL's contacts; a pair within its margins but
apart gets one row: the middle of the nearest points, their direction, depth = -distance).
Names only stop each pair's narrow phase at its first contact; data asks FCL for every contact.)doc")
      .def(
          "in_collision_single",
          [](const Manager& m, py::handle geometry, py::handle tf, bool names, bool data,
             int max_contacts, py::handle mesh) {
            const Want w = want(names, data, max_contacts);
            GeometryPtr g = geometryOf(geometryArg(geometry, mesh, "in_collision_single"));
            Object q(g->fcl, transform(tf));
            return collideQuery(m, nullptr, w, Kind::single, [&] {
              refuseFclCrashes(&m, nullptr, {g->kind}, false, "in_collision_single");
              q.refresh(m.isCube() ? 0.0 : m.managerMargin());
              return collide(m, &q, nullptr, w);
            });
          },
          py::arg("geometry") = py::none(), py::arg("transform") = py::none(),
          py::arg("return_names") = false, py::arg("return_data") = false,
          py::arg("max_contacts") = 100000, py::kw_only(), py::arg("mesh") = py::none(), R"doc(
Does `geometry` (a Geometry or a trimesh.Trimesh, taken as add_object takes it: a convex one as a
solid; or by trimesh's keyword mesh=) placed by `transform` (4x4 rigid, None: identity) collide
with any object? Returns is_collision, plus the set of names hit, plus the contacts dict (names
(object, '__external')), as in_collision_internal. The query has the default filter bits and the
manager-wide margin. TypeError / ValueError for a bad geometry or transform, TypeError for both
or neither of geometry and mesh.)doc")
      .def(
          "in_collision_other",
          [](const Manager& m, const Manager& other, bool names, bool data, int max_contacts) {
            const Want w = want(names, data, max_contacts);
            return collideQuery(m, &other, w, &m == &other ? Kind::internal : Kind::other, [&] {
              if (&m != &other) refuseFclCrashes(&m, &other, {}, false, "in_collision_other");
              return &m == &other ? collide(m, nullptr, nullptr, w)
                                  : collide(m, nullptr, &other, w);
            });
          },
          py::arg("other_manager"), py::arg("return_names") = false, py::arg("return_data") = false,
          py::arg("max_contacts") = 100000, R"doc(
Does any object of this manager collide with one of `other_manager` (either backend)? Returns
is_collision, plus the set of (name here, name there) tuples, plus the contacts dict, as
in_collision_internal. Filter bits apply across the two managers, whichever backend each has
(a cube manager against an FCL-backend one asks FCL's tree for each of its objects); ignored
pairs and margins do not. The same manager as other is in_collision_internal.)doc")
      .def(
          "min_distance_internal",
          [](const Manager& m, bool names, bool data, py::object name) {
            const std::optional<std::string> from =
                name.is_none() ? std::nullopt : std::optional<std::string>(nameOfArg(name));
            DistOut o;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m);
              const Entry* e = from ? m.find(*from) : nullptr;
              refuseFclCrashes(&m, nullptr, {}, true, "min_distance_internal");
              o = e ? distanceFrom(m, *e, data) : distance(m, nullptr, nullptr, data);
            }
            return distanceReturn(o, names, data, Kind::internal);
          },
          py::arg("return_names") = false, py::arg("return_data") = false,
          py::arg("name") = py::none(), R"doc(
The smallest distance between two objects (FCL's fcl::distance; <= 0 when some pair touches: the
search stops at the first such pair; inf with fewer than two objects that may pair). A pair with
a plane (the two-sided plane n . x = offset; cube backend only), on which FCL 0.7's fcl::distance
crashes, gets its exact distance in closed form instead, -1 when they meet; the 'fcl' backend
refuses a distance query with a plane (ValueError). Filter bits and ignored pairs apply, margins
do not. name: only the pairs of that object with the others (trimesh's name=: the distance from
it to the rest; give it by keyword, trimesh's newest puts it first). Returns distance, plus
(return_names) the sorted (name, name) tuple (None if none), plus (return_data) a dict:
'distance', 'names' (as found), 'points' (2, 3) the nearest points in the world frame, in the
order of 'names'. UnknownNameError (a KeyError and a ValueError) for an unknown name, TypeError
for a name that is not a str.)doc")
      .def(
          "min_distance_single",
          [](const Manager& m, py::handle geometry, py::handle tf, bool name, bool data,
             py::handle mesh) {
            GeometryPtr g = geometryOf(geometryArg(geometry, mesh, "min_distance_single"));
            Object q(g->fcl, transform(tf));
            DistOut o;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m);
              refuseFclCrashes(&m, nullptr, {g->kind}, true, "min_distance_single");
              o = distance(m, &q, nullptr, data);
            }
            return distanceReturn(o, name, data, Kind::single);
          },
          py::arg("geometry") = py::none(), py::arg("transform") = py::none(),
          py::arg("return_name") = false, py::arg("return_data") = false, py::kw_only(),
          py::arg("mesh") = py::none(), R"doc(
The smallest distance from `geometry` (or trimesh's keyword mesh=, as in_collision_single)
placed by `transform` to any object. Returns distance, plus (return_name) the nearest object's
name, plus the data dict (names (name, '__external')), as min_distance_internal.)doc")
      .def(
          "min_distance_other",
          [](const Manager& m, const Manager& other, bool names, bool data) {
            DistOut o;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m, &other);
              refuseFclCrashes(&m, &m == &other ? nullptr : &other, {}, true, "min_distance_other");
              o = distance(m, nullptr, &m == &other ? nullptr : &other, data);
            }
            return distanceReturn(o, names, data, &m == &other ? Kind::internal : Kind::other);
          },
          py::arg("other_manager"), py::arg("return_names") = false, py::arg("return_data") = false,
          R"doc(
The smallest distance between an object here and one of `other_manager` (either backend) whose
filter bits let them pair. Returns distance, plus the (name here, name there) tuple, plus the
data dict, as min_distance_internal.)doc")
      .def(
          "ray_first",
          [](const Manager& m, py::handle origins, py::handle ends, bool narrow, double tol,
             const Bits& bits) {
            Array o = floats(origins, "origins", {-1, 3});
            Array e = floats(ends, "ends", {o.shape(0), 3});
            if (!(tol >= 0)) throw py::value_error("tolerance must be >= 0");
            const auto n = static_cast<std::size_t>(o.shape(0));
            cube::RayOptions<double> opt;
            opt.narrow_phase = narrow;
            opt.tolerance = tol;
            std::vector<std::optional<Ray>> hits(n);
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m);
              for (std::size_t i = 0; i < n; ++i) {
                auto r = rayAll(m, vec3(o.data() + 3 * i), vec3(e.data() + 3 * i), opt, true, bits);
                if (!r.empty()) hits[i] = r[0];
              }
            }
            py::list names;
            py::array_t<double> t(static_cast<py::ssize_t>(n)),
                pts({static_cast<py::ssize_t>(n), py::ssize_t(3)});
            auto tt = t.mutable_unchecked<1>();
            auto pp = pts.mutable_unchecked<2>();
            for (std::size_t i = 0; i < n; ++i) {
              names.append(hits[i] ? py::object(py::str(hits[i]->name)) : py::none());
              tt(i) = hits[i] ? hits[i]->t : std::nan("");
              for (int k = 0; k < 3; ++k) pp(i, k) = hits[i] ? hits[i]->point[k] : std::nan("");
            }
            py::object arr =
                py::module_::import("numpy").attr("array")(names, py::arg("dtype") = "object");
            return py::make_tuple(arr, t, pts);
          },
          py::arg("origins"), py::arg("ends"), py::arg("narrow_phase") = true,
          py::arg("tolerance") = 1e-6, py::kw_only(), py::arg("filter") = py::none(), R"doc(
The first object each segment meets: origins and ends are (n, 3) arrays, segment i from
origins[i] to ends[i]. Returns (names (n,) object array, None for a miss; t (n,) in [0, 1] along
the segment, NaN for a miss; points (n, 3), NaN for a miss). narrow_phase=False: the objects'
boxes decide. Exact for primitives, within `tolerance` (a length) for meshes, cones and convexes
(cube_collision/spatial_queries.h). Ties: the earlier added object. filter: the query's
(category, mask) filter bits: only objects whose bits (set_filter) pair with them are hit
(None: every object). ValueError for non-finite or mis-shaped points, a negative tolerance.)doc")
      .def(
          "ray_all",
          [](const Manager& m, py::handle origin, py::handle end, bool narrow, double tol,
             const Bits& bits) {
            Array o = floats(origin, "origin", {3});
            Array e = floats(end, "end", {3});
            if (!(tol >= 0)) throw py::value_error("tolerance must be >= 0");
            cube::RayOptions<double> opt;
            opt.narrow_phase = narrow;
            opt.tolerance = tol;
            std::vector<Ray> hits;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m);
              hits = rayAll(m, vec3(o.data()), vec3(e.data()), opt, false, bits);
            }
            const auto n = static_cast<py::ssize_t>(hits.size());
            py::list names;
            py::array_t<double> t(n), pts({n, py::ssize_t(3)});
            auto tt = t.mutable_unchecked<1>();
            auto pp = pts.mutable_unchecked<2>();
            for (py::ssize_t i = 0; i < n; ++i) {
              names.append(hits[i].name);
              tt(i) = hits[i].t;
              for (int k = 0; k < 3; ++k) pp(i, k) = hits[i].point[k];
            }
            return py::make_tuple(names, t, pts);
          },
          py::arg("origin"), py::arg("end"), py::arg("narrow_phase") = true,
          py::arg("tolerance") = 1e-6, py::kw_only(), py::arg("filter") = py::none(), R"doc(
Every object the segment from origin (3,) to end (3,) meets, by t (ties: the earlier added).
Returns (names list, t (k,), points (k, 3)). As ray_first otherwise (filter too).)doc")
      .def(
          "objects_in_box",
          [](const Manager& m, py::handle lower, py::handle upper, const Bits& bits) {
            Array lo = floats(lower, "lower", {3}, false);
            Array hi = floats(upper, "upper", {3}, false);
            fcl::AABBd box;
            for (int k = 0; k < 3; ++k) {
              if (std::isnan(lo.at(k)) || std::isnan(hi.at(k)) || lo.at(k) > hi.at(k))
                throw py::value_error("objects_in_box: bounds must not be NaN, lower <= upper");
              box.min_[k] = lo.at(k);
              box.max_[k] = hi.at(k);
            }
            py::gil_scoped_release nogil;
            ReadLocks lock(m);
            return region(m, &box, nullptr, 0, bits);
          },
          py::arg("lower"), py::arg("upper"), py::kw_only(), py::arg("filter") = py::none(),
          R"doc(
The names of the objects whose box (the AABB, grown by the margin) overlaps the box
[lower, upper] (touching counts; infinite bounds allowed), in the order added. filter: the
query's (category, mask) filter bits, as ray_first's (None: every object). ValueError for a NaN
bound or lower > upper.)doc")
      .def(
          "objects_near",
          [](const Manager& m, py::handle point, double radius, const Bits& bits) {
            Array p = floats(point, "point", {3});
            if (!(radius >= 0)) throw py::value_error("radius must be >= 0");
            const fcl::Vector3d c = vec3(p.data());
            py::gil_scoped_release nogil;
            ReadLocks lock(m);
            return region(m, nullptr, &c, radius, bits);
          },
          py::arg("point"), py::arg("radius"), py::kw_only(), py::arg("filter") = py::none(),
          R"doc(
The names of the objects whose box (the AABB, grown by the margin) lies within radius of point
(the distance to the box, not to the geometry), in the order added. filter: as objects_in_box's.
ValueError for a non-finite point or a negative or NaN radius.)doc")
      .def(
          "_collide_python",
          [](const Manager& m, py::function fn, py::object target) {
            Target t = targetOf(m, target, "_collide_python");
            PyDrive d{fn, "_collide_python", nullptr};
            d.run(m, t.other, [&] {
              if (t.query)
                m.broadphase().collide(t.query.get(), &d, &PyDrive::collideCb);
              else if (t.other)
                m.broadphase().collide(&t.other->broadphase(), &d, &PyDrive::collideCb);
              else
                m.broadphase().collide(&d, &PyDrive::collideCb);
            });
          },
          py::arg("callback"), py::arg("target") = py::none(),
          "Hook of the benchmark (trimesh's way over python-fcl) and of cube_collision.fcl's "
          "managers with a user's callback: the backend's collide calling "
          "callback(handle_a, handle_b) -> bool (True stops) for every candidate pair; target: "
          "None (self-collide), another manager of the same backend, or (geometry, transform) "
          "(handle name '__external'). Filters are not applied. The managers must not change "
          "from the callback (RuntimeError). What the callback raises stops the walk and is "
          "raised here; TypeError for a result that is not a bool.")
      .def(
          "_distance_python",
          [](const Manager& m, py::function fn, py::object target) {
            Target t = targetOf(m, target, "_distance_python");
            PyDrive d{fn, "_distance_python", nullptr};
            d.run(m, t.other, [&] {
              if (t.query)
                m.broadphase().distance(t.query.get(), &d, &PyDrive::distanceCb);
              else if (t.other)
                m.broadphase().distance(&t.other->broadphase(), &d, &PyDrive::distanceCb);
              else
                m.broadphase().distance(&d, &PyDrive::distanceCb);
            });
          },
          py::arg("callback"), py::arg("target") = py::none(),
          "Hook as _collide_python for the backend's distance: callback(handle_a, handle_b) -> "
          "(stop, best distance so far) for every pair it visits (TypeError for a result that "
          "is not (bool, float)).")
      .def(
          "_fcl_collide_all",
          [](const Manager& m, py::object target, py::object request, py::object result,
             py::object contact_type, py::dict geoms, py::object other_geoms,
             py::object query_geom) {
            const fcl::CollisionRequestd req = collisionRequestOf(request);
            const bool prior = result.attr("is_collision").cast<bool>();
            py::list contacts = result.attr("contacts");
            const std::size_t prior_count = py::len(contacts);
            Target t = targetOf(m, target, "collide");
            if (!m.isCube()) throw py::value_error("_fcl_collide_all: a cube manager only");
            struct Row {
              ObjPtr a, b;
              fcl::Contactd c;
            };
            std::vector<Row> rows;
            bool any = false, done = false;
            std::optional<ReadLocks> lock;
            {
              py::gil_scoped_release nogil;
              lock.emplace(m, t.other);
              const auto& c = *m.cube();
              const std::vector<cube::ObjectPair<double>> pairs =
                  t.query   ? cube::overlappingPairs(c, t.query.get())
                  : t.other ? cube::overlappingPairs(c, t.other->broadphase())
                            : cube::overlappingPairs(c);
              cube::NarrowPhaseOptions<double> opt;
              opt.threads = m.threads();
              // python-fcl's defaultCollisionCallback: fcl::collide per candidate pair (a fresh
              // result each, its contacts appended), done once the result holds more than
              // num_max_contacts contacts (costs aside). Pairs go to the pipeline at once when
              // the budget is at least their number, else in chunks that double from 64, so
              // that an early stop wastes little.
              std::size_t count = prior_count;
              std::size_t chunk = req.num_max_contacts < pairs.size() ? 64 : pairs.size();
              for (std::size_t start = 0; start < pairs.size() && !done;
                   start += chunk, chunk = std::min<std::size_t>(2 * chunk, 8192)) {
                const std::vector<cube::ObjectPair<double>> sub(
                    pairs.begin() + static_cast<std::ptrdiff_t>(start),
                    pairs.begin() +
                        static_cast<std::ptrdiff_t>(std::min(pairs.size(), start + chunk)));
                const auto results = cube::collidePairs(sub, req, opt);
                for (std::size_t i = 0; i < sub.size(); ++i) {
                  if (results[i].isCollision()) {
                    any = true;
                    for (std::size_t k = 0; k < results[i].numContacts(); ++k)
                      rows.push_back({sub[i].first, sub[i].second, results[i].getContact(k)});
                    count += results[i].numContacts();
                  }
                  if (!req.enable_cost && (prior || any) && count > req.num_max_contacts) {
                    done = true;
                    break;
                  }
                }
              }
            }
            // Built while the locks keep the entries; Python code run by an allocation may not
            // change a manager (as collideQuery).
            CallbackScope refuse;
            const auto geomOf = [&](ObjPtr o) -> py::object {
              const Entry* e = Manager::entryOf(o);
              if (!e) return query_geom;
              PyObject* g = PyDict_GetItem(geoms.ptr(), e->pyname.ptr());
              if (!g && PyDict_Check(other_geoms.ptr()))
                g = PyDict_GetItem(other_geoms.ptr(), e->pyname.ptr());
              return g ? py::reinterpret_borrow<py::object>(g) : py::object(py::none());
            };
            ObjPtr last_a = nullptr, last_b = nullptr;
            py::object pa, pb;
            for (const Row& r : rows) {
              if (r.a != last_a || r.b != last_b) {
                last_a = r.a;
                last_b = r.b;
                pa = geomOf(r.a);
                pb = geomOf(r.b);
              }
              contacts.append(makeContact(contact_type, r.c, r.a->collisionGeometry().get(), pa, pb,
                                          req.enable_contact));
            }
            result.attr("is_collision") = prior || any;
            return done;
          },
          py::arg("target"), py::arg("request"), py::arg("result"), py::arg("contact_type"),
          py::arg("geoms"), py::arg("other_geoms"), py::arg("query_geom"),
          "cube_collision.fcl's managers with python-fcl's defaultCollisionCallback, in C++: "
          "fcl::collide with `request` on every candidate pair (target as _collide_python) in "
          "the walk's order, each pair's contacts appended to result.contacts as "
          "contact_type(o1, o2, b1, b2, normal, pos, depth), o1 / o2 the Python geometries "
          "geoms[name] (or other_geoms[name]; query_geom for the query object), until the "
          "result holds more than num_max_contacts contacts. Sets result.is_collision; returns "
          "whether that limit stopped the query (python-fcl's cdata.done).")
      .def(
          "_fcl_distance_all",
          [](const Manager& m, py::object target, py::object request, py::object result,
             py::dict geoms, py::object other_geoms, py::object query_geom) {
            const fcl::DistanceRequestd req = distanceRequestOf(request);
            Target t = targetOf(m, target, "distance");
            if (!m.isCube()) throw py::value_error("_fcl_distance_all: a cube manager only");
            DistOut o;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m, t.other);
              refuseFclCrashes(
                  &m, t.other,
                  t.query ? std::vector<std::string>{t.geometry->kind} : std::vector<std::string>{},
                  true, "distance");
              o = distance(m, t.query.get(), t.other, req.enable_nearest_points);
            }
            if (!o.found || !(o.distance < result.attr("min_distance").cast<double>())) return;
            const auto geomOf = [&](const std::string& name) -> py::object {
              if (name == kExternal) return query_geom;
              py::str key(name);
              PyObject* g = PyDict_GetItem(geoms.ptr(), key.ptr());
              if (!g && PyDict_Check(other_geoms.ptr()))
                g = PyDict_GetItem(other_geoms.ptr(), key.ptr());
              return g ? py::reinterpret_borrow<py::object>(g) : py::object(py::none());
            };
            result.attr("min_distance") = o.distance;
            py::list pts;
            pts.append(toArray(o.pa));
            pts.append(toArray(o.pb));
            result.attr("nearest_points") = pts;
            result.attr("o1") = geomOf(o.a);
            result.attr("o2") = geomOf(o.b);
            result.attr("b1") = o.ba;
            result.attr("b2") = o.bb;
          },
          py::arg("target"), py::arg("request"), py::arg("result"), py::arg("geoms"),
          py::arg("other_geoms"), py::arg("query_geom"),
          "cube_collision.fcl's managers with python-fcl's defaultDistanceCallback, in C++: the "
          "smallest distance (the package's minimum-distance query; target as _collide_python) "
          "written to result (min_distance, nearest_points, o1 / o2 as _fcl_collide_all, b1, "
          "b2) if smaller than result.min_distance. ValueError with a plane (FCL 0.7 has no "
          "distance for it).");
}

void bindQueries(py::module_& m) {
  py::class_<Handle>(m, "_Handle", "An object handed to a benchmark hook's callback.")
      .def_readonly("name", &Handle::name)
      .def_readonly("geometry", &Handle::geometry);
  // python-fcl's collide() and distance() (Cython there, C++ here): the request read from the
  // Python request's attributes on every call, a fresh FCL result, and each contact made a
  // Python object (numpy normal and position) appended to the Python result.
  m.def(
      "_fcl_collide",
      [](const Handle& a, const Handle& b, py::object request, py::object result,
         py::object contact_type) {
        fcl::CollisionRequestd req(request.attr("num_max_contacts").cast<std::size_t>(),
                                   request.attr("enable_contact").cast<bool>(),
                                   request.attr("num_max_cost_sources").cast<std::size_t>(),
                                   request.attr("enable_cost").cast<bool>(),
                                   request.attr("use_approximate_cost").cast<bool>());
        fcl::CollisionResultd res;
        const std::size_t ret = fcl::collide(a.obj, b.obj, req, res);
        result.attr("is_collision") = result.attr("is_collision").cast<bool>() || res.isCollision();
        py::list contacts = result.attr("contacts");
        const auto* ga = a.obj->collisionGeometry().get();
        for (std::size_t k = 0; k < res.numContacts(); ++k) {
          const auto& ct = res.getContact(k);
          py::object c = contact_type();
          c.attr("o1") = ct.o1 == ga ? a.geometry : b.geometry;
          c.attr("o2") = ct.o2 == ga ? a.geometry : b.geometry;
          c.attr("b1") = ct.b1;
          c.attr("b2") = ct.b2;
          c.attr("normal") = toArray(ct.normal);
          c.attr("pos") = toArray(ct.pos);
          c.attr("penetration_depth") = ct.penetration_depth;
          contacts.append(c);
        }
        return ret;
      },
      py::arg("o1"), py::arg("o2"), py::arg("request"), py::arg("result"), py::arg("contact_type"),
      "Benchmark hook: python-fcl's fcl.collide(o1, o2, request, result) on two handles.");
  m.def(
      "_fcl_distance",
      [](const Handle& a, const Handle& b, py::object request, py::object result) {
        fcl::DistanceRequestd req(request.attr("enable_nearest_points").cast<bool>());
        fcl::DistanceResultd res;
        const double d = fcl::distance(a.obj, b.obj, req, res);
        if (result.attr("min_distance").cast<double>() > res.min_distance) {
          result.attr("min_distance") = res.min_distance;
          py::list pts;
          pts.append(toArray(res.nearest_points[0]));
          pts.append(toArray(res.nearest_points[1]));
          result.attr("nearest_points") = pts;
          const auto* ga = a.obj->collisionGeometry().get();
          result.attr("o1") = res.o1 == ga ? a.geometry : b.geometry;
          result.attr("o2") = res.o2 == ga ? a.geometry : b.geometry;
          result.attr("b1") = res.b1;
          result.attr("b2") = res.b2;
        }
        return d;
      },
      py::arg("o1"), py::arg("o2"), py::arg("request"), py::arg("result"),
      "Benchmark hook: python-fcl's fcl.distance(o1, o2, request, result) on two handles.");

  // cube_collision.fcl's collide() and distance(): python-fcl's, on two placed geometries.
  m.def(
      "_fcl_pair_collide",
      [](py::handle ga, py::handle ta, py::handle gb, py::handle tb, py::object request,
         py::object result, py::object contact_type, py::object pa, py::object pb) {
        const fcl::CollisionRequestd req = collisionRequestOf(request);
        GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
        Object oa(a->fcl, transform(ta, "transform_a")), ob(b->fcl, transform(tb, "transform_b"));
        fcl::CollisionResultd res;
        {
          py::gil_scoped_release nogil;
          // The pipeline's narrow phase on one pair: fcl::collide, except for a convex against
          // a plane, on which FCL 0.7 crashes (answered from the convex's vertices).
          cube::NarrowPhaseOptions<double> opt;
          opt.threads = 1;
          res = cube::collidePairs<double>({{&oa, &ob}}, req, opt)[0];
        }
        result.attr("is_collision") = result.attr("is_collision").cast<bool>() || res.isCollision();
        py::list contacts = result.attr("contacts");
        for (std::size_t k = 0; k < res.numContacts(); ++k)
          contacts.append(makeContact(contact_type, res.getContact(k), a->fcl.get(), pa, pb,
                                      req.enable_contact));
        return res.numContacts();
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      py::arg("request"), py::arg("result"), py::arg("contact_type"), py::arg("o1"), py::arg("o2"),
      "cube_collision.fcl.collide: fcl::collide with a python-fcl request on two placed "
      "geometries; contacts appended to result.contacts as contact_type(o1, o2, b1, b2, normal, "
      "pos, depth) naming the Python geometries o1 / o2; returns the number of contacts.");
  m.def(
      "_fcl_pair_distance",
      [](py::handle ga, py::handle ta, py::handle gb, py::handle tb, py::object request,
         py::object result, py::object pa, py::object pb) {
        const fcl::DistanceRequestd req = distanceRequestOf(request);
        GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
        refuseFclCrashes(nullptr, nullptr, {a->kind, b->kind}, true, "distance");
        Object oa(a->fcl, transform(ta, "transform_a")), ob(b->fcl, transform(tb, "transform_b"));
        fcl::DistanceResultd res;
        double d;
        {
          py::gil_scoped_release nogil;
          d = fcl::distance(&oa, &ob, req, res);
        }
        if (res.min_distance < result.attr("min_distance").cast<double>()) {
          const bool a_first = res.o1 == a->fcl.get();
          result.attr("min_distance") = res.min_distance;
          py::list pts;
          pts.append(toArray(res.nearest_points[0]));
          pts.append(toArray(res.nearest_points[1]));
          result.attr("nearest_points") = pts;
          result.attr("o1") = a_first ? pa : pb;
          result.attr("o2") = a_first ? pb : pa;
          result.attr("b1") = res.b1;
          result.attr("b2") = res.b2;
        }
        return d;
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      py::arg("request"), py::arg("result"), py::arg("o1"), py::arg("o2"),
      "cube_collision.fcl.distance: fcl::distance with a python-fcl request on two placed "
      "geometries; result updated if closer (python-fcl's rule); returns the distance. "
      "ValueError with a plane (FCL 0.7's fcl::distance crashes on it).");

  auto pairObjects = [](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
    GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
    return std::make_pair(std::make_unique<Object>(a->fcl, transform(ta, "transform_a")),
                          std::make_unique<Object>(b->fcl, transform(tb, "transform_b")));
  };
  m.def(
      "pair_in_collision",
      [pairObjects](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
        auto [a, b] = pairObjects(ga, ta, gb, tb);
        refuseFclCrashes(nullptr, nullptr, {geometryOf(ga)->kind, geometryOf(gb)->kind}, false,
                         "pair_in_collision");
        py::gil_scoped_release nogil;
        fcl::CollisionResultd res;
        fcl::collide(a.get(), b.get(), fcl::CollisionRequestd(), res);
        return res.isCollision();
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      "FCL's own fcl::collide on two placed geometries (FCL's default request): no broadphase, "
      "for checks and tests; FCL 0.7's answer as it is (a cylinder against a plane: its "
      "defective yes/no test, which the managers correct). TypeError / ValueError for bad "
      "geometry or transforms.");
  m.def(
      "pair_distance",
      [pairObjects](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
        auto [a, b] = pairObjects(ga, ta, gb, tb);
        refuseFclCrashes(nullptr, nullptr, {geometryOf(ga)->kind, geometryOf(gb)->kind}, true,
                         "pair_distance");
        py::gil_scoped_release nogil;
        fcl::DistanceResultd res;
        fcl::distance(a.get(), b.get(), fcl::DistanceRequestd(), res);
        return res.min_distance;
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      "fcl::distance on two placed geometries (<= 0 when they touch). As pair_in_collision; "
      "ValueError for a plane (FCL 0.7's fcl::distance crashes on it).");
}

}  // namespace cubepy
