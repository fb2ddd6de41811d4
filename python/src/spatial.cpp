// Rays and regions (spatial_queries.h): the cube manager's own queries; FCL's tree, which has
// none, loops over its objects with the library's per-object ray test (raycastObject) and the
// same box tests on the boxes its backend grew by the margins.

#include <cube_collision/spatial_queries.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/narrowphase/collision.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>

#include "query_common.h"

namespace cubepy {

namespace {

// A query's filter bits (None: every object), as cube::QueryFilter; the FCL backend tests them
// against each object's bits as the broadphase keeps them.
using Bits = std::optional<std::pair<std::uint64_t, std::uint64_t>>;

std::optional<cube::QueryFilter> queryFilter(const Bits& bits) {
  if (!bits) return std::nullopt;
  return cube::QueryFilter{bits->first, bits->second};
}

bool lets(const Manager& m, const Entry& e, const Bits& bits) {
  if (!bits) return true;
  const auto [category, mask] = m.filterOf(e);
  return (category & bits->second) != 0 && (bits->first & mask) != 0;
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
    if (!lets(m, *e, bits)) continue;
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
    if (!lets(m, *e, bits)) continue;
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

// objectsInCapsule; FCL's tree puts every object the filter lets through to fcl::collide with
// the capsule the contract places.
std::vector<std::string> capsule(const Manager& m, const fcl::Vector3d& a, const fcl::Vector3d& b,
                                 double radius, const Bits& bits) {
  std::vector<std::string> out;
  if (m.isCube()) {
    for (auto* o : cube::objectsInCapsule(*m.cube(), a, b, radius, queryFilter(bits)))
      out.push_back(nameOf(o));
    return out;
  }
  const fcl::Vector3d d = b - a;
  const double length = d.norm();
  fcl::Matrix3d rot = fcl::Matrix3d::Identity();
  if (length != 0)
    rot = Eigen::Quaterniond::FromTwoVectors(fcl::Vector3d::UnitZ(), d).toRotationMatrix();
  const fcl::CollisionObjectd cap(std::make_shared<fcl::Capsuled>(radius, length), rot,
                                  fcl::Vector3d(a + d / 2));
  for (const Entry* e : m.ordered()) {
    if (!lets(m, *e, bits) || e->obj->collisionGeometry() == nullptr) continue;
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    if (fcl::collide(&cap, e->obj.get(), request, result) > 0) out.push_back(e->name);
  }
  return out;
}

fcl::Vector3d vec3(const double* d) {
  return {d[0], d[1], d[2]};
}

}  // namespace

void bindSpatialQueries(ManagerClass& cls) {
  cls.def(
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
          "objects_in_capsule",
          [](const Manager& m, py::handle a, py::handle b, double radius, const Bits& bits) {
            Array pa = floats(a, "a", {3});
            Array pb = floats(b, "b", {3});
            const fcl::Vector3d va = vec3(pa.data()), vb = vec3(pb.data());
            const double extent = (vb - va).norm() + 2 * radius;
            if (!(radius >= 0) || !std::isfinite(radius) || !std::isfinite(extent * extent))
              throw py::value_error(
                  "objects_in_capsule: radius must be finite and >= 0, the capsule not too long");
            py::gil_scoped_release nogil;
            ReadLocks lock(m);
            return capsule(m, va, vb, radius, bits);
          },
          py::arg("a"), py::arg("b"), py::arg("radius"), py::kw_only(),
          py::arg("filter") = py::none(), R"doc(
The names of the objects that the capsule of `radius` about the segment from a (3,) to b (3,)
touches, as FCL's narrow phase says (a segment of length 0: a ball), in the order added.
filter: as objects_in_box's. ValueError for a non-finite point, a negative, NaN or infinite
radius, or a capsule whose extent squared overflows.)doc");
}

}  // namespace cubepy
