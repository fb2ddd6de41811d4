// The collision queries (trimesh's in_collision_internal / single / other), on either backend
// through the library's entry points over the manager's broadphase: the cube manager, or FCL's
// tree under the same rules (fcl_backend.h).

#include <cube_collision/margins.h>
#include <cube_collision/queries.h>
#include <fcl/narrowphase/distance.h>
#include <pybind11/stl.h>

#include <optional>

#include "query_common.h"

namespace cubepy {

namespace {

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

// Either backend: the pipeline on the broadphase's candidate pairs (the rules applied by its
// walk). Does anything collide: collideAll's early stop. Names or data: each candidate pair
// answered on its own (first contact only for names), on the pipeline's threads.
CollideOut pipelineCollide(const Manager& m, ObjPtr query, const Manager* other, const Want& want) {
  CollideOut out;
  cube::NarrowPhaseOptions<double> opt;
  opt.threads = m.threads();
  const auto& c = m.broadphase();
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

// FCL's tree with margins: its candidate pairs (boxes grown by the margins, the rules applied),
// the pipeline's collide on each, then fcl::distance against the sum of the two margins for the
// pairs apart: contactsWithinMargin's answer, which reads the cube manager's own tables.
CollideOut fclMargins(const Manager& m, ObjPtr query, const Want& want) {
  CollideOut out;
  const auto& bp = m.broadphase();
  const auto pairs = query ? cube::overlappingPairs(bp, query) : cube::overlappingPairs(bp);
  cube::NarrowPhaseOptions<double> opt;
  opt.threads = m.threads();
  const auto results = cube::collidePairs(
      pairs, want.anyOnly() ? fcl::CollisionRequestd() : want.pairRequest(), opt);
  for (std::size_t i = 0; i < pairs.size() && !(out.any && want.anyOnly()); ++i) {
    const auto [a, b] = pairs[i];
    if (results[i].isCollision()) {
      record(out, want, a, b, results[i]);
      continue;
    }
    const double sum = m.marginOf(Manager::entryOf(a)) + m.marginOf(Manager::entryOf(b));
    if (sum <= 0) continue;
    fcl::DistanceResultd d;
    fcl::distance(a, b, fcl::DistanceRequestd(true), d);
    if (d.min_distance <= sum)
      recordNear(out, want, a, b, d.min_distance, d.nearest_points[0], d.nearest_points[1]);
  }
  return out;
}

void swapSides(CollideOut& o) {
  for (auto& p : o.pairs) std::swap(p.first, p.second);
  for (auto& c : o.contacts) {
    std::swap(c.a, c.b);
    c.normal = -c.normal;
  }
}

CollideOut collide(const Manager& m, ObjPtr query, const Manager* other, const Want& want) {
  if (other && m.isCube() && !other->isCube()) {
    // FCL's tree asks the bits of both sides (the cube manager's walk knows only its own): it
    // leads, and the pairs come back as (here, there).
    CollideOut o = pipelineCollide(*other, nullptr, &m, want);
    swapSides(o);
    return o;
  }
  if (!other && m.anyMargin())
    return m.isCube() ? cubeMargins(m, query, want) : fclMargins(m, query, want);
  return pipelineCollide(m, query, other, want);
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

// in_collision_single's transform argument holds several poses: an array (or nested lists) of
// three dimensions.
bool manyPoses(py::handle tf) {
  if (tf.is_none() || py::isinstance<py::str>(tf)) return false;
  py::array a = py::array::ensure(tf);
  if (!a) {
    PyErr_Clear();
    return false;
  }
  return a.ndim() == 3;
}

// The single-object query at each of an (n, 4, 4) array's poses: one pass in C++, the query
// object moved from pose to pose under one lock, each answer the single-pose call's.
py::object collideAtPoses(const Manager& m, const GeometryPtr& g, py::handle tfs, const Want& w) {
  if (!w.anyOnly())
    throw py::value_error(
        "in_collision_single: return_names / return_data take one pose (a 4x4 transform), not "
        "an (n, 4, 4) array");
  Array a = floats(tfs, "transforms", {-1, 4, 4}, false);
  const std::size_t n = static_cast<std::size_t>(a.shape(0));
  std::vector<fcl::Transform3d> poses(n);
  transformsFrom(a.data(), n, poses.data(), [&](std::size_t i) {
    return transformFrom(a.data() + 16 * i, "transforms[" + std::to_string(i) + "]");
  });
  std::vector<unsigned char> hit(n, 0);
  if (n > 0) {
    Object q(g->fcl, poses[0]);
    py::gil_scoped_release nogil;
    ReadLocks lock(m, nullptr);
    refuseFclCrashes(&m, nullptr, {g->kind}, false, "in_collision_single");
    const double pad = m.isCube() ? 0.0 : m.managerMargin();
    for (std::size_t i = 0; i < n; ++i) {
      q.setTransform(poses[i]);
      q.refresh(pad);
      hit[i] = collide(m, &q, nullptr, w).any;
    }
  }
  py::array_t<bool> out(static_cast<py::ssize_t>(n));
  std::copy(hit.begin(), hit.end(), out.mutable_data());
  return py::object(std::move(out));
}

}  // namespace

void bindCollideQueries(ManagerClass& cls) {
  cls.def(
         "in_collision_internal",
         [](const Manager& m, bool names, bool data, int max_contacts) {
           const Want w = want(names, data, max_contacts);
           return collideQuery(m, nullptr, w, Kind::internal,
                               [&] { return collide(m, nullptr, nullptr, w); });
         },
         py::arg("return_names") = false, py::arg("return_data") = false,
         py::arg("max_contacts") = 100000, R"doc(
Does any pair of objects collide (filter bits and excluded pairs applied; with margins, or come
closer than margin(a) + margin(b))? As trimesh: returns is_collision, plus (return_names) the set
of colliding pairs as sorted (name, name) tuples, plus (return_data) the contacts as a dict of
arrays: 'names' (n, 2) object, 'points' (n, 3), 'normals' (n, 3) (from the first to the second
name), 'depths' (n,), up to max_contacts per pair (FCL's contacts; a pair within its margins but
apart gets one row: the middle of the nearest points, their direction, depth = -distance).
Names only stop each pair's narrow phase at its first contact; data asks FCL for every contact.)doc")
      .def(
          "in_collision_single",
          [](const Manager& m, py::handle geometry, py::handle tf, bool names, bool data,
             int max_contacts, py::handle mesh) -> py::object {
            const Want w = want(names, data, max_contacts);
            GeometryPtr g = geometryOf(geometryArg(geometry, mesh, "in_collision_single"));
            if (manyPoses(tf)) return collideAtPoses(m, g, tf, w);
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
or neither of geometry and mesh.

With `transform` an (n, 4, 4) array of poses: one call for them all, returning a numpy bool array
of n, entry i the answer of the single-pose call at transforms[i] (the same rules: filter bits,
ignored pairs, margins). Every pose is checked first (ValueError naming the first bad one);
return_names / return_data are refused (ValueError) with several poses.)doc")
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
in_collision_internal. Filter bits apply across the two managers, whichever backend each has;
excluded pairs and margins do not. The same manager as other is in_collision_internal.)doc");
}

}  // namespace cubepy
