// Batched state and motion checks for planners (cube_collision/batch.h): a Body of links, poses
// in as one (states, links, 4, 4) array, answers out as arrays, on the library's threads with the
// GIL released.

#include <cube_collision/batch.h>
#include <pybind11/stl.h>

#include <cmath>
#include <mutex>

#include "manager.h"

namespace cubepy {

namespace {

/// What the BodySet does not answer of a link: the Python geometry it was made from and its
/// filter bits (pickling). Its margin and the excluded pairs are read from the BodySet.
struct Link {
  GeometryPtr geometry;
  std::uint64_t category, mask;
};

/// The moving bodies: cube::BodySet plus what rebuilds it (pickling).
struct Body {
  cube::BodySet<double> set;
  std::vector<Link> links;

  std::size_t addLink(GeometryPtr g, double margin, std::uint64_t category, std::uint64_t mask) {
    if (g->kind == "plane" || g->kind == "halfspace")
      throw py::value_error("add_link: a link must be bounded (no plane or halfspace)");
    if (!std::isfinite(margin) || margin < 0)
      throw py::value_error("add_link: margin must be finite and >= 0");
    const std::size_t i = set.addLink(g->fcl, margin, category, mask);
    links.push_back({g, category, mask});
    return i;
  }
  std::vector<std::string> kinds() const {
    std::vector<std::string> out;
    for (const auto& l : links) out.push_back(l.geometry->kind);
    return out;
  }
  /// `where`: the Python call named in errors.
  void excludePair(std::size_t i, std::size_t j, const char* where) {
    if (i >= links.size() || j >= links.size() || i == j)
      throw py::value_error(std::string(where) + ": two different link indices below " +
                            std::to_string(links.size()) + " expected");
    set.excludePair(i, j);
  }
  /// The pairs of links never checked, (i, j) with i < j, sorted.
  std::vector<std::pair<std::size_t, std::size_t>> excluded() const {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t i = 0; i < links.size(); ++i)
      for (std::size_t j = i + 1; j < links.size(); ++j)
        if (!set.checked(i, j)) out.emplace_back(i, j);
    return out;
  }
};

// poses (states, links, 4, 4) -> transforms, each checked finite and rigid.
std::vector<fcl::Transform3d> posesOf(py::handle poses, std::size_t links, std::size_t* states) {
  if (links == 0) throw py::value_error("the body has no link");
  Array a = floats(poses, "poses", {-1, static_cast<py::ssize_t>(links), 4, 4}, false);
  *states = static_cast<std::size_t>(a.shape(0));
  std::vector<fcl::Transform3d> out(*states * links);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = transformFrom(a.data() + 16 * i, "poses[" + std::to_string(i / links) + ", " +
                                                  std::to_string(i % links) + "]");
  return out;
}

void needCube(const Manager& m, const char* what) {
  if (!m.isCube())
    throw py::value_error(std::string(what) +
                          " needs backend='cube' (the batched checks walk the "
                          "cube hierarchy)");
}

}  // namespace

