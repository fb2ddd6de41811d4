// cube_rebuild_probe: what a refit costs the walks against a rebuild, after every object of a
// scene moved once. The calibration of the rebuild prediction (docs/tuning.md, Rebuild or refit;
// the generated table in benchmarks/README.md).
//
//   cube_rebuild_probe [--json out.json] [--quick]
//
// Per scene: a manager that only refits (UpdatePolicy::refit) is built, every object moves once
// (by up to its typical size, or turned by up to 10 degrees about a random axis through the
// centre, as FCL's update program turns its objects about the origin's axes), and the manager's
// update() refits. A second manager is then built on the
// moved objects. Printed: the refitted tree's quality and the first build's room (the leaves'
// surface area over their objects'), the update() that refits, the self-collide of each tree (best
// of several), the second build's time, the loss the library predicts for a walk
// (RebuildPolicy::staleCost) and the one measured ((refitted / rebuilt - 1) x self-collide /
// build), and the box tests of object queries of a sample of the objects (every objects/256-th) on
// the first tree before and after the motion and on the second. Both trees must report the pairs
// FCL's NaiveCollisionManager reports (up to 10,000 objects; the two trees the same pairs beyond),
// exit status 1 otherwise. --quick: 1,000 objects a scene and one timing each, for the test suite.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/rebuild_policy.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/inspect.h"
#include "cube_collision/query_stats.h"
#include "scenes.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Manager = cube::CubeCollisionManager<S>;
using Clock = std::chrono::steady_clock;
namespace scenes = cube::scenes;

bool countPair(Object*, Object*, void* data) {
  ++*static_cast<std::size_t*>(data);
  return false;
}

double microseconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// The best of `reps` self-collides; the pairs into *pairs.
double walkTime(const Manager& m, int reps, std::size_t* pairs) {
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    std::size_t c = 0;
    const auto t0 = Clock::now();
    m.collide(&c, countPair);
    best = std::min(best, microseconds(t0, Clock::now()));
    *pairs = c;
  }
  return best;
}

// Box tests of the object queries of every `step`-th object against the manager.
std::size_t sampledTests(const Manager& m, const std::vector<Object*>& objs, std::size_t step) {
  cube::QueryStats st;
  std::size_t c = 0;
  for (std::size_t i = 0; i < objs.size(); i += step) m.collide(objs[i], &c, countPair, &st);
  return st.box_tests;
}

double boxArea(const cube::BoundingBox& b) {
  const double dx = b.second[0] - b.first[0], dy = b.second[1] - b.first[1],
               dz = b.second[2] - b.first[2];
  return 2 * (dx * dy + dy * dz + dz * dx);
}

// The leaves' surface area over their objects' boxes', as the build measures it (1 if the
// objects have none).
double roomOf(const Manager& m) {
  const cube::HierarchyView<S> view(m);
  std::vector<cube::BoundingBox> cubes;
  view.getBoundingTree(cubes);
  double leaves = 0, objects = 0;
  for (int i = 0; i < view.getNumberCells(); ++i)
    if (view.isLeaf(i)) leaves += boxArea(cubes[std::size_t(i)]);
  for (std::size_t k = 0; k < view.objects().size(); ++k)
    objects += boxArea(view.objectBox(int(k)));
  return objects > 0 ? leaves / objects : 1.0;
}

// Every object turned by up to `degrees` about a random axis through the origin.
void turnAboutCentre(std::vector<Object*>& objs, double degrees, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> axis(0, 1);
  const double most = degrees * 3.141592653589793 / 180;
  std::uniform_real_distribution<double> angle(-most, most);
  for (Object* o : objs) {
    fcl::Vector3<S> a(axis(rng), axis(rng), axis(rng));
    a.normalize();
    const fcl::Transform3<S> turn(fcl::AngleAxis<S>(angle(rng), a));
    o->setTransform(turn * o->getTransform());
    o->computeAABB();
  }
}

struct Case {
  const char* name;
  scenes::Layout layout;
  double overlaps;
  bool large;  // 100,000 objects rather than 10,000 (both 1,000 with --quick)
  bool turn;
};

}  // namespace

