#include <cmath>
#include <sstream>

#include "common.h"

namespace cubepy {

namespace {

std::string shapeText(const std::vector<py::ssize_t>& shape) {
  std::ostringstream s;
  s << "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i) s << ", ";
    if (shape[i] < 0)
      s << "N";
    else
      s << shape[i];
  }
  if (shape.size() == 1) s << ",";
  s << ")";
  return s.str();
}

std::string shapeText(const py::array& a) {
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  return shapeText(shape);
}

py::array asNumeric(py::handle obj, const char* what, bool integers_only) {
  py::array a = py::module_::import("numpy").attr("asarray")(obj);
  const char kind = a.dtype().kind();
  const bool ok =
      integers_only ? (kind == 'i' || kind == 'u') : (kind == 'i' || kind == 'u' || kind == 'f');
  if (!ok)
    throw py::type_error(std::string(what) + ": expected " +
                         (integers_only ? "an integer" : "a real (integer or float)") +
                         " array, got dtype " + py::str(a.dtype()).cast<std::string>());
  return a;
}

void checkShape(const py::array& a, const char* what, const std::vector<py::ssize_t>& shape) {
  bool ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
  for (std::size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || a.shape(i) == shape[i];
  if (!ok)
    throw py::value_error(std::string(what) + ": expected shape " + shapeText(shape) + ", got " +
                          shapeText(a));
}

}  // namespace

Array floats(py::handle obj, const char* what, std::vector<py::ssize_t> shape, bool finite) {
  py::array a = asNumeric(obj, what, false);
  checkShape(a, what, shape);
  Array out = Array::ensure(a);
  if (!out) throw py::type_error(std::string(what) + ": cannot be read as float64");
  if (finite) {
    const double* d = out.data();
    for (py::ssize_t i = 0; i < out.size(); ++i)
      if (!std::isfinite(d[i]))
        throw py::value_error(std::string(what) + ": entry " + std::to_string(i) +
                              " is not finite (" + std::to_string(d[i]) + ")");
  }
  return out;
}

IndexArray indices(py::handle obj, const char* what, std::vector<py::ssize_t> shape) {
  py::array a = asNumeric(obj, what, true);
  checkShape(a, what, shape);
  IndexArray out = IndexArray::ensure(a);
  if (!out) throw py::type_error(std::string(what) + ": cannot be read as int64");
  return out;
}

fcl::Transform3d transformFrom(const double* m, const std::string& what) {
  for (int i = 0; i < 16; ++i)
    if (!std::isfinite(m[i])) throw py::value_error(what + ": entries must be finite");
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
    throw py::value_error(what + ": the last row must be (0, 0, 0, 1)");
  fcl::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m[i * 4 + j];
  const double err = (r.transpose() * r - fcl::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6 || r.determinant() < 0)
    throw py::value_error(what +
                          ": not a rigid transform (the 3x3 rotation must be orthonormal with "
                          "determinant +1, within 1e-6: no scaling, shearing or mirroring)");
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = r;
  tf.translation() = fcl::Vector3d(m[3], m[7], m[11]);
  return tf;
}

fcl::Transform3d transform(py::handle obj, const char* what) {
  if (obj.is_none()) return fcl::Transform3d::Identity();
  Array a = floats(obj, what, {4, 4}, false);
  return transformFrom(a.data(), what);
}

py::array_t<double> toArray(const fcl::Transform3d& tf) {
  py::array_t<double> out({4, 4});
  auto o = out.mutable_unchecked<2>();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) o(i, j) = tf.matrix()(i, j);
  return out;
}

py::array_t<double> toArray(const fcl::Vector3d& v) {
  py::array_t<double> out(3);
  auto o = out.mutable_unchecked<1>();
  for (int i = 0; i < 3; ++i) o(i) = v[i];
  return out;
}

}  // namespace cubepy