void bindManagerBatch(ManagerClass& cls) {
  cls.def(
         "check_states",
         [](const Manager& m, const Body& body, py::handle poses, bool self_collision,
            bool first_pair, bool clearance, py::object threads) {
           needCube(m, "check_states");
           std::size_t states = 0;
           auto tfs = posesOf(poses, body.links.size(), &states);
           cube::BatchOptions opt;
           opt.self_collision = self_collision;
           opt.first_pair = first_pair;
           opt.clearance = clearance;
           opt.threads = threads.is_none() ? m.threads() : threads.cast<int>();
           std::vector<cube::StateResult<double>> res;
           std::vector<std::string> objects;
           {
             py::gil_scoped_release nogil;
             std::shared_lock lock(m.mutex);
             refuseFclCrashes(&m, nullptr, body.kinds(), false, "check_states");
             res = cube::checkStates(*m.cube(), body.set, tfs, opt);
             objects.resize(res.size());
             for (std::size_t i = 0; i < res.size(); ++i)
               if (res[i].object) objects[i] = Manager::entryOf(res[i].object)->name;
           }
           const auto n = static_cast<py::ssize_t>(res.size());
           py::array_t<bool> colliding(n);
           py::array_t<std::int64_t> link(n), other_link(n);
           py::array_t<double> clear(n);
           py::list names;
           for (py::ssize_t i = 0; i < n; ++i) {
             const auto& r = res[i];
             colliding.mutable_at(i) = r.colliding;
             link.mutable_at(i) = r.link == cube::kNoIndex ? -1 : static_cast<std::int64_t>(r.link);
             other_link.mutable_at(i) =
                 r.other_link == cube::kNoIndex ? -1 : static_cast<std::int64_t>(r.other_link);
             clear.mutable_at(i) =
                 r.clearance >= std::numeric_limits<double>::max() ? INFINITY : r.clearance;
             names.append(r.object ? py::object(py::str(objects[i])) : py::none());
           }
           py::dict d;
           d["colliding"] = colliding;
           d["link"] = link;
           d["object"] =
               py::module_::import("numpy").attr("array")(names, py::arg("dtype") = "object");
           d["other_link"] = other_link;
           d["clearance"] = clear;
           return d;
         },
         py::arg("body"), py::arg("poses"), py::kw_only(), py::arg("self_collision") = false,
         py::arg("first_pair") = false, py::arg("clearance") = false,
         py::arg("threads") = py::none(), R"doc(
Checks many states of `body` against this manager's objects in one call (cube backend; the
objects are the static world). poses: (states, links, 4, 4), link l's world pose in state k.
Returns a dict of arrays over the states: 'colliding' (bool), and with first_pair the first
colliding pair: 'link' (int64, -1 if none), 'object' (the world object's name or None) or
'other_link' (-1 if none); 'clearance' (float64: with clearance, a free state's smallest
fcl::distance, 0 if colliding; inf otherwise). self_collision: also links against links (pairs
excluded by Body.exclude_pair). Filter bits, excluded pairs and margins of the world apply (as
the library's checkStates). threads: None = the manager's; answers do not depend on it. Raises
ValueError (wrong shape, a pose not finite or rigid, a body without links, backend='fcl'),
TypeError (non-numeric poses).)doc")
      .def(
          "check_motions",
          [](const Manager& m, const Body& body, py::handle poses, py::handle edge_starts,
             const std::string& order, bool self_collision, py::object threads) {
            needCube(m, "check_motions");
            std::size_t states = 0;
            auto tfs = posesOf(poses, body.links.size(), &states);
            IndexArray starts = indices(edge_starts, "edge_starts", {-1});
            std::vector<std::size_t> s;
            for (py::ssize_t i = 0; i < starts.size(); ++i) {
              const auto v = starts.at(i);
              if (v < 0 || static_cast<std::size_t>(v) >= states || (i == 0 && v != 0) ||
                  (i > 0 && v <= starts.at(i - 1)))
                throw py::value_error(
                    "edge_starts must start at 0 and increase strictly within "
                    "the states");
              s.push_back(static_cast<std::size_t>(v));
            }
            cube::MotionOrder mo;
            if (order == "path")
              mo = cube::MotionOrder::path;
            else if (order == "bisection")
              mo = cube::MotionOrder::bisection;
            else
              throw py::value_error("order must be 'path' or 'bisection'");
            cube::BatchOptions opt;
            opt.self_collision = self_collision;
            opt.threads = threads.is_none() ? m.threads() : threads.cast<int>();
            std::vector<std::size_t> res;
            {
              py::gil_scoped_release nogil;
              std::shared_lock lock(m.mutex);
              refuseFclCrashes(&m, nullptr, body.kinds(), false, "check_motions");
              if (!s.empty()) res = cube::checkMotions(*m.cube(), body.set, tfs, s, mo, opt);
            }
            py::array_t<std::int64_t> out(static_cast<py::ssize_t>(res.size()));
            for (std::size_t i = 0; i < res.size(); ++i)
              out.mutable_at(i) = res[i] == cube::kNoIndex ? -1 : static_cast<std::int64_t>(res[i]);
            return out;
          },
          py::arg("body"), py::arg("poses"), py::arg("edge_starts"), py::kw_only(),
          py::arg("order") = "path", py::arg("self_collision") = false,
          py::arg("threads") = py::none(), R"doc(
Checks edges (motions): edge e is states edge_starts[e] .. edge_starts[e + 1] - 1 of poses
(states, links, 4, 4). Returns (edges,) int64: the index within the edge of its first colliding
state in `order` ('path': 0, 1, 2...; 'bisection': OMPL's DiscreteMotionValidator order), -1 if
the edge is free. ValueError for edge_starts not starting at 0 or not increasing, or as
check_states.)doc");
}

void bindBatch(py::module_& m) {
  py::class_<Body, std::shared_ptr<Body>>(m, "Body", R"doc(
The moving bodies of check_states / check_motions: a robot's links (or any objects that move
together), built once. Pickles. Not changed by the checks: several threads may check with one
Body at once; add links from one thread.)doc")
      .def(py::init<>(), "An empty body.")
      .def(
          "add_link",
          [](Body& b, py::handle geometry, double margin, std::uint64_t category,
             std::uint64_t mask) {
            return b.addLink(geometryOf(geometry), margin, category, mask);
          },
          py::arg("geometry"), py::kw_only(), py::arg("margin") = 0.0, py::arg("category") = 1,
          py::arg("mask") = ~std::uint64_t(0), R"doc(
Adds a link and returns its index (0, 1, ...). margin: it touches what lies within margin + the
world object's margin. category / mask: filter bits against the world's objects. ValueError for
a plane or a negative or non-finite margin; TypeError for something not a geometry.)doc")
      .def(
          "exclude_pair",
          [](Body& b, std::size_t i, std::size_t j) { b.excludePair(i, j, "exclude_pair"); },
          py::arg("i"), py::arg("j"),
          "Links i and j are never checked against each other (adjacent links). ValueError for "
          "an unknown index or i == j.")
      .def(
          "allow_pair",
          [](Body& b, std::size_t i, std::size_t j) { b.excludePair(i, j, "allow_pair"); },
          py::arg("i"), py::arg("j"), "Alias of exclude_pair (the former name).")
      .def("__len__", [](const Body& b) { return b.links.size(); })
      .def_property_readonly(
          "excluded_pairs", [](const Body& b) { return b.excluded(); },
          "The excluded pairs, as (i, j) with i < j, sorted.")
      .def_property_readonly(
          "allowed_pairs", [](const Body& b) { return b.excluded(); },
          "Alias of excluded_pairs (the former name).")
      .def(py::pickle(
          [](const Body& b) {
            py::list links;
            for (std::size_t i = 0; i < b.links.size(); ++i) {
              const Link& l = b.links[i];
              links.append(py::make_tuple(l.geometry, b.set.margin(i), l.category, l.mask));
            }
            return py::make_tuple(links, b.excluded());
          },
          [](py::tuple t) {
            auto b = std::make_shared<Body>();
            for (py::handle h : t[0].cast<py::list>()) {
              auto l = h.cast<py::tuple>();
              b->addLink(geometryOf(l[0]), l[1].cast<double>(), l[2].cast<std::uint64_t>(),
                         l[3].cast<std::uint64_t>());
            }
            for (const auto& [i, j] : t[1].cast<std::vector<std::pair<std::size_t, std::size_t>>>())
              b->excludePair(i, j, "unpickling");
            return b;
          }));
}

}  // namespace cubepy
