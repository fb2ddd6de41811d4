// cube_collision_bench: the benchmark's stand-ins for python-fcl's compiled fcl.collide and
// fcl.distance (Cython there, C++ here), on the handles that CollisionManager._collide_python /
// _distance_python hand to a callback. Built beside the package for python/benchmarks, never
// installed: the package itself answers every query in C++ without them. batch_way.cpp adds the
// library's batched checks timed in C++, for bench_check_states.py.

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "handle.h"

namespace py = pybind11;
using cubepy::Handle;

namespace {

py::array_t<double> vec(const fcl::Vector3d& v) {
  py::array_t<double> a(3);
  for (int k = 0; k < 3; ++k) a.mutable_at(k) = v[k];
  return a;
}

// The object a result names for a handle's side: its Geometry, or what `owners` maps it to (the
// caller's own geometry object, as python-fcl reads it from the FCL object's user data).
py::object owner(const Handle& h, const py::object& owners) {
  if (owners.is_none()) return h.geometry;
  PyObject* o = PyDict_GetItem(owners.ptr(), h.geometry.ptr());
  return o ? py::reinterpret_borrow<py::object>(o) : h.geometry;
}

}  // namespace

namespace cubepy {
void bindBatchWay(py::module_& m);  // batch_way.cpp
}

PYBIND11_MODULE(cube_collision_bench, m) {
  m.doc() = "Benchmark-only stand-ins for python-fcl's fcl.collide / fcl.distance.";
  // Handles are cube_collision._core's type: imported so that pybind11 knows it here.
  py::module_::import("cube_collision._core");
  cubepy::bindBatchWay(m);
  // The request read from the Python request's attributes on every call, a fresh FCL result,
  // and each contact made a Python object (numpy normal and position) appended to the result.
  m.def(
      "fcl_collide",
      [](const Handle& a, const Handle& b, py::object request, py::object result,
         py::object contact_type, py::object owners) {
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
        const py::object oa = owner(a, owners), ob = owner(b, owners);
        for (std::size_t k = 0; k < res.numContacts(); ++k) {
          const auto& ct = res.getContact(k);
          py::object c = contact_type();
          c.attr("o1") = ct.o1 == ga ? oa : ob;
          c.attr("o2") = ct.o2 == ga ? oa : ob;
          c.attr("b1") = ct.b1;
          c.attr("b2") = ct.b2;
          c.attr("normal") = vec(ct.normal);
          c.attr("pos") = vec(ct.pos);
          c.attr("penetration_depth") = ct.penetration_depth;
          contacts.append(c);
        }
        return ret;
      },
      py::arg("o1"), py::arg("o2"), py::arg("request"), py::arg("result"), py::arg("contact_type"),
      py::arg("owners") = py::none(),
      "python-fcl's fcl.collide(o1, o2, request, result) on two handles; owners: None, or a "
      "dict from a handle's geometry to the object the contacts name instead.");
  m.def(
      "fcl_distance",
      [](const Handle& a, const Handle& b, py::object request, py::object result,
         py::object owners) {
        fcl::DistanceRequestd req(request.attr("enable_nearest_points").cast<bool>());
        fcl::DistanceResultd res;
        const double d = fcl::distance(a.obj, b.obj, req, res);
        if (result.attr("min_distance").cast<double>() > res.min_distance) {
          result.attr("min_distance") = res.min_distance;
          py::list pts;
          pts.append(vec(res.nearest_points[0]));
          pts.append(vec(res.nearest_points[1]));
          result.attr("nearest_points") = pts;
          const auto* ga = a.obj->collisionGeometry().get();
          result.attr("o1") = res.o1 == ga ? owner(a, owners) : owner(b, owners);
          result.attr("o2") = res.o2 == ga ? owner(a, owners) : owner(b, owners);
          result.attr("b1") = res.b1;
          result.attr("b2") = res.b2;
        }
        return d;
      },
      py::arg("o1"), py::arg("o2"), py::arg("request"), py::arg("result"),
      py::arg("owners") = py::none(),
      "python-fcl's fcl.distance(o1, o2, request, result) on two handles (owners as "
      "fcl_collide).");
}
