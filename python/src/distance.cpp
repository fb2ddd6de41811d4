// The distance queries (trimesh's min_distance_internal / single / other), on either backend
// through the library's minimumDistance over the manager's broadphase (the cube manager, or
// FCL's tree under the same rules: fcl_backend.h).

#include <cube_collision/queries.h>
#include <pybind11/stl.h>

#include <optional>

#include "query_common.h"

namespace cubepy {

namespace {

// Names the objects of a pipeline's result, whose o1 / o2 name geometries: each FCL geometry
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

// The smallest distance from one object of m to the others: a distance query with the object
// itself, which neither backend pairs with itself (the rules of both applied by the walk).
DistOut distanceFrom(const Manager& m, const Entry& e, bool points) {
  cube::NarrowPhaseOptions<double> opt;
  opt.threads = m.threads();
  const fcl::DistanceResultd r =
      cube::minimumDistance(m.broadphase(), e.obj.get(), fcl::DistanceRequestd(points), opt);
  DistOut out = nameResult(r, m, e.obj->collisionGeometry().get(), nullptr);
  if (out.found) out.b = e.name;  // nameResult names the query object as trimesh's external
  return out;
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

}  // namespace

DistOut distance(const Manager& m, ObjPtr query, const Manager* other, bool points) {
  if (other && m.isCube() && !other->isCube()) {
    // FCL's tree asks the bits of both sides: it leads, the answer comes back as (here, there).
    DistOut o = distance(*other, nullptr, &m, points);
    std::swap(o.a, o.b);
    std::swap(o.pa, o.pb);
    std::swap(o.ba, o.bb);
    return o;
  }
  const fcl::DistanceRequestd request(points);
  cube::NarrowPhaseOptions<double> opt;
  opt.threads = m.threads();
  const auto& bp = m.broadphase();
  const fcl::DistanceResultd r = query ? cube::minimumDistance(bp, query, request, opt)
                                 : other
                                     ? cube::minimumDistance(bp, other->broadphase(), request, opt)
                                     : cube::minimumDistance(bp, request, opt);
  return nameResult(r, m, query ? query->collisionGeometry().get() : nullptr, other);
}

void bindDistanceQueries(ManagerClass& cls) {
  cls.def(
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
crashes, gets its exact distance in closed form instead, -1 when they meet; a distance query
with a plane and an 'fcl'-backend manager is refused (ValueError). Filter bits and excluded pairs apply, margins
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
data dict, as min_distance_internal.)doc");
}

}  // namespace cubepy