int main(int argc, char** argv) {
  std::string json;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0 && i + 1 < argc) {
      json = argv[++i];
    } else if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: cube_rebuild_probe [--json out.json] [--quick]\n");
      return 2;
    }
  }
  const std::size_t small = quick ? 1000 : 10000, large = quick ? 1000 : 100000;
  const int walk_reps = quick ? 1 : 7, build_reps = quick ? 1 : 5;
  const Case cases[] = {
      {"uniform, 0.25 overlaps an object", scenes::Layout::uniform, 0.25, false, false},
      {"uniform, 1 overlap", scenes::Layout::uniform, 1, false, false},
      {"uniform, 4 overlaps", scenes::Layout::uniform, 4, false, false},
      {"uniform, 1 overlap", scenes::Layout::uniform, 1, true, false},
      {"thin rods, 0.25 overlaps", scenes::Layout::thin, 0.25, false, false},
      {"thin rods, 1 overlap", scenes::Layout::thin, 1, false, false},
      {"thin rods, 4 overlaps", scenes::Layout::thin, 4, false, false},
      {"uniform, 1 overlap, turned about the centre", scenes::Layout::uniform, 1, false, true},
      {"clustered, 0.25 overlaps", scenes::Layout::clustered, 0.25, false, false},
      {"clustered, 1 overlap", scenes::Layout::clustered, 1, false, false},
      {"clustered, 4 overlaps", scenes::Layout::clustered, 4, false, false},
      {"clustered, 1 overlap", scenes::Layout::clustered, 1, true, false},
  };
  std::string out = "{\n  \"scenes\": [\n";
  bool agree = true;
  std::printf("%-45s %8s %6s %6s %8s %8s %8s %8s %7s %7s %9s %9s %9s\n", "scene", "objects", "q",
              "room", "update", "refitted", "rebuilt", "build", "pred", "meas", "samp_bef",
              "samp_aft", "samp_reb");
  // Builds are timed on memory the process already holds: freed blocks stay in the heap, and one
  // build first brings it to size. Fresh pages fault in one by one (about 10 us a page on the
  // machine of the kept run), which would make a build's time depend on what the allocator
  // happened to return to the system before it.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  {
    scenes::SceneOptions o;
    o.n = large;
    const auto scene = scenes::makeScene<S>(o);
    Manager warm;
    warm.registerObjects(scene.pointers());
    warm.setup();
  }
  for (std::size_t ci = 0; ci < sizeof(cases) / sizeof(cases[0]); ++ci) {
    const Case& c = cases[ci];
    scenes::SceneOptions o;
    o.n = c.large ? large : small;
    o.layout = c.layout;
    o.overlaps_per_object = c.overlaps;
    auto scene = scenes::makeScene<S>(o);
    auto objs = scene.pointers();
    cube::Config refit_only;
    refit_only.update_policy = cube::UpdatePolicy::refit;
    Manager a(refit_only);
    a.registerObjects(objs);
    a.setup();
    const double room = roomOf(a);
    const std::size_t step = std::max<std::size_t>(1, objs.size() / 256);
    const std::size_t samp_before = sampledTests(a, objs, step);
    if (c.turn)
      turnAboutCentre(objs, 10, 7);
    else
      scenes::jitter(scene, 1.0, scenes::typicalSize(o), false, 7);
    const auto u0 = Clock::now();
    a.update();
    const double refit = microseconds(u0, Clock::now());
    const double q = cube::HierarchyView<S>(a).stats().quality_ratio;
    std::size_t pairs_refit = 0, pairs_rebuilt = 0;
    const double walk_refit = walkTime(a, walk_reps, &pairs_refit);
    const std::size_t samp_after = sampledTests(a, objs, step);
    std::unique_ptr<Manager> b;
    double build = 1e300;
    // Each build while the last one's manager lives, as a rebuild makes its cubes while the old
    // ones are still allocated.
    for (int r = 0; r < build_reps; ++r) {
      b = std::make_unique<Manager>();
      const auto t0 = Clock::now();
      b->registerObjects(objs);
      b->setup();
      build = std::min(build, microseconds(t0, Clock::now()));
    }
    const double walk_rebuilt = walkTime(*b, walk_reps, &pairs_rebuilt);
    const std::size_t samp_rebuilt = sampledTests(*b, objs, step);
    const double predicted = cube::detail::RebuildPolicy::staleCost(q, room);
    const double measured = (walk_refit / walk_rebuilt - 1) * walk_rebuilt / build;
    std::size_t pairs_naive = pairs_rebuilt;
    if (objs.size() <= 10000) {  // the oracle, where its quadratic walk is affordable
      fcl::NaiveCollisionManager<S> naive;
      naive.registerObjects(objs);
      naive.setup();
      pairs_naive = 0;
      naive.collide(&pairs_naive, countPair);
    }
    if (pairs_refit != pairs_rebuilt || pairs_rebuilt != pairs_naive) {
      agree = false;
      std::fprintf(stderr, "%s: %zu pairs refitted, %zu rebuilt, %zu by brute force\n", c.name,
                   pairs_refit, pairs_rebuilt, pairs_naive);
    }
    std::printf("%-45s %8zu %6.2f %6.2f %8.0f %8.0f %8.0f %8.0f %7.3f %7.3f %9zu %9zu %9zu\n",
                c.name, objs.size(), q, room, refit, walk_refit, walk_rebuilt, build, predicted,
                measured, samp_before, samp_after, samp_rebuilt);
    char line[1024];
    std::snprintf(line, sizeof(line),
                  "    {\"scene\": \"%s\", \"objects\": %zu, \"quality\": %.6g, \"room\": %.6g, "
                  "\"update_us\": %.6g, \"walk_refitted_us\": %.6g, \"walk_rebuilt_us\": %.6g, "
                  "\"build_us\": %.6g, "
                  "\"predicted_loss\": %.6g, \"measured_loss\": %.6g, \"pairs\": %zu, "
                  "\"sample_queries\": %zu, \"sample_tests_before\": %zu, "
                  "\"sample_tests_after\": %zu, \"sample_tests_rebuilt\": %zu}%s\n",
                  c.name, objs.size(), q, room, refit, walk_refit, walk_rebuilt, build, predicted,
                  measured, pairs_refit, (objs.size() + step - 1) / step, samp_before, samp_after,
                  samp_rebuilt, ci + 1 < sizeof(cases) / sizeof(cases[0]) ? "," : "");
    out += line;
    std::fflush(stdout);
  }
  out += "  ]\n}\n";
  if (!json.empty()) {
    FILE* f = std::fopen(json.c_str(), "w");
    if (f == nullptr) {
      std::perror(json.c_str());
      return 2;
    }
    std::fputs(out.c_str(), f);
    std::fclose(f);
  }
  return agree ? 0 : 1;
}
