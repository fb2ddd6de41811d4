// Swept boxes for continuous collision (continuous.h): 10% of a scene's objects move (a
// translation of up to three object sizes per axis and a rotation of up to pi), the rest stay.
//  - continuous/swept-pairs/<n>/<motion>/cube: cube::sweptPairs; counter x_brute is how many
//    times faster it is than the brute-force baseline (sweptBox of each mover, then every pair
//    with a mover tested), the fastest of a few runs timed in the same run.
//  - continuous/collide-all/1000/<motion>/cube: cube::continuousCollideAll; x_brute against
//    fcl::continuousCollide on every pair with a mover, timed in the same run.
// Both are checked equal to their baseline before timing; a mismatch fails the binary.

#include <benchmark/benchmark.h>
#include <fcl/narrowphase/continuous_collision.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cube_collision/continuous.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

extern bool g_extra_failed;  // cube_bench.cpp: makes the binary exit non-zero

namespace {

using Obj = fcl::CollisionObjectd;
using Pairs = std::vector<std::pair<Obj*, Obj*>>;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Moving {
  cube::scenes::Scene<double> scene;
  cube::CubeCollisionManagerd manager;
  std::vector<Obj*> objs;  // registration order
  std::vector<cube::Motion<double>> motions;
  std::vector<const fcl::Transform3d*> end;  // per object, null if it stays

  explicit Moving(std::size_t n) {
    cube::scenes::SceneOptions o;
    o.n = n;
    o.seed = 21;
    scene = cube::scenes::makeScene<double>(o);
    objs = scene.pointers();
    manager.registerObjects(objs);
    const double size = cube::scenes::typicalSize(o);
    std::mt19937 rng(22);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> g(0, 1);
    for (Obj* obj : objs) {
      if (u(rng) >= 0.1) continue;
      fcl::Transform3d tf = obj->getTransform();
      for (int k = 0; k < 3; ++k) tf.translation()[k] += (2 * u(rng) - 1) * 3 * size;
      const fcl::Vector3d axis = fcl::Vector3d(g(rng), g(rng), g(rng)).normalized();
      tf.linear() = fcl::AngleAxisd(u(rng) * M_PI, axis).toRotationMatrix() * tf.linear();
      motions.push_back({obj, tf});
    }
    end.assign(objs.size(), nullptr);
    for (std::size_t i = 0, k = 0; i < objs.size() && k < motions.size(); ++i)
      if (objs[i] == motions[k].object) end[i] = &motions[k++].end;
  }

  // The baseline: every pair with a mover, box against box, in registration order.
  Pairs brutePairs(fcl::CCDMotionType type) const {
    std::vector<fcl::AABBd> box(objs.size());
    for (std::size_t i = 0; i < objs.size(); ++i)
      box[i] = end[i] ? cube::sweptBox(*objs[i], *end[i], type) : objs[i]->getAABB();
    Pairs out;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j)
        if ((end[i] || end[j]) && box[i].overlap(box[j])) out.emplace_back(objs[i], objs[j]);
    return out;
  }

  // The baseline: fcl::continuousCollide on every pair with a mover, sorted as the helper sorts.
  std::vector<cube::ContinuousContact> bruteContacts(
      const fcl::ContinuousCollisionRequestd& request) const {
    std::vector<cube::ContinuousContact> out;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        if (!end[i] && !end[j]) continue;
        fcl::ContinuousCollisionResultd r;
        fcl::continuousCollide(objs[i], end[i] ? *end[i] : objs[i]->getTransform(), objs[j],
                               end[j] ? *end[j] : objs[j]->getTransform(), request, r);
        if (r.is_collide)
          out.push_back({objs[i], objs[j], r.time_of_contact, r.contact_tf1, r.contact_tf2});
      }
    std::stable_sort(out.begin(), out.end(), [](const auto& x, const auto& y) {
      return x.time_of_contact < y.time_of_contact;
    });
    return out;
  }
};

Moving& moving(std::size_t n) {
  static std::map<std::size_t, std::unique_ptr<Moving>> scenes;
  auto& m = scenes[n];
  if (!m) m = std::make_unique<Moving>(n);
  return *m;
}

