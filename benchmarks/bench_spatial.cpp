// Ray and region queries (spatial_queries.h) on the uniform scene of cube_bench at
// 1,000, 10,000 and 100,000 objects: the cube query against a loop over every registered object
// (the box test on each AABB, then, with the narrow phase, raycastObject on those the segment
// meets). The loop reads a contiguous copy of the AABBs, made before timing: reading them
// through the objects (scattered on the heap) would make it several times slower at 100,000. Each
// case first checks the cube answers equal the loop's on every query, then times the cube query;
// the counter vs_brute is the loop's time over the cube's, both measured here.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/spatial_queries.h"
#include "scenes.h"

// cube_bench.cpp's flag for checks of the cases registered from other files: its exit code.
extern bool g_extra_failed;

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using V3 = fcl::Vector3<S>;
using Clock = std::chrono::steady_clock;

constexpr int kQueries = 64;  // segments (or regions) per iteration

struct World {
  cube::scenes::SceneOptions options;
  cube::scenes::Scene<S> scene;
  std::vector<Object*> objs;
  std::vector<fcl::AABB<S>> aabbs;  // the loop's copy of every AABB, contiguous, in objs order
  std::unique_ptr<cube::CubeCollisionManager<S>> manager;
  std::vector<std::pair<V3, V3>> segments;
  std::vector<std::pair<V3, S>> balls;  // objectsNear queries
  std::vector<fcl::AABB<S>> boxes;      // objectsInBox queries
};

// The scene cube_bench calls uniform; segments between two random points of its world (they
// cross it, meeting about n^(1/3) / 4 boxes each); regions a few object sizes across.
World& world(std::size_t n) {
  static std::map<std::size_t, std::unique_ptr<World>> worlds;
  auto& w = worlds[n];
  if (w) return *w;
  w = std::make_unique<World>();
  w->options.n = n;
  w->scene = cube::scenes::makeScene<S>(w->options);
  w->objs = w->scene.pointers();
  for (Object* o : w->objs) w->aabbs.push_back(o->getAABB());
  w->manager = std::make_unique<cube::CubeCollisionManager<S>>();
  w->manager->registerObjects(w->objs);
  w->manager->setup();
  const double h = w->options.half_extent, size = cube::scenes::typicalSize(w->options);
  std::mt19937 rng(20);
  std::uniform_real_distribution<double> u(-h, h), r(0, 3 * size);
  const auto point = [&] { return V3(u(rng), u(rng), u(rng)); };
  for (int i = 0; i < kQueries; ++i) {
    w->segments.emplace_back(point(), point());
    w->balls.emplace_back(point(), r(rng));
    const V3 c = point(), e(r(rng), r(rng), r(rng));
    w->boxes.emplace_back(c - e, c + e);
  }
  return *w;
}

// The loop over every object: the box test of the contract, then raycastObject where it meets.
std::vector<cube::RayHit<S>> bruteAll(const World& w, const V3& from, const V3& to, bool narrow) {
  double o[3], inv[3];
  for (int k = 0; k < 3; ++k) {
    o[k] = from[k];
    inv[k] = 1.0 / (to[k] - from[k]);
  }
  cube::RayOptions<S> opt;
  opt.narrow_phase = narrow;
  std::vector<cube::RayHit<S>> hits;
  for (std::size_t i = 0; i < w.objs.size(); ++i) {
    Object* obj = w.objs[i];
    const fcl::AABB<S>& b = w.aabbs[i];
    double lo = 0, hi = 1;
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(inv[k])) {
        if (o[k] < b.min_[k] || o[k] > b.max_[k]) lo = 2;
        continue;
      }
      const double t1 = (b.min_[k] - o[k]) * inv[k], t2 = (b.max_[k] - o[k]) * inv[k];
      lo = std::max(lo, inv[k] > 0 ? t1 : t2);
      hi = std::min(hi, inv[k] > 0 ? t2 : t1);
    }
    if (lo > hi) continue;
    if (!narrow) {
      cube::RayHit<S> h;
      h.object = obj;
      h.t = lo;
      h.distance = lo * (to - from).norm();
      h.point = from + lo * (to - from);
      hits.push_back(h);
    } else if (auto h = cube::raycastObject(*obj, b, from, to, opt)) {
      hits.push_back(*h);
    }
  }
  std::stable_sort(hits.begin(), hits.end(),
                   [](const auto& a, const auto& b) { return a.t < b.t; });
  return hits;
}

std::vector<Object*> bruteNear(const World& w, const V3& p, S r) {
  std::vector<Object*> out;
  for (std::size_t i = 0; i < w.objs.size(); ++i) {
    const fcl::AABB<S>& b = w.aabbs[i];
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
      const double g = std::max({0.0, b.min_[k] - p[k], p[k] - b.max_[k]});
      sum += g * g;
    }
    if (sum <= r * r) out.push_back(w.objs[i]);
  }
  return out;
}

std::vector<Object*> bruteInBox(const World& w, const fcl::AABB<S>& q) {
  std::vector<Object*> out;
  for (std::size_t i = 0; i < w.objs.size(); ++i)
    if (w.aabbs[i].overlap(q)) out.push_back(w.objs[i]);
  return out;
}

enum class Kind { first_box, all_box, first_narrow, all_narrow, near, in_box };

