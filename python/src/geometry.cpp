// Geometry from arrays: meshes (FCL's OBBRSS BVH), convex hulls and FCL's primitives.

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>
#include <pybind11/stl.h>

#include <cmath>

#include "common.h"

namespace cubepy {

namespace {

using Mesh = fcl::BVHModel<fcl::OBBRSSd>;

void positive(double v, const char* what) {
  if (!std::isfinite(v) || v <= 0)
    throw py::value_error(std::string(what) + " must be finite and > 0, got " + std::to_string(v));
}

void checkArrays(const std::string& kind, const std::vector<double>& vertices,
                 const std::vector<std::int64_t>& faces) {
  const std::size_t n = vertices.size() / 3, m = faces.size() / 3;
  if (n < 3 || m < 1)
    throw py::value_error(kind + ": empty mesh (needs at least 3 vertices and 1 face, got " +
                          std::to_string(n) + " and " + std::to_string(m) + ")");
  for (double v : vertices)
    if (!std::isfinite(v)) throw py::value_error(kind + ": vertices must be finite");
  for (std::size_t i = 0; i < faces.size(); ++i)
    if (faces[i] < 0 || faces[i] >= static_cast<std::int64_t>(n))
      throw py::value_error(kind + ": face " + std::to_string(i / 3) + " indexes vertex " +
                            std::to_string(faces[i]) + ", past the " + std::to_string(n) +
                            " vertices");
}

std::vector<fcl::Vector3d> points(const std::vector<double>& v) {
  std::vector<fcl::Vector3d> out(v.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
  return out;
}

std::shared_ptr<fcl::CollisionGeometryd> buildFcl(const Geometry& g) {
  const auto& p = g.params;
  std::shared_ptr<fcl::CollisionGeometryd> out;
  if (g.kind == "mesh") {
    auto mesh = std::make_shared<Mesh>();
    std::vector<fcl::Triangle> tris(g.faces.size() / 3);
    for (std::size_t i = 0; i < tris.size(); ++i)
      tris[i] = fcl::Triangle(g.faces[3 * i], g.faces[3 * i + 1], g.faces[3 * i + 2]);
    mesh->beginModel(static_cast<int>(tris.size()), static_cast<int>(g.vertices.size() / 3));
    mesh->addSubModel(points(g.vertices), tris);
    mesh->endModel();
    out = mesh;
  } else if (g.kind == "convex") {
    auto verts = std::make_shared<std::vector<fcl::Vector3d>>(points(g.vertices));
    auto faces = std::make_shared<std::vector<int>>();
    for (std::size_t i = 0; i < g.faces.size(); i += 3) {
      faces->push_back(3);
      for (int k = 0; k < 3; ++k) faces->push_back(static_cast<int>(g.faces[i + k]));
    }
    out = std::make_shared<fcl::Convexd>(verts, static_cast<int>(g.faces.size() / 3), faces);
  } else if (g.kind == "box") {
    out = std::make_shared<fcl::Boxd>(p[0], p[1], p[2]);
  } else if (g.kind == "sphere") {
    out = std::make_shared<fcl::Sphered>(p[0]);
  } else if (g.kind == "cylinder") {
    out = std::make_shared<fcl::Cylinderd>(p[0], p[1]);
  } else if (g.kind == "capsule") {
    out = std::make_shared<fcl::Capsuled>(p[0], p[1]);
  } else if (g.kind == "cone") {
    out = std::make_shared<fcl::Coned>(p[0], p[1]);
  } else if (g.kind == "ellipsoid") {
    out = std::make_shared<fcl::Ellipsoidd>(p[0], p[1], p[2]);
  } else if (g.kind == "plane") {
    out = std::make_shared<fcl::Planed>(fcl::Vector3d(p[0], p[1], p[2]), p[3]);
  } else if (g.kind == "halfspace") {
    out = std::make_shared<fcl::Halfspaced>(fcl::Vector3d(p[0], p[1], p[2]), p[3]);
  } else {
    throw py::value_error("unknown geometry kind '" + g.kind + "'");
  }
  out->computeLocalAABB();
  return out;
}

std::vector<double> flat(const Array& a) {
  return {a.data(), a.data() + a.size()};
}

GeometryPtr fromArrays(const std::string& kind, py::handle vertices, py::handle faces) {
  Array v = floats(vertices, (kind + " vertices").c_str(), {-1, 3});
  IndexArray f = indices(faces, (kind + " faces").c_str(), {-1, 3});
  return makeGeometry(kind, {}, flat(v), {f.data(), f.data() + f.size()});
}

py::array_t<double> verticesArray(const Geometry& g) {
  py::array_t<double> out({static_cast<py::ssize_t>(g.vertices.size() / 3), py::ssize_t(3)});
  std::copy(g.vertices.begin(), g.vertices.end(), out.mutable_data());
  return out;
}

py::array_t<std::int64_t> facesArray(const Geometry& g) {
  py::array_t<std::int64_t> out({static_cast<py::ssize_t>(g.faces.size() / 3), py::ssize_t(3)});
  std::copy(g.faces.begin(), g.faces.end(), out.mutable_data());
  return out;
}

}  // namespace

GeometryPtr makeGeometry(const std::string& kind, std::vector<double> params,
                         std::vector<double> vertices, std::vector<std::int64_t> faces) {
  auto g = std::make_shared<Geometry>();
  g->kind = kind;
  if (kind == "mesh" || kind == "convex") {
    if (vertices.size() % 3 || faces.size() % 3)
      throw py::value_error(kind + ": vertices and faces must have 3 columns");
    checkArrays(kind, vertices, faces);
  } else if (kind == "box") {
    if (params.size() != 3) throw py::value_error("box: 3 extents expected");
    for (double e : params) positive(e, "box extents");
  } else if (kind == "ellipsoid") {
    if (params.size() != 3) throw py::value_error("ellipsoid: 3 radii expected");
    for (double e : params) positive(e, "ellipsoid radii");
  } else if (kind == "sphere") {
    if (params.size() != 1) throw py::value_error("sphere: a radius expected");
    positive(params[0], "sphere radius");
  } else if (kind == "cylinder" || kind == "capsule" || kind == "cone") {
    if (params.size() != 2) throw py::value_error(kind + ": radius and height expected");
    positive(params[0], (kind + " radius").c_str());
    positive(params[1], (kind + " height").c_str());
  } else if (kind == "plane" || kind == "halfspace") {
    if (params.size() != 4) throw py::value_error(kind + ": normal (3) and offset expected");
    for (double e : params)
      if (!std::isfinite(e)) throw py::value_error(kind + ": normal and offset must be finite");
    const double len =
        std::sqrt(params[0] * params[0] + params[1] * params[1] + params[2] * params[2]);
    if (!(len > 1e-12)) throw py::value_error(kind + ": the normal must not be zero");
    for (int i = 0; i < 3; ++i) params[i] /= len;
    params[3] /= len;
  } else {
    throw py::value_error("unknown geometry kind '" + kind + "'");
  }
  g->params = std::move(params);
  g->vertices = std::move(vertices);
  g->faces = std::move(faces);
  g->fcl = buildFcl(*g);
  return g;
}

std::shared_ptr<fcl::CollisionGeometryd> cloneFcl(const Geometry& g) {
  if (g.kind == "mesh") return std::make_shared<Mesh>(static_cast<const Mesh&>(*g.fcl));
  if (g.kind == "convex") {
    auto c = std::make_shared<fcl::Convexd>(static_cast<const fcl::Convexd&>(*g.fcl));
    c->computeLocalAABB();
    return c;
  }
  return buildFcl(g);  // a primitive costs less to build than to look up
}

GeometryPtr geometryOf(py::handle obj) {
  if (py::isinstance<Geometry>(obj)) return obj.cast<GeometryPtr>();
  if (py::hasattr(obj, "vertices") && py::hasattr(obj, "faces")) {
    // As trimesh's collision module: a mesh whose is_convex is true becomes FCL's Convex (a
    // solid), any other a BVH (a surface).
    const bool convex = py::hasattr(obj, "is_convex") && py::bool_(obj.attr("is_convex"));
    return fromArrays(convex ? "convex" : "mesh", obj.attr("vertices"), obj.attr("faces"));
  }
  throw py::type_error(
      "expected a cube_collision Geometry or an object with vertices and faces "
      "(a trimesh.Trimesh), got " +
      py::str(py::type::of(obj)).cast<std::string>());
}

void bindGeometry(py::module_& m) {
  py::class_<Geometry, GeometryPtr> geom(m, "Geometry", R"doc(
A collision shape in its own frame, built once and shared by every object that uses it. Made by
the functions mesh, convex, box, sphere, cylinder, capsule, cone and plane; immutable; pickles
(rebuilt from its kind and arrays). Thread-safe: it is only read after construction.)doc");
  geom.def_property_readonly(
          "kind", [](const Geometry& g) { return g.kind; },
          "'mesh', 'convex', 'box', 'sphere', 'cylinder', 'capsule', 'cone' or 'plane'.")
      .def_property_readonly(
          "params", [](const Geometry& g) { return g.params; },
          "The sizes: box (x, y, z extents), sphere (radius,), cylinder / capsule / cone (radius, "
          "height), plane (nx, ny, nz, offset) with a unit normal; empty for mesh and convex.")
      .def_property_readonly("vertices", &verticesArray,
                             "Vertices (n, 3) float64 of a mesh or convex; (0, 3) otherwise.")
      .def_property_readonly("faces", &facesArray,
                             "Triangles (m, 3) int64 of a mesh or convex; (0, 3) otherwise.")
      .def_property_readonly(
          "aabb",
          [](const Geometry& g) {
            py::array_t<double> out({2, 3});
            auto o = out.mutable_unchecked<2>();
            for (int i = 0; i < 3; ++i) {
              o(0, i) = g.fcl->aabb_local.min_[i];
              o(1, i) = g.fcl->aabb_local.max_[i];
            }
            return out;
          },
          "The local axis-aligned bounds, [[min x, y, z], [max x, y, z]] (FCL's local AABB).")
      .def("__repr__",
           [](const Geometry& g) {
             std::string s = "cube_collision." + g.kind + "(";
             if (g.kind == "mesh" || g.kind == "convex")
               s += std::to_string(g.vertices.size() / 3) + " vertices, " +
                    std::to_string(g.faces.size() / 3) + " faces";
             for (std::size_t i = 0; i < g.params.size(); ++i)
               s += (i ? ", " : "") + std::to_string(g.params[i]);
             return s + ")";
           })
      .def(py::pickle(
          [](const Geometry& g) {
            return py::make_tuple(g.kind, g.params, verticesArray(g), facesArray(g));
          },
          [](py::tuple t) {
            if (t.size() != 4) throw py::value_error("bad Geometry state");
            Array v = floats(t[2], "vertices", {-1, 3});
            IndexArray f = indices(t[3], "faces", {-1, 3});
            return makeGeometry(t[0].cast<std::string>(), t[1].cast<std::vector<double>>(), flat(v),
                                {f.data(), f.data() + f.size()});
          }));

  m.def(
      "mesh", [](py::handle v, py::handle f) { return fromArrays("mesh", v, f); },
      py::arg("vertices"), py::arg("faces"), R"doc(
A triangle mesh as FCL's BVH of oriented boxes (OBBRSS), the geometry trimesh hands python-fcl.

vertices: (n, 3) real array, finite. faces: (m, 3) integer array indexing vertices. A surface:
it collides where its triangles meet the other shape (a shape wholly inside a closed mesh does
not touch it). A trimesh.Trimesh given to the manager is made a mesh unless its is_convex is
true: then, as trimesh does, a convex() (a solid). Raises TypeError for a non-numeric array or
float faces, ValueError for a wrong shape, a NaN or infinite vertex, a face index past the
vertices or negative, an empty mesh (fewer than 3 vertices or no face).)doc");
  m.def(
      "convex", [](py::handle v, py::handle f) { return fromArrays("convex", v, f); },
      py::arg("vertices"), py::arg("faces"), R"doc(
A convex polyhedron (FCL's Convex), tested as a solid by GJK: for convex hulls, e.g. trimesh's
mesh.convex_hull.vertices / .faces. The vertices must be those of a convex shape (they are not
hulled here; a non-convex set is treated as its hull by the support function but its faces are
then wrong). Same checks and errors as mesh().)doc");
  m.def(
      "box",
      [](double x, double y, double z) {
        return makeGeometry("box", {x, y, z}, {}, {});
      },
      py::arg("x"), py::arg("y"), py::arg("z"),
      "A box with these full side lengths, centred on the origin. ValueError unless each is "
      "finite and > 0.");
  m.def(
      "sphere", [](double r) { return makeGeometry("sphere", {r}, {}, {}); }, py::arg("radius"),
      "A sphere centred on the origin. ValueError unless the radius is finite and > 0.");
  m.def(
      "ellipsoid",
      [](double a, double b, double c) {
        return makeGeometry("ellipsoid", {a, b, c}, {}, {});
      },
      py::arg("a"), py::arg("b"), py::arg("c"),
      "An ellipsoid centred on the origin with these radii along x, y and z (FCL's Ellipsoid, a "
      "solid). ValueError unless each is finite and > 0.");
  m.def(
      "cylinder",
      [](double r, double h) {
        return makeGeometry("cylinder", {r, h}, {}, {});
      },
      py::arg("radius"), py::arg("height"),
      "A cylinder along z from -height/2 to height/2. ValueError unless both are finite and > 0.");
  m.def(
      "capsule",
      [](double r, double h) {
        return makeGeometry("capsule", {r, h}, {}, {});
      },
      py::arg("radius"), py::arg("height"),
      "A capsule: the segment from z = -height/2 to height/2 grown by radius. ValueError unless "
      "both are finite and > 0.");
  m.def(
      "cone",
      [](double r, double h) {
        return makeGeometry("cone", {r, h}, {}, {});
      },
      py::arg("radius"), py::arg("height"),
      "A cone along z, base of this radius at -height/2, apex at height/2. ValueError unless both "
      "are finite and > 0.");
  m.def(
      "plane",
      [](py::handle normal, double offset) {
        Array n = floats(normal, "plane normal", {3});
        return makeGeometry("plane", {n.at(0), n.at(1), n.at(2), offset}, {}, {});
      },
      py::arg("normal"), py::arg("offset") = 0.0,
      "The infinite plane n . x = offset (a surface, FCL's Plane); the normal is normalised. "
      "ValueError for a zero or non-finite normal or offset. Unbounded: keep planes out of the "
      "FCL backend, whose tree needs bounded boxes.");
  m.def(
      "halfspace",
      [](py::handle normal, double offset) {
        Array n = floats(normal, "halfspace normal", {3});
        return makeGeometry("halfspace", {n.at(0), n.at(1), n.at(2), offset}, {}, {});
      },
      py::arg("normal"), py::arg("offset") = 0.0,
      "The solid half-space n . x <= offset (FCL's Halfspace); the normal is normalised. "
      "ValueError for a zero or non-finite normal or offset. Unbounded, and refused where a "
      "plane is (the FCL backend, links, distances on the FCL backend, a convex in the same "
      "query).");
}

}  // namespace cubepy
