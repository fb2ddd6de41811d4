// cube_collision_bench: the library's own checkStates / checkMotions on a Python manager's world
// and Body, timed in C++ (poses converted before the clock starts), for bench_check_states.py's
// comparison of the Python calls with the C++ calls they wrap (continuous edges included); under
// callgrind, the instructions of one call of each instead (count_as, counted).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "batch.h"
#include "manager.h"

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define CUBE_ON_VALGRIND() (RUNNING_ON_VALGRIND != 0)
#else  // without valgrind's headers nothing is counted (the calls still run)
#define CALLGRIND_ZERO_STATS
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#define CALLGRIND_DUMP_STATS_AT(label) (void)(label)
#define CUBE_ON_VALGRIND() false
#endif

namespace py = pybind11;

namespace cubepy {

namespace {

std::vector<fcl::Transform3d> transformsOf(const py::array_t<double, py::array::c_style>& a,
                                           std::size_t links) {
  if (a.ndim() != 4 || static_cast<std::size_t>(a.shape(1)) != links || a.shape(2) != 4 ||
      a.shape(3) != 4)
    throw py::value_error("poses: (states, links, 4, 4) expected");
  std::vector<fcl::Transform3d> out(static_cast<std::size_t>(a.shape(0)) * links);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double* m = a.data() + 16 * i;
    out[i].setIdentity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) out[i].matrix()(r, c) = m[4 * r + c];
  }
  return out;
}

// f run once with callgrind's instrumentation on, its instructions dumped under `label` (a
// profile of their own: bench_check_states.py --instructions reads it).
template <class F>
void counted(const std::string& label, F&& f) {
  CALLGRIND_START_INSTRUMENTATION;
  CALLGRIND_ZERO_STATS;
  f();
  CALLGRIND_STOP_INSTRUMENTATION;
  CALLGRIND_DUMP_STATS_AT(label.c_str());
}

// The least of `repeats` runs of f, in seconds (f's last answer kept by f); with count_as, f
// runs once, counted (0 seconds).
template <class F>
double best(int repeats, F&& f, const std::optional<std::string>& count_as = std::nullopt) {
  if (count_as) {
    counted(*count_as, f);
    return 0;
  }
  double out = std::numeric_limits<double>::infinity();
  for (int r = 0; r < std::max(repeats, 1); ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    out =
        std::min(out, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return out;
}

}  // namespace

void bindBatchWay(py::module_& m) {
  m.def(
      "on_valgrind", [] { return CUBE_ON_VALGRIND(); },
      "Whether the process runs under valgrind (and the module was built with its headers).");
  m.def(
      "counted",
      [](const std::string& label, const py::function& f) { counted(label, [&] { f(); }); },
      py::arg("label"), py::arg("f"),
      "Calls f() with callgrind's instrumentation on and dumps its instructions under `label`.");
  m.def(
      "check_states_cpp",
      [](const Manager& world, const Body& body,
         const py::array_t<double, py::array::c_style>& poses, int threads, int repeats,
         bool self_collision, const std::optional<std::string>& count_as) {
        const auto tfs = transformsOf(poses, body.links.size());
        cube::BatchOptions opt;
        opt.threads = threads;
        opt.self_collision = self_collision;
        std::vector<cube::StateResult<double>> res;
        double seconds;
        {
          py::gil_scoped_release nogil;
          std::shared_lock lock(world.mutex);
          seconds = best(
              repeats, [&] { res = cube::checkStates(*world.cube(), body.set, tfs, opt); },
              count_as);
        }
        py::array_t<bool> colliding(static_cast<py::ssize_t>(res.size()));
        for (std::size_t i = 0; i < res.size(); ++i)
          colliding.mutable_at(static_cast<py::ssize_t>(i)) = res[i].colliding;
        return py::make_tuple(seconds, colliding);
      },
      py::arg("manager"), py::arg("body"), py::arg("poses"), py::arg("threads"), py::arg("repeats"),
      py::arg("self_collision") = false, py::arg("count_as") = py::none(),
      "(best seconds of `repeats` cube::checkStates calls, colliding per state); count_as: one "
      "call, counted under that label.");
  m.def(
      "check_motions_cpp",
      [](const Manager& world, const Body& body,
         const py::array_t<double, py::array::c_style>& poses,
         const std::vector<std::size_t>& edge_starts, int threads, int repeats, bool continuous,
         const std::optional<std::vector<double>>& motion_bounds,
         const std::optional<std::string>& count_as) {
        const auto tfs = transformsOf(poses, body.links.size());
        cube::BatchOptions opt;
        opt.threads = threads;
        opt.continuous = continuous;
        std::vector<std::size_t> res;
        double seconds;
        {
          py::gil_scoped_release nogil;
          std::shared_lock lock(world.mutex);
          seconds = best(
              repeats,
              [&] {
                res = motion_bounds
                          ? cube::checkMotions(*world.cube(), body.set, tfs, edge_starts,
                                               *motion_bounds, cube::MotionOrder::path, opt)
                          : cube::checkMotions(*world.cube(), body.set, tfs, edge_starts,
                                               cube::MotionOrder::path, opt);
              },
              count_as);
        }
        py::array_t<std::int64_t> first(static_cast<py::ssize_t>(res.size()));
        for (std::size_t i = 0; i < res.size(); ++i)
          first.mutable_at(static_cast<py::ssize_t>(i)) =
              res[i] == cube::kNoIndex ? -1 : static_cast<std::int64_t>(res[i]);
        return py::make_tuple(seconds, first);
      },
      py::arg("manager"), py::arg("body"), py::arg("poses"), py::arg("edge_starts"),
      py::arg("threads"), py::arg("repeats"), py::arg("continuous") = false,
      py::arg("motion_bounds") = py::none(), py::arg("count_as") = py::none(),
      "(best seconds of `repeats` cube::checkMotions calls in path order, first colliding state "
      "per edge or -1); `continuous` as BatchOptions::continuous, `motion_bounds` (flat, "
      "state-major) the overload that takes them; count_as: one call, counted under that label.");
}

}  // namespace cubepy
