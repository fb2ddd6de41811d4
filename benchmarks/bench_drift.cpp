// The rebuild-threshold study: a scene whose objects drift steadily, N steps of
// move + update() + self-collide, for several values of Config::rebuild_threshold and the two
// forced policies, and a few values of Config::rebuild_budget, with FCL's tree manager on the
// same motion for reference. The default threshold in config.h was chosen from this case.

#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/inspect.h"
#include "scenes.h"

namespace {

constexpr std::size_t kObjects = 10000;
constexpr int kSteps = 100;

// Every object drifts along its own fixed direction; after kSteps steps it has travelled about
// three typical object sizes, enough to spoil a tree built at the start.
struct Drift {
  cube::scenes::Scene<double> scene;
  std::vector<fcl::Transform3d> start;
  std::vector<fcl::Vector3d> velocity;

  Drift() {
    cube::scenes::SceneOptions options;
    options.n = kObjects;
    options.seed = 11;
    scene = cube::scenes::makeScene<double>(options);
    const double speed = 3.0 * cube::scenes::typicalSize(options) / kSteps;
    std::mt19937 rng(12);
    std::normal_distribution<double> g(0, 1);
    for (const auto& o : scene.objects) {
      start.push_back(o->getTransform());
      fcl::Vector3d v(g(rng), g(rng), g(rng));
      velocity.push_back(v.normalized() * speed);
    }
  }

  void reset() {
    for (std::size_t i = 0; i < start.size(); ++i) {
      scene.objects[i]->setTransform(start[i]);
      scene.objects[i]->computeAABB();
    }
  }

  void step() {
    for (std::size_t i = 0; i < start.size(); ++i) {
      auto& o = *scene.objects[i];
      o.setTranslation(o.getTranslation() + velocity[i]);
      o.computeAABB();
    }
  }
};

Drift& drift() {
  static Drift d;
  return d;
}

bool countPair(fcl::CollisionObjectd*, fcl::CollisionObjectd*, void* data) {
  ++*static_cast<std::size_t*>(data);
  return false;
}

// Times only update() + self-collide; moving the objects is the same work for every manager.
// `after(manager)` may add counters once the steps are done.
template <class MakeManager, class After>
void runDrift(benchmark::State& state, MakeManager make, After after) {
  Drift& d = drift();
  for (auto _ : state) {
    d.reset();
    auto manager = make();
    manager->registerObjects(d.scene.pointers());
    manager->setup();
    double seconds = 0;
    std::size_t pairs = 0;
    for (int s = 0; s < kSteps; ++s) {
      d.step();
      const auto t0 = std::chrono::steady_clock::now();
      manager->update();
      manager->collide(&pairs, countPair);
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    state.SetIterationTime(seconds);
    state.counters["pairs"] = double(pairs);
    after(*manager);
  }
}

void cubeDrift(benchmark::State& state, cube::UpdatePolicy policy, double threshold,
               double budget = 0) {
  cube::Config config;
  config.update_policy = policy;
  if (threshold > 1) config.rebuild_threshold = threshold;
  config.rebuild_budget = budget;
  runDrift(
      state, [&] { return std::make_unique<cube::CubeCollisionManagerd>(config); },
      [&](const cube::CubeCollisionManagerd& m) {
        state.counters["builds"] = double(cube::HierarchyView<double>(m).stats().builds);
      });
}

void registerDrift() {
  for (double t : {1.1, 1.25, 1.5, 2.0, 3.0, 5.0}) {
    benchmark::RegisterBenchmark(
        ("drift/threshold/" + std::to_string(t).substr(0, 4) + "/cube").c_str(),
        [t](benchmark::State& s) { cubeDrift(s, cube::UpdatePolicy::automatic, t); })
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->Repetitions(3);
  }
  // Config::rebuild_budget at the default threshold: a steady drift should rebuild at the same
  // steps (its "builds" counter) as with no budget.
  for (double b : {1.0, 2.0, 4.0}) {
    benchmark::RegisterBenchmark(
        ("drift/budget/" + std::to_string(b).substr(0, 3) + "/cube").c_str(),
        [b](benchmark::State& s) { cubeDrift(s, cube::UpdatePolicy::automatic, 0, b); })
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->Repetitions(3);
  }
  benchmark::RegisterBenchmark(
      "drift/refit-only/cube",
      [](benchmark::State& s) { cubeDrift(s, cube::UpdatePolicy::refit, 0); })
      ->UseManualTime()
      ->Unit(benchmark::kMillisecond)
      ->Iterations(1)
      ->Repetitions(3);
  benchmark::RegisterBenchmark(
      "drift/rebuild-always/cube",
      [](benchmark::State& s) { cubeDrift(s, cube::UpdatePolicy::rebuild, 0); })
      ->UseManualTime()
      ->Unit(benchmark::kMillisecond)
      ->Iterations(1)
      ->Repetitions(3);
  benchmark::RegisterBenchmark(
      "drift/dynamic-aabb-tree/fcl",
      [](benchmark::State& s) {
        runDrift(
            s, [] { return std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>(); },
            [](const fcl::DynamicAABBTreeCollisionManagerd&) {});
      })
      ->UseManualTime()
      ->Unit(benchmark::kMillisecond)
      ->Iterations(1)
      ->Repetitions(3);
}

// Registered at start-up like BENCHMARK(); the drift scene itself is built on first use only.
const bool registered = (registerDrift(), true);

}  // namespace
