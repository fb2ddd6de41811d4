// The self walk split over threads: collideAll on 2 threads, every contact,
// with the candidate pairs gathered by the serial walk (NarrowPhaseOptions::split_walk off, the
// default) and by the split walk (on), in the same run; and the serial walk alone, for its share
// of the serial query. Each
// case first checks the walk's pairs against a brute-force sweep over every object and the two
// paths' contacts against each other (bit for bit), and reports speedup = before / after.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

extern bool g_extra_failed;

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Clock = std::chrono::steady_clock;
constexpr int kThreads = 2;

using Pair = std::pair<Object*, Object*>;

Pair unordered(Object* a, Object* b) {
  return a < b ? Pair{a, b} : Pair{b, a};
}

// Brute force: every pair of objects whose AABBs overlap (closed), by a sweep along x.
std::vector<Pair> brutePairs(const std::vector<Object*>& objs) {
  std::vector<Object*> v = objs;
  std::sort(v.begin(), v.end(),
            [](Object* a, Object* b) { return a->getAABB().min_[0] < b->getAABB().min_[0]; });
  std::vector<Pair> out;
  for (std::size_t i = 0; i < v.size(); ++i)
    for (std::size_t j = i + 1; j < v.size() && v[j]->getAABB().min_[0] <= v[i]->getAABB().max_[0];
         ++j)
      if (v[i]->getAABB().overlap(v[j]->getAABB())) out.push_back(unordered(v[i], v[j]));
  std::sort(out.begin(), out.end());
  return out;
}

bool sameContacts(const fcl::CollisionResult<S>& a, const fcl::CollisionResult<S>& b) {
  if (a.numContacts() != b.numContacts()) return false;
  for (std::size_t k = 0; k < a.numContacts(); ++k) {
    const auto &x = a.getContact(k), &y = b.getContact(k);
    if (x.o1 != y.o1 || x.o2 != y.o2 || x.b1 != y.b1 || x.b2 != y.b2 ||
        std::memcmp(x.pos.data(), y.pos.data(), sizeof(S) * 3) != 0 ||
        std::memcmp(&x.penetration_depth, &y.penetration_depth, sizeof(S)) != 0)
      return false;
  }
  return true;
}

struct Fixture {
  cube::scenes::Scene<S> scene;
  std::unique_ptr<cube::CubeCollisionManager<S>> cube;
  std::map<std::string, double> seconds;  // each path's last mean, for the speedup
  bool ok = true;
  std::string message;
};

std::map<std::string, std::unique_ptr<Fixture>> g_fixtures;

Fixture& fixture(const std::string& layout, std::size_t n) {
  auto& f = g_fixtures[layout + std::to_string(n)];
  if (f) return *f;
  f = std::make_unique<Fixture>();
  cube::scenes::SceneOptions o;
  o.n = n;
  o.layout = layout == "uniform" ? cube::scenes::Layout::uniform : cube::scenes::Layout::clustered;
  o.seed = 5;
  f->scene = cube::scenes::makeScene<S>(o);
  f->cube = std::make_unique<cube::CubeCollisionManager<S>>();
  f->cube->registerObjects(f->scene.pointers());
  // The checks, once: the walk against brute force, the two paths against each other.
  std::vector<Pair> walk;
  for (const auto& [a, b] : cube::overlappingPairs<S>(*f->cube)) walk.push_back(unordered(a, b));
  std::sort(walk.begin(), walk.end());
  cube::NarrowPhaseOptions<S> serial, split;
  serial.threads = split.threads = kThreads;
  split.split_walk = true;
  fcl::CollisionRequest<S> req(std::size_t(1) << 30, true);
  if (walk != brutePairs(f->scene.pointers())) {
    f->ok = false;
    f->message = "the walk's pairs differ from brute force";
  } else if (!sameContacts(cube::collideAll<S>(*f->cube, req, split),
                           cube::collideAll<S>(*f->cube, req, serial))) {
    f->ok = false;
    f->message = "split and serial walks give different contacts";
  }
  return *f;
}

enum class Path { walk, serial, split };

void run(benchmark::State& state, const std::string& layout, std::size_t n, Path path) {
  Fixture& f = fixture(layout, n);
  if (!f.ok) {
    g_extra_failed = true;
    state.SkipWithError(f.message.c_str());
    return;
  }
  cube::NarrowPhaseOptions<S> opt;
  opt.threads = kThreads;
  opt.split_walk = path == Path::split;
  const fcl::CollisionRequest<S> req(std::size_t(1) << 30, true);
  std::size_t count = 0;
  double total = 0;
  std::int64_t runs = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    if (path == Path::walk)
      count = cube::overlappingPairs<S>(*f.cube).size();
    else
      count = cube::collideAll<S>(*f.cube, req, opt).numContacts();
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    state.SetIterationTime(s);
    total += s;
    ++runs;
  }
  const char* name = path == Path::walk ? "walk" : path == Path::serial ? "serial" : "split";
  f.seconds[name] = total / double(std::max<std::int64_t>(runs, 1));
  state.counters[path == Path::walk ? "pairs" : "contacts"] = double(count);
  if (path == Path::split && f.seconds.count("serial"))
    state.counters["speedup"] = f.seconds["serial"] / f.seconds["split"];
  if (path == Path::walk && f.seconds.count("serial"))
    state.counters["walk_share_of_serial"] = f.seconds["walk"] / f.seconds["serial"];
}

void registerSplitWalk() {
  for (const char* layout : {"uniform", "clustered"})
    for (std::size_t n : {std::size_t(1000), std::size_t(10000), std::size_t(100000)})
      for (Path p : {Path::serial, Path::split, Path::walk}) {
        const std::string path = p == Path::walk     ? "serial_walk_only"
                                 : p == Path::serial ? "collideAll_serial_walk_t2"
                                                     : "collideAll_split_walk_t2";
        benchmark::RegisterBenchmark(
            ("splitwalk/" + std::string(layout) + "/" + std::to_string(n) + "/" + path).c_str(),
            [layout = std::string(layout), n, p](benchmark::State& s) { run(s, layout, n, p); })
            ->Unit(benchmark::kMillisecond)
            ->UseManualTime();
      }
}

// Registered at start-up like BENCHMARK(); the scenes are built on first use only.
const bool registered = (registerSplitWalk(), true);

}  // namespace
