// Batched state and motion checks for planners (cube_collision/batch.h): a Body of links, poses
// in as one (states, links, 4, 4) array, answers out as arrays, on the library's threads with the
// GIL released.

#include "batch.h"

#include <cube_collision/batch.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

#include "manager.h"

namespace cubepy {

namespace {

// poses (states, links, 4, 4) as float64, its state count into *states.
Array posesArray(py::handle poses, std::size_t links, std::size_t* states) {
  if (links == 0) throw py::value_error("the body has no link");
  Array a = floats(poses, "poses", {-1, static_cast<py::ssize_t>(links), 4, 4}, false);
  *states = static_cast<std::size_t>(a.shape(0));
  return a;
}

// The name transformFrom's error gives pose `at` of the array.
std::string poseName(std::size_t at, std::size_t links) {
  return "poses[" + std::to_string(at / links) + ", " + std::to_string(at % links) + "]";
}

// Writes state k's links' transforms from the (states, links, 4, 4) array, each checked finite
// and rigid (transformFrom's checks): the library calls it for the states it reads, on its
// checking threads, so that the array is neither converted whole first nor on one thread.
struct PoseReader {
  const double* data;
  std::size_t links;
  /// Throws transformFrom's ValueError for a pose that fails its checks.
  void operator()(std::size_t state, fcl::Transform3d* out) const {
    const double* m = data + 16 * state * links;
    transformsFrom(m, links, out, [&](std::size_t l) {
      return transformFrom(m + 16 * l, poseName(state * links + l, links));
    });
  }
};

// Reads states' poses as PoseReader does, except that a pose failing transformFrom's checks is
// written as a NaN one (the library's rule then decides whether the call throws) and its error
// kept: rethrow() turns the library's error naming it into that error. Safe to call from the
// checking threads.
class BadPoses {
 public:
  BadPoses(const double* data, std::size_t links) : read_{data, links} {}
  void read(std::size_t state, fcl::Transform3d* out) {
    const double* m = read_.data + 16 * state * read_.links;
    transformsFrom(m, read_.links, out, [&](std::size_t l) {
      const std::size_t at = state * read_.links + l;
      try {
        return transformFrom(m + 16 * l, poseName(at, read_.links));
      } catch (const py::value_error& e) {
        const std::lock_guard<std::mutex> guard(mutex_);
        bad_.emplace(at, e.what());
        fcl::Transform3d nan = fcl::Transform3d::Identity();
        nan.translation()[0] = std::numeric_limits<double>::quiet_NaN();
        return nan;
      }
    });
  }
  /// `offset`: the index of the library's pose 0 among the array's.
  [[noreturn]] void rethrow(const std::invalid_argument& e, std::size_t offset) const {
    const std::string what = e.what();
    for (const auto& [at, error] : bad_)
      if (at >= offset &&
          what.find("pose " + std::to_string(at - offset) + " ") != std::string::npos)
        throw py::value_error(error);
    throw e;
  }