bool fail(benchmark::State& state, const std::string& why) {
  g_extra_failed = true;
  std::fprintf(stderr, "CHECK FAILED: %s\n", why.c_str());
  state.SkipWithError(("check failed: " + why).c_str());
  return false;
}

// The fastest of a few runs of `f` (at least 3, and until 0.2 s are spent, at most 20): one
// cold run on a machine shared with builds says little.
template <class F>
double fastest(F&& f) {
  double best = 1e300, spent = 0;
  for (int k = 0; k < 20 && (k < 3 || spent < 0.2); ++k) {
    const auto t0 = Clock::now();
    f();
    const double s = since(t0);
    best = std::min(best, s);
    spent += s;
  }
  return best;
}

const char* motionName(fcl::CCDMotionType t) {
  return t == fcl::CCDM_TRANS ? "trans" : "screw";
}

void sweptPairsCase(benchmark::State& state, std::size_t n, fcl::CCDMotionType type) {
  Moving& m = moving(n);
  const Pairs want = m.brutePairs(type);
  const double brute = fastest([&] { benchmark::DoNotOptimize(m.brutePairs(type)); });
  if (cube::sweptPairs(m.manager, m.motions, type) != want)
    return (void)fail(state, "sweptPairs differs from the brute-force pairs");
  double total = 0;
  std::size_t pairs = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    const Pairs got = cube::sweptPairs(m.manager, m.motions, type);
    const double s = since(t0);
    state.SetIterationTime(s);
    total += s;
    pairs = got.size();
  }
  state.counters["movers"] = double(m.motions.size());
  state.counters["pairs"] = double(pairs);
  state.counters["brute_ms"] = brute * 1e3;
  state.counters["x_brute"] = brute / (total / double(state.iterations()));
}

void collideAllCase(benchmark::State& state, std::size_t n, fcl::CCDMotionType type) {
  Moving& m = moving(n);
  fcl::ContinuousCollisionRequestd request;
  request.ccd_motion_type = type;
  auto t0 = Clock::now();
  const auto want = m.bruteContacts(request);
  double brute = since(t0);
  t0 = Clock::now();
  m.bruteContacts(request);  // a second run: the fastest of two (each is a fraction of a second)
  brute = std::min(brute, since(t0));
  const auto got = cube::continuousCollideAll(m.manager, m.motions, request);
  bool same = got.size() == want.size();
  for (std::size_t k = 0; same && k < got.size(); ++k)
    same = got[k].a == want[k].a && got[k].b == want[k].b &&
           got[k].time_of_contact == want[k].time_of_contact;
  if (!same) return (void)fail(state, "continuousCollideAll differs from FCL over every pair");
  double total = 0;
  for (auto _ : state) {
    t0 = Clock::now();
    benchmark::DoNotOptimize(cube::continuousCollideAll(m.manager, m.motions, request));
    const double s = since(t0);
    state.SetIterationTime(s);
    total += s;
  }
  std::size_t later = 0;
  for (const auto& c : got) later += c.time_of_contact > 0;
  state.counters["contacts"] = double(got.size());
  state.counters["during_motion"] = double(later);
  state.counters["brute_ms"] = brute * 1e3;
  state.counters["x_brute"] = brute / (total / double(state.iterations()));
}

void registerContinuous() {
  for (const auto type : {fcl::CCDM_TRANS, fcl::CCDM_SCREW}) {
    for (const std::size_t n : {1000, 10000}) {
      benchmark::RegisterBenchmark(
          ("continuous/swept-pairs/" + std::to_string(n) + "/" + motionName(type) + "/cube")
              .c_str(),
          [n, type](benchmark::State& s) { sweptPairsCase(s, n, type); })
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond);
    }
    benchmark::RegisterBenchmark(
        (std::string("continuous/collide-all/1000/") + motionName(type) + "/cube").c_str(),
        [type](benchmark::State& s) { collideAllCase(s, 1000, type); })
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond);
  }
}

const bool registered = (registerContinuous(), true);

}  // namespace