const char* kindName(Kind k) {
  switch (k) {
    case Kind::first_box:
      return "spatial_ray_first_box";
    case Kind::all_box:
      return "spatial_ray_all_box";
    case Kind::first_narrow:
      return "spatial_ray_first_narrow";
    case Kind::all_narrow:
      return "spatial_ray_all_narrow";
    case Kind::near:
      return "spatial_objects_near";
    default:
      return "spatial_objects_in_box";
  }
}

bool narrowOf(Kind k) {
  return k == Kind::first_narrow || k == Kind::all_narrow;
}

// One pass of kQueries queries: by the cube manager, or by the loop. Returns a checksum of the
// answers, so that nothing is optimised away.
double pass(const World& w, Kind k, bool cube_side) {
  cube::RayOptions<S> opt;
  opt.narrow_phase = narrowOf(k);
  double sum = 0;
  for (int i = 0; i < kQueries; ++i) {
    const auto& [from, to] = w.segments[i];
    switch (k) {
      case Kind::first_box:
      case Kind::first_narrow:
        if (cube_side) {
          if (auto h = cube::raycastFirst(*w.manager, from, to, opt)) sum += h->t;
        } else {
          const auto all = bruteAll(w, from, to, opt.narrow_phase);
          if (!all.empty()) sum += all.front().t;
        }
        break;
      case Kind::all_box:
      case Kind::all_narrow:
        sum += double(cube_side ? cube::raycastAll(*w.manager, from, to, opt).size()
                                : bruteAll(w, from, to, opt.narrow_phase).size());
        break;
      case Kind::near:
        sum += double(
            cube_side ? cube::objectsNear(*w.manager, w.balls[i].first, w.balls[i].second).size()
                      : bruteNear(w, w.balls[i].first, w.balls[i].second).size());
        break;
      case Kind::in_box:
        sum += double(cube_side ? cube::objectsInBox(*w.manager, w.boxes[i]).size()
                                : bruteInBox(w, w.boxes[i]).size());
        break;
    }
  }
  return sum;
}

bool sameHits(const std::vector<cube::RayHit<S>>& a, const std::vector<cube::RayHit<S>>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].object != b[i].object || a[i].t != b[i].t || a[i].kind != b[i].kind) return false;
  return true;
}

// Every query of the case against the loop; empty if all agree, else what differed.
std::string check(const World& w, Kind k) {
  cube::RayOptions<S> opt;
  opt.narrow_phase = narrowOf(k);
  for (int i = 0; i < kQueries; ++i) {
    const auto& [from, to] = w.segments[i];
    const std::string at = " at query " + std::to_string(i);
    switch (k) {
      case Kind::first_box:
      case Kind::first_narrow: {
        const auto want = bruteAll(w, from, to, opt.narrow_phase);
        const auto got = cube::raycastFirst(*w.manager, from, to, opt);
        if (got.has_value() != !want.empty() || (got && !sameHits({*got}, {want.front()})))
          return "first hit differs from the loop" + at;
        break;
      }
      case Kind::all_box:
      case Kind::all_narrow:
        if (!sameHits(cube::raycastAll(*w.manager, from, to, opt),
                      bruteAll(w, from, to, opt.narrow_phase)))
          return "hits differ from the loop" + at;
        break;
      case Kind::near:
        if (cube::objectsNear(*w.manager, w.balls[i].first, w.balls[i].second) !=
            bruteNear(w, w.balls[i].first, w.balls[i].second))
          return "objectsNear differs from the loop" + at;
        break;
      case Kind::in_box:
        if (cube::objectsInBox(*w.manager, w.boxes[i]) != bruteInBox(w, w.boxes[i]))
          return "objectsInBox differs from the loop" + at;
        break;
    }
  }
  return {};
}

void runSpatial(benchmark::State& state, Kind k, std::size_t n) {
  const World& w = world(n);
  const std::string bad = check(w, k);
  if (!bad.empty()) {
    g_extra_failed = true;
    std::fprintf(stderr, "CHECK FAILED: %s/%zu: %s\n", kindName(k), n, bad.c_str());
    state.SkipWithError(("check failed: " + bad).c_str());
    return;
  }
  double sink = 0, cube_seconds = 0;
  std::size_t passes = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    sink += pass(w, k, true);
    cube_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    ++passes;
  }
  // The loop over every object on the same queries, for at least 0.2 s (or one pass).
  double brute_seconds = 0;
  std::size_t brute_passes = 0;
  while (brute_passes == 0 || brute_seconds < 0.2) {
    const auto t0 = Clock::now();
    sink += pass(w, k, false);
    brute_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    ++brute_passes;
  }
  benchmark::DoNotOptimize(sink);
  const double cube_per = cube_seconds / double(passes), brute_per = brute_seconds / brute_passes;
  state.counters["vs_brute"] = brute_per / cube_per;
  state.counters["brute_us_per_query"] = 1e6 * brute_per / kQueries;
  state.counters["cube_us_per_query"] = 1e6 * cube_per / kQueries;
}

void registerSpatial() {
  for (Kind k : {Kind::first_box, Kind::all_box, Kind::first_narrow, Kind::all_narrow, Kind::near,
                 Kind::in_box})
    for (std::size_t n : {std::size_t(1000), std::size_t(10000), std::size_t(100000)})
      benchmark::RegisterBenchmark(
          (std::string(kindName(k)) + "/uniform/" + std::to_string(n) + "/cube").c_str(),
          [k, n](benchmark::State& s) { runSpatial(s, k, n); })
          ->Unit(benchmark::kMicrosecond);
}

// Registered at start-up like BENCHMARK(); the scenes are built on first use only.
const bool registered = (registerSpatial(), true);

}  // namespace