 private:
  PoseReader read_;
  std::mutex mutex_;
  std::map<std::size_t, std::string> bad_;  // pose index -> its error
};

// motion_bounds in the library's layout (state-major: k * links + l), read in place by the call
// (no copy): shape (states, links). Its values are checked by the library before any work (one
// pass, which a second here would double): boundsError names the first bad one.
Array motionBounds(py::handle obj, std::size_t states, std::size_t links) {
  return floats(obj, "motion_bounds",
                {static_cast<py::ssize_t>(states), static_cast<py::ssize_t>(links)}, false);
}

// The ValueError for bounds the library refused (a value negative, NaN or infinite), naming the
// first such as [state, link]; returns if every value is finite and >= 0 (the error was another).
void boundsError(const Array& bounds, std::size_t links) {
  const double* d = bounds.data();
  const std::size_t count = static_cast<std::size_t>(bounds.size());
  for (std::size_t i = 0; i < count; ++i)
    if (!(d[i] >= 0) || !std::isfinite(d[i]))
      throw py::value_error("motion_bounds[" + std::to_string(i / links) + ", " +
                            std::to_string(i % links) + "] is " + std::to_string(d[i]) +
                            ": each bound must be finite and >= 0");
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
           const Array a = posesArray(poses, body.links.size(), &states);
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
             // A bad pose: the first state's error, as the library passes it on.
             res = cube::checkStates<double>(*m.cube(), body.set, states,
                                             PoseReader{a.data(), body.links.size()}, opt);
             objects.resize(res.size());
             for (std::size_t i = 0; i < res.size(); ++i)
               if (res[i].object) objects[i] = Manager::entryOf(res[i].object)->name;
           }
           const auto n = static_cast<py::ssize_t>(res.size());
           py::array_t<bool> colliding(n);
           py::array_t<std::int64_t> link(n), other_link(n);
           py::array_t<double> clear(n);
           bool* c = colliding.mutable_data();
           std::int64_t* l = link.mutable_data();
           std::int64_t* o = other_link.mutable_data();
           double* d = clear.mutable_data();
           const auto index = [](std::size_t i) {
             return i == cube::kNoIndex ? std::int64_t(-1) : static_cast<std::int64_t>(i);
           };
           for (py::ssize_t i = 0; i < n; ++i) {
             const auto& r = res[i];
             c[i] = r.colliding;
             l[i] = index(r.link);
             o[i] = index(r.other_link);
             d[i] = r.clearance >= std::numeric_limits<double>::max() ? INFINITY : r.clearance;
           }
           // An object array holds None throughout (numpy's empty); the named entries replace
           // theirs (the array owns one reference to each item).
           py::array names =
               py::module_::import("numpy").attr("empty")(n, py::arg("dtype") = "object");
           PyObject** item = static_cast<PyObject**>(names.mutable_data());
           for (py::ssize_t i = 0; i < n; ++i)
             if (res[i].object) {
               PyObject* name = py::str(objects[i]).release().ptr();
               Py_XDECREF(item[i]);  // None, or nothing in an array numpy left empty
               item[i] = name;
             }
           py::dict out;
           out["colliding"] = colliding;
           out["link"] = link;
           out["object"] = names;
           out["other_link"] = other_link;
           out["clearance"] = clear;
           return out;
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
             const std::string& order, bool self_collision, bool continuous,
             py::handle motion_bounds, py::object threads) {
            needCube(m, "check_motions");
            std::size_t states = 0;
            const std::size_t n = body.links.size();
            const Array a = posesArray(poses, n, &states);
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
            const bool given = !motion_bounds.is_none();
            const Array bounds = given ? motionBounds(motion_bounds, states, n) : Array();
            const cube::MotionBounds<double> view(given ? bounds.data() : nullptr,
                                                  given ? states * n : 0);
            cube::BatchOptions opt;
            opt.self_collision = self_collision;
            opt.continuous = continuous;
            opt.threads = threads.is_none() ? m.threads() : threads.cast<int>();
            std::vector<std::size_t> res;
            {
              py::gil_scoped_release nogil;
              std::shared_lock lock(m.mutex);
              refuseFclCrashes(&m, nullptr, body.kinds(), false, "check_motions");
              // A pose that fails the checks is handed to the library as a NaN one, so that
              // its rule decides whether the call throws, whatever the thread count; the error
              // then names it as transformFrom does.
              BadPoses bad(a.data(), n);
              const auto read = [&](std::size_t k, fcl::Transform3d* out) { bad.read(k, out); };
              if (!s.empty()) {
                // Only the states the check reads are converted, on its threads (with SE(3)
                // bounds, their neighbours too).
                try {
                  if (given) {
                    res = cube::checkMotions<double>(*m.cube(), body.set, states, s, read, view, mo,
                                                     opt);
                  } else {
                    res = cube::checkMotions<double>(*m.cube(), body.set, states, s, read, mo, opt);
                  }
                } catch (const std::invalid_argument& e) {
                  if (given) boundsError(bounds, n);
                  bad.rethrow(e, 0);
                }
              } else if (given) {
                boundsError(bounds, n);  // no edge: the library is not called
              }
            }
            py::array_t<std::int64_t> out(static_cast<py::ssize_t>(res.size()));
            for (std::size_t i = 0; i < res.size(); ++i)
              out.mutable_at(i) = res[i] == cube::kNoIndex ? -1 : static_cast<std::int64_t>(res[i]);
            return out;
          },
          py::arg("body"), py::arg("poses"), py::arg("edge_starts"), py::kw_only(),
          py::arg("order") = "path", py::arg("self_collision") = false,
          py::arg("continuous") = false, py::arg("motion_bounds") = py::none(),
          py::arg("threads") = py::none(), R"doc(
Checks edges (motions): edge e is states edge_starts[e] .. edge_starts[e + 1] - 1 of poses
(states, links, 4, 4). Returns (edges,) int64: the index within the edge of its first colliding
state in `order` ('path': 0, 1, 2...; 'bisection': OMPL's DiscreteMotionValidator order), -1 if
the edge is free.

Discrete (the default): only the edge's states are checked; an obstacle thinner than the motion
between two states can be stepped over.
Continuous (continuous=True, or motion_bounds given): -1 means no link can touch a world object
(or, with self_collision, another checked link) anywhere between consecutive states of the edge,
given a bound b on each link's motion per interval (the longest path any point of the link
travels). Each state is checked with each link's margin raised by half the larger bound of the
two intervals it ends and starts (a contact, or fcl::distance within the raised margins); the
answer is the first state in `order` whose raised check fails. Conservative: an edge may be
refused though nothing is touched. Every state the discrete check finds colliding fails too.
continuous=True computes the bounds from the poses, for each link moving in SE(3) between states
(translation linear, rotation along the geodesic): |t1 - t0| + angle * the farthest corner of
the link's local box from its origin (the angle never below the rotation's, at most 2e-14
above it); they do not hold for other motions (a joint-space edge of an arm): give those bounds
instead. motion_bounds: (states, links) float array, [k, l] bounds link l's motion from state k
to k + 1 of the same edge (each edge's last state's values are not used, but checked); with it
the check is continuous whatever `continuous` says. Nothing is said of the motion before an
edge's first state or after its last.

Raises ValueError for edge_starts not starting at 0 or not increasing, motion_bounds of another
shape or with a negative, NaN or infinite value (before any work), or as check_states; TypeError
for non-numeric motion_bounds. A pose not finite or rigid raises only where its state is checked
(before its edge's first colliding state in `order`: the states after it are not read, on any
thread count); with continuous=True a state's check also reads its neighbours' poses in the
edge.)doc");
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
