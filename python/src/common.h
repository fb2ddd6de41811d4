#pragma once

// Shared by the binding's files: numpy conversion with the checks every call makes (dtype, shape,
// finite values, rigid transforms), and the geometry held by Python objects.

#include <fcl/geometry/collision_geometry.h>
#include <fcl/math/constants.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/kernels/rigid_rows.h"

namespace cubepy {

namespace py = pybind11;

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

/// `obj` as a C-contiguous float64 array. TypeError if it is not numeric (strings, objects,
/// booleans, complex); ValueError if its shape is not `shape` (-1: any length on that axis), or,
/// with `finite`, if an entry is NaN or infinite. `what` names the argument in the message.
Array floats(py::handle obj, const char* what, std::vector<py::ssize_t> shape, bool finite = true);

/// `obj` as int64 (integer dtypes only: TypeError for floats), of the given shape.
IndexArray indices(py::handle obj, const char* what, std::vector<py::ssize_t> shape);

/// A 4x4 homogeneous rigid transform: finite, last row (0, 0, 0, 1), rotation orthonormal with
/// determinant +1 within 1e-6. None gives the identity. TypeError / ValueError as floats().
fcl::Transform3d transform(py::handle obj, const char* what = "transform");
/// The same check on 16 doubles (row-major); throws ValueError naming `what`.
fcl::Transform3d transformFrom(const double* m, const std::string& what);
/// The transforms of n row-major 4x4 matrices m[16 i .. 16 i + 15] into out[0 .. n-1]: each one
/// that passes transformFrom's checks with a margin rounding cannot close is copied at once;
/// out[i] = fallback(i) for any other (which throws transformFrom's error, or writes what the
/// caller wants in its place), then the rest continue.
template <class Fallback>
void transformsFrom(const double* m, std::size_t n, fcl::Transform3d* out, Fallback&& fallback) {
  static_assert(sizeof(fcl::Transform3d) == 16 * sizeof(double),
                "consecutive transforms are consecutive column-major matrices");
  if (n == 0) return;
  for (std::size_t done = 0;; ++done) {
    done += cube::detail::rigidRows(m + 16 * done, n - done, out[done].matrix().data());
    if (done >= n) return;
    out[done] = fallback(done);
  }
}
/// A transform as a new 4x4 float64 array.
py::array_t<double> toArray(const fcl::Transform3d& tf);
/// A 3-vector as a new float64 array.
py::array_t<double> toArray(const fcl::Vector3d& v);

/// The geometry behind a Python Geometry: FCL's object and what rebuilds it (pickling).
struct Geometry {
  std::string kind;  ///< mesh, convex, box, sphere, ellipsoid, cylinder, capsule, cone, plane
  std::vector<double> params;    ///< sizes (box: 3 extents; ellipsoid: 3 radii; plane: n, offset)
  std::vector<double> vertices;  ///< mesh and convex: n x 3
  std::vector<std::int64_t> faces;               ///< mesh and convex: m x 3
  std::shared_ptr<fcl::CollisionGeometryd> fcl;  ///< built once, shared by the objects using it
};
using GeometryPtr = std::shared_ptr<Geometry>;

/// Builds FCL's geometry for a kind and its arrays (checked: ValueError on bad sizes).
GeometryPtr makeGeometry(const std::string& kind, std::vector<double> params,
                         std::vector<double> vertices, std::vector<std::int64_t> faces);
/// A copy of g's FCL geometry (a new object: one name per geometry pointer within a manager).
std::shared_ptr<fcl::CollisionGeometryd> cloneFcl(const Geometry& g);
/// A Geometry from a Python object: a Geometry, or anything with `vertices` and `faces`
/// (trimesh.Trimesh), made into a convex if its `is_convex` is true (as trimesh does), else a
/// mesh. TypeError otherwise.
GeometryPtr geometryOf(py::handle obj);

void bindGeometry(py::module_& m);
void bindManager(py::module_& m);
void bindBatch(py::module_& m);

}  // namespace cubepy
