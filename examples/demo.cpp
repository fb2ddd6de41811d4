// The demo: the same queries on the same random world with cube::CubeCollisionManager and with
// fcl::DynamicAABBTreeCollisionManager, side by side. Prints what each found and how long it
// took; exits with status 1 if any result differs.
//
// Usage: demo [object count]   (default 10000)

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace {

using Object = fcl::CollisionObjectd;
using Manager = fcl::BroadPhaseCollisionManagerd;
using Pair = std::pair<Object*, Object*>;

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// The default narrow-phase callback, asked for every contact, noting which pairs collide so that
// the two managers can be compared pair by pair (their call orders differ).
struct Recorder {
  cube::CollisionData<double> data;
  std::vector<Pair> colliding;
  Recorder() { data.request.num_max_contacts = std::numeric_limits<std::size_t>::max(); }
  static bool callback(Object* a, Object* b, void* self) {
    auto& r = *static_cast<Recorder*>(self);
    const auto before = r.data.result.numContacts();
    const bool stop = cube::defaultCollisionCallback<double>(a, b, &r.data);
    if (r.data.result.numContacts() > before)
      r.colliding.emplace_back(std::min(a, b), std::max(a, b));
    return stop;
  }
  std::vector<Pair> sorted() const {
    auto out = colliding;
    std::sort(out.begin(), out.end());
    return out;
  }
};

struct Row {
  explicit Row(std::string op) : operation(std::move(op)) {}
  std::string operation;
  std::string cube_result, fcl_result;
  double cube_ms = 0, fcl_ms = 0;
  bool same = true;
};

template <class F>
double timed(F&& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  return msSince(start);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t n = 10000;
  if (argc > 1) {
    char* end = nullptr;
    const long v = std::strtol(argv[1], &end, 10);
    if (*end != '\0' || v < 2) {
      std::fprintf(stderr, "usage: %s [object count >= 2]\n", argv[0]);
      return 2;
    }
    n = static_cast<std::size_t>(v);
  }
  const std::size_t n_queries = std::min<std::size_t>(1000, n);

  // The world: boxes, spheres and cylinders in random poses, each overlapping about one other.
  cube::scenes::SceneOptions world_options;
  world_options.n = n;
  world_options.seed = 1;
  const auto world = cube::scenes::makeScene<double>(world_options);
  auto query_options = world_options;
  query_options.n = n_queries;
  query_options.seed = 2;
  const auto queries = cube::scenes::makeScene<double>(query_options);
  // A sparser copy (objects a fiftieth of the size) where nothing touches, for distance.
  auto sparse_options = world_options;
  sparse_options.seed = 3;
  sparse_options.size_scale = 0.02;
  const auto sparse = cube::scenes::makeScene<double>(sparse_options);

  std::printf("cube-collision demo: %zu objects, %zu query objects\n\n", n, n_queries);

  cube::CubeCollisionManagerd cube_world, cube_sparse;
  fcl::DynamicAABBTreeCollisionManagerd fcl_world, fcl_sparse;
  Manager* managers[2] = {&cube_world, &fcl_world};
  Manager* sparse_managers[2] = {&cube_sparse, &fcl_sparse};
  std::vector<Row> rows;

  {
    Row row("register + setup");
    double ms[2];
    for (int m = 0; m < 2; ++m)
      ms[m] = timed([&] {
        managers[m]->registerObjects(world.pointers());
        managers[m]->setup();
        sparse_managers[m]->registerObjects(sparse.pointers());
        sparse_managers[m]->setup();
      });
    row.cube_result = std::to_string(cube_world.size() + cube_sparse.size()) + " objects";
    row.fcl_result = std::to_string(fcl_world.size() + fcl_sparse.size()) + " objects";
    row.same = cube_world.size() == fcl_world.size() && cube_sparse.size() == fcl_sparse.size();
    row.cube_ms = ms[0];
    row.fcl_ms = ms[1];
    rows.push_back(row);
  }
  {
    Row row("self-collide");
    Recorder rec[2];
    double ms[2];
    for (int m = 0; m < 2; ++m)
      ms[m] = timed([&] { managers[m]->collide(&rec[m], &Recorder::callback); });
    row.cube_result = std::to_string(rec[0].colliding.size()) + " pairs";
    row.fcl_result = std::to_string(rec[1].colliding.size()) + " pairs";
    row.same = rec[0].sorted() == rec[1].sorted() &&
               rec[0].data.result.numContacts() == rec[1].data.result.numContacts();
    row.cube_ms = ms[0];
    row.fcl_ms = ms[1];
    rows.push_back(row);
  }
  {
    Row row(std::to_string(n_queries) + " object queries");
    Recorder rec[2];
    double ms[2];
    for (int m = 0; m < 2; ++m)
      ms[m] = timed([&] {
        for (auto* q : queries.pointers()) managers[m]->collide(q, &rec[m], &Recorder::callback);
      });
    row.cube_result = std::to_string(rec[0].colliding.size()) + " pairs";
    row.fcl_result = std::to_string(rec[1].colliding.size()) + " pairs";
    row.same = rec[0].sorted() == rec[1].sorted() &&
               rec[0].data.result.numContacts() == rec[1].data.result.numContacts();
    row.cube_ms = ms[0];
    row.fcl_ms = ms[1];
    rows.push_back(row);
  }
  {
    Row row("self distance (sparse)");
    cube::DistanceData<double> data[2];
    double ms[2];
    for (int m = 0; m < 2; ++m)
      ms[m] = timed(
          [&] { sparse_managers[m]->distance(&data[m], &cube::defaultDistanceCallback<double>); });
    const double a = data[0].result.min_distance, b = data[1].result.min_distance;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", a);
    row.cube_result = buf;
    std::snprintf(buf, sizeof buf, "%.6f", b);
    row.fcl_result = buf;
    row.same = std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(b));
    row.cube_ms = ms[0];
    row.fcl_ms = ms[1];
    rows.push_back(row);
  }

  std::printf("%-24s %-16s %-16s %12s %12s  %s\n", "operation", "cube", "fcl DynamicAABB",
              "cube ms", "fcl ms", "same");
  bool all_same = true;
  for (const auto& r : rows) {
    std::printf("%-24s %-16s %-16s %12.2f %12.2f  %s\n", r.operation.c_str(), r.cube_result.c_str(),
                r.fcl_result.c_str(), r.cube_ms, r.fcl_ms, r.same ? "yes" : "NO");
    all_same = all_same && r.same;
  }
  std::printf("\n%s\n", all_same ? "All results identical to FCL's."
                                 : "MISMATCH: the cube manager disagrees with FCL.");
  return all_same ? 0 : 1;
}
