// Issue 20's pair rules: what filter bits, margins and canonical order cost, each checked
// against brute force before it is timed.
//   pair_filters/<n>/{unmasked,half_masked}/cube      self-collide + FCL's narrow phase
//   (collideAll) margins/<n>/{cube,fcl_inflated}                   pairs within a contact margin,
//   answered by
//                                                     FCL; FCL's tree over AABBs grown by hand
//   canonical/<n>/{off,on}/cube                       self-collide (broadphase), the knob's cost

#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/margins.h"
#include "cube_collision/queries.h"
#include "scenes.h"

namespace {

using Obj = fcl::CollisionObjectd;

// A failed check ends the run with exit code 1, so that the smoke test fails.
void check(bool ok, const std::string& what) {
  if (ok) return;
  std::fprintf(stderr, "CHECK FAILED: %s\n", what.c_str());
  std::exit(1);
}

struct World {
  cube::scenes::Scene<double> scene;
  double size = 0;
  explicit World(std::size_t n) {
    cube::scenes::SceneOptions o;
    o.n = n;
    o.seed = 2020;
    o.overlaps_per_object = 3.0;
    scene = cube::scenes::makeScene<double>(o);
    size = cube::scenes::typicalSize(o);
  }
};

World& world(std::size_t n) {
  static std::map<std::size_t, std::unique_ptr<World>> worlds;
  auto& w = worlds[n];
  if (!w) w = std::make_unique<World>(n);
  return *w;
}

// Two groups, each pairing only within itself: about half of the overlapping pairs are masked.
void halfMask(cube::CubeCollisionManagerd& m, const std::vector<Obj*>& objs) {
  for (std::size_t i = 0; i < objs.size(); ++i) {
    const std::uint64_t group = std::uint64_t(1) << (i % 2);
    m.setFilter(objs[i], group, group);
  }
}

bool countPair(Obj*, Obj*, void* d) {
  ++*static_cast<std::size_t*>(d);
  return false;
}

// narrow: collideAll (FCL's narrow phase on one thread); otherwise the broadphase alone, with a
// callback that counts.
void pairFilters(benchmark::State& state, std::size_t n, bool masked, bool narrow) {
  World& w = world(n);
  const auto objs = w.scene.pointers();
  cube::CubeCollisionManagerd m;
  m.registerObjects(objs);
  if (masked) halfMask(m, objs);
  m.update();  // as after any change: lays the cubes out by filter group (Config::filter_groups)
  const fcl::CollisionRequestd request(100000000);
  cube::NarrowPhaseOptions<double> one;
  one.threads = 1;
  // Check: the narrow phase sees exactly the pairs whose boxes overlap and bits pass.
  std::size_t want = 0;
  for (const auto& p : cube::overlappingPairs<double>(m)) {
    (void)p;
    ++want;
  }
  std::size_t brute = 0;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      brute += objs[i]->getAABB().overlap(objs[j]->getAABB()) && (!masked || i % 2 == j % 2);
  check(want == brute, "pair_filters: " + std::to_string(want) + " pairs vs " +
                           std::to_string(brute) + " by brute force");
  cube::NarrowPhaseStats stats;
  cube::NarrowPhaseOptions<double> counted = one;
  counted.stats = &stats;
  const std::size_t contacts = cube::collideAll(m, request, counted).numContacts();
  if (narrow) {
    for (auto _ : state) benchmark::DoNotOptimize(cube::collideAll(m, request, one).numContacts());
  } else {
    for (auto _ : state) {
      std::size_t c = 0;
      m.collide(&c, countPair);
      benchmark::DoNotOptimize(c);
    }
  }
  state.counters["candidate_pairs"] = double(stats.candidate_pairs);
  state.counters["narrow_calls"] = double(stats.narrow_calls);
  state.counters["contacts"] = double(contacts);
}

// Within-margin contacts: cube's helper against what an FCL user writes today (tesseract does
// this): a CollisionObject subclass whose AABB is grown by the margin, FCL's tree over those,
// then fcl::collide and fcl::distance on every candidate pair. Both managers are built before
// the timing, as for a static scene.
using Found = std::vector<std::tuple<Obj*, Obj*, bool>>;

struct Inflated : Obj {
  Obj* original;
  Inflated(Obj* o, double margin)
      : Obj(std::const_pointer_cast<fcl::CollisionGeometryd>(o->collisionGeometry()),
            o->getTransform()),
        original(o) {
    aabb.min_ -= fcl::Vector3d::Constant(margin);
    aabb.max_ += fcl::Vector3d::Constant(margin);
  }
};

struct FclInflated {
  std::vector<std::unique_ptr<Inflated>> objs;
  fcl::DynamicAABBTreeCollisionManagerd tree;
  double within;
  FclInflated(const std::vector<Obj*>& originals, double margin) : within(2 * margin) {
    std::vector<Obj*> ptrs;
    for (Obj* o : originals) {
      objs.push_back(std::make_unique<Inflated>(o, margin));
      ptrs.push_back(objs.back().get());
    }
    tree.registerObjects(ptrs);
    tree.setup();
  }
  Found run() {
    struct Data {
      double within;
      Found found;
    } data{within, {}};
    tree.collide(&data, [](Obj* x, Obj* y, void* d) {
      auto& dd = *static_cast<Data*>(d);
      Obj* a = static_cast<Inflated*>(x)->original;
      Obj* b = static_cast<Inflated*>(y)->original;
      if (b < a) std::swap(a, b);
      fcl::CollisionRequestd creq;
      fcl::CollisionResultd cres;
      if (fcl::collide(a, b, creq, cres) > 0) {
        dd.found.emplace_back(a, b, true);
        return false;
      }
      fcl::DistanceRequestd dreq(true);
      fcl::DistanceResultd dres;
      if (fcl::distance(a, b, dreq, dres) <= dd.within) dd.found.emplace_back(a, b, false);
      return false;
    });
    std::sort(data.found.begin(), data.found.end());
    return data.found;
  }
};

void margins(benchmark::State& state, std::size_t n, bool cube_side) {
  World& w = world(n);
  const auto objs = w.scene.pointers();
  const double margin = 0.25 * w.size;
  FclInflated fcl_side(objs, margin);
  static std::map<std::size_t, Found> reference;
  if (!reference.count(n)) reference[n] = fcl_side.run();
  if (cube_side) {
    cube::CubeCollisionManagerd m;
    m.registerObjects(objs);
    m.setMargin(margin);
    Found got;
    cube::NarrowPhaseStats stats;
    for (const auto& c : cube::contactsWithinMargin(m, fcl::DistanceRequestd(true), 1, &stats))
      got.emplace_back(std::min(c.a, c.b), std::max(c.a, c.b), c.colliding);
    std::sort(got.begin(), got.end());
    check(got == reference[n], "margins: cube's pairs within the margin differ from FCL's");
    state.counters["narrow_calls"] = double(stats.narrow_calls);
    state.counters["culled"] = double(stats.culled);
    for (auto _ : state)
      benchmark::DoNotOptimize(cube::contactsWithinMargin(m, fcl::DistanceRequestd(true)).size());
  } else {
    for (auto _ : state) benchmark::DoNotOptimize(fcl_side.run().size());
  }
  state.counters["pairs_within"] = double(reference[n].size());
}

void canonical(benchmark::State& state, std::size_t n, bool on) {
  World& w = world(n);
  cube::Config cfg;
  cfg.canonical_pairs = on;
  cfg.keep_pairs = false;
  cube::CubeCollisionManagerd m(cfg);
  m.registerObjects(w.scene.pointers());
  std::size_t pairs = 0;
  m.collide(&pairs, countPair);
  check(pairs == cube::overlappingPairs<double>(m).size(), "canonical: pair count");
  for (auto _ : state) {
    std::size_t c = 0;
    m.collide(&c, countPair);
    benchmark::DoNotOptimize(c);
  }
  state.counters["pairs"] = double(pairs);
}

void registerPairRules() {
  for (const std::size_t n : {1000u, 10000u}) {
    const std::string s = std::to_string(n);
    for (const bool narrow : {true, false})
      for (const bool masked : {false, true})
        benchmark::RegisterBenchmark(
            ("pair_filters/" + s + (narrow ? "/narrow" : "/broadphase") +
             (masked ? "/half_masked" : "/unmasked") + "/cube")
                .c_str(),
            [n, masked, narrow](benchmark::State& st) { pairFilters(st, n, masked, narrow); })
            ->Unit(benchmark::kMicrosecond);
    for (const bool c : {true, false})
      benchmark::RegisterBenchmark(("margins/" + s + (c ? "/cube" : "/fcl_inflated")).c_str(),
                                   [n, c](benchmark::State& st) { margins(st, n, c); })
          ->Unit(benchmark::kMillisecond);
    for (const bool on : {false, true})
      benchmark::RegisterBenchmark(("canonical/" + s + (on ? "/on" : "/off") + "/cube").c_str(),
                                   [n, on](benchmark::State& st) { canonical(st, n, on); })
          ->Unit(benchmark::kMicrosecond);
  }
}

const bool registered = (registerPairRules(), true);

}  // namespace
