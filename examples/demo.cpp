// The demo: the same queries on the same random world three ways, each with FCL's narrow phase.
//   fcl       fcl::DynamicAABBTreeCollisionManager with FCL's default callbacks;
//   drop-in   cube::CubeCollisionManager with the same FCL callbacks (one line changed);
//   pipeline  cube::collideAll / cube::minimumDistance on the cube manager, default options
//             (culling by tight volumes, contacts of touching primitives proved without FCL,
//             the hardware's threads where they pay).
// Prints what each found, how long it took and the ratios to FCL; exits with status 1 if any
// answer differs from FCL's.
//
// Usage: demo [object count]   (default 10000)

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

namespace {

using Object = fcl::CollisionObjectd;
using Manager = fcl::BroadPhaseCollisionManagerd;
using GeometryPair = std::pair<const fcl::CollisionGeometryd*, const fcl::CollisionGeometryd*>;

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

template <class F>
double timed(F&& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  return msSince(start);
}

// The pairs a result's contacts name (each object has a geometry of its own in these scenes),
// unordered and sorted: the three ways call FCL in different orders.
std::vector<GeometryPair> pairsOf(const fcl::CollisionResultd& r) {
  std::vector<GeometryPair> out;
  for (std::size_t k = 0; k < r.numContacts(); ++k) {
    const auto& c = r.getContact(k);
    out.emplace_back(std::min(c.o1, c.o2), std::max(c.o1, c.o2));
  }
  std::sort(out.begin(), out.end());
  return out;
}

// FCL's default request asks for one contact; the demo asks for every contact, so that the
// whole narrow phase runs and the answers can be compared pair by pair.
fcl::CollisionRequestd everyContact() {
  fcl::CollisionRequestd r;
  r.num_max_contacts = std::numeric_limits<int>::max();
  return r;
}

// Manager self-collide / object query / distance with FCL's default callbacks.
fcl::CollisionResultd fclCollide(const Manager& m) {
  fcl::DefaultCollisionData<double> d;
  d.request = everyContact();
  m.collide(&d, fcl::DefaultCollisionFunction<double>);
  return d.result;
}
fcl::CollisionResultd fclCollide(const Manager& m, Object* q) {
  fcl::DefaultCollisionData<double> d;
  d.request = everyContact();
  m.collide(q, &d, fcl::DefaultCollisionFunction<double>);
  return d.result;
}
double fclDistance(const Manager& m) {
  fcl::DefaultDistanceData<double> d;
  m.distance(&d, fcl::DefaultDistanceFunction<double>);
  return d.result.min_distance;
}
double fclDistance(const Manager& m, Object* q) {
  fcl::DefaultDistanceData<double> d;
  m.distance(q, &d, fcl::DefaultDistanceFunction<double>);
  return d.result.min_distance;
}

bool sameDistance(double a, double b) {
  return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(b));
}

struct Row {
  std::string operation, answer;
  double ms[3] = {0, 0, 0};  // fcl, drop-in, pipeline
  bool same = true;
};

std::string ratio(double fcl_ms, double ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2fx", ms > 0 ? fcl_ms / ms : 0.0);
  return buf;
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
  const std::size_t n_distance = std::min<std::size_t>(100, n);

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
  auto probe_options = sparse_options;
  probe_options.n = n_distance;
  probe_options.seed = 4;
  const auto probes = cube::scenes::makeScene<double>(probe_options);

  std::printf("cube-collision demo: %zu objects, %zu query objects, %d threads\n\n", n, n_queries,
              cube::hardwareThreads());

  cube::CubeCollisionManagerd cube_world, cube_sparse;
  fcl::DynamicAABBTreeCollisionManagerd fcl_world, fcl_sparse;
  std::vector<Row> rows;

  {
    Row row{"register + setup", ""};
    row.ms[0] = timed([&] {
      fcl_world.registerObjects(world.pointers());
      fcl_world.setup();
      fcl_sparse.registerObjects(sparse.pointers());
      fcl_sparse.setup();
    });
    row.ms[1] = row.ms[2] = timed([&] {
      cube_world.registerObjects(world.pointers());
      cube_world.setup();
      cube_sparse.registerObjects(sparse.pointers());
      cube_sparse.setup();
    });
    row.answer = std::to_string(cube_world.size() + cube_sparse.size()) + " objects";
    row.same = cube_world.size() == fcl_world.size() && cube_sparse.size() == fcl_sparse.size();
    rows.push_back(row);
  }
  {
    Row row{"self-collide", ""};
    fcl::CollisionResultd r[3];
    row.ms[0] = timed([&] { r[0] = fclCollide(fcl_world); });
    row.ms[1] = timed([&] { r[1] = fclCollide(cube_world); });
    row.ms[2] = timed([&] { r[2] = cube::collideAll<double>(cube_world, everyContact()); });
    row.answer = std::to_string(r[0].numContacts()) + " contacts";
    row.same = pairsOf(r[1]) == pairsOf(r[0]) && pairsOf(r[2]) == pairsOf(r[0]);
    rows.push_back(row);
  }
  {
    Row row{std::to_string(n_queries) + " object queries", ""};
    std::vector<GeometryPair> found[3];
    const auto gather = [&](int way, const fcl::CollisionResultd& r) {
      const auto p = pairsOf(r);
      found[way].insert(found[way].end(), p.begin(), p.end());
    };
    row.ms[0] = timed([&] {
      for (Object* q : queries.pointers()) gather(0, fclCollide(fcl_world, q));
    });
    row.ms[1] = timed([&] {
      for (Object* q : queries.pointers()) gather(1, fclCollide(cube_world, q));
    });
    row.ms[2] = timed([&] {
      for (Object* q : queries.pointers())
        gather(2, cube::collideAll<double>(cube_world, q, everyContact()));
    });
    row.answer = std::to_string(found[0].size()) + " contacts";
    row.same = found[1] == found[0] && found[2] == found[0];
    rows.push_back(row);
  }
  {
    Row row{"self distance (sparse)", ""};
    double d[3];
    row.ms[0] = timed([&] { d[0] = fclDistance(fcl_sparse); });
    row.ms[1] = timed([&] { d[1] = fclDistance(cube_sparse); });
    row.ms[2] = timed([&] { d[2] = cube::minimumDistance<double>(cube_sparse).min_distance; });
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", d[0]);
    row.answer = buf;
    row.same = sameDistance(d[1], d[0]) && sameDistance(d[2], d[0]);
    rows.push_back(row);
  }
  {
    Row row{std::to_string(n_distance) + " distance queries", ""};
    std::vector<double> d[3];
    row.ms[0] = timed([&] {
      for (Object* q : probes.pointers()) d[0].push_back(fclDistance(fcl_sparse, q));
    });
    row.ms[1] = timed([&] {
      for (Object* q : probes.pointers()) d[1].push_back(fclDistance(cube_sparse, q));
    });
    row.ms[2] = timed([&] {
      for (Object* q : probes.pointers())
        d[2].push_back(cube::minimumDistance<double>(cube_sparse, q).min_distance);
    });
    double sum = 0;
    for (std::size_t i = 0; i < d[0].size(); ++i) {
      sum += d[0][i];
      row.same = row.same && sameDistance(d[1][i], d[0][i]) && sameDistance(d[2][i], d[0][i]);
    }
    char buf[64];
    std::snprintf(buf, sizeof buf, "sum %.3f", sum);
    row.answer = buf;
    rows.push_back(row);
  }

  std::printf("%-22s %-16s %9s %9s %7s %9s %7s  %s\n", "operation", "answer", "fcl ms", "drop-in",
              "ratio", "pipeline", "ratio", "same");
  bool all_same = true;
  for (const auto& r : rows) {
    std::printf("%-22s %-16s %9.2f %9.2f %7s %9.2f %7s  %s\n", r.operation.c_str(),
                r.answer.c_str(), r.ms[0], r.ms[1], ratio(r.ms[0], r.ms[1]).c_str(), r.ms[2],
                ratio(r.ms[0], r.ms[2]).c_str(), r.same ? "yes" : "NO");
    all_same = all_same && r.same;
  }
  std::printf(
      "\nfcl: fcl::DynamicAABBTreeCollisionManager with FCL's default callbacks (every contact).\n"
      "drop-in: cube::CubeCollisionManager with the same FCL callbacks: one line changed, your\n"
      "  callbacks as they are; the broadphase is faster, FCL's narrow phase runs on every pair\n"
      "  whose boxes overlap. Use it where you keep your own callbacks.\n"
      "pipeline: cube::collideAll / cube::minimumDistance (queries.h) on the cube manager: the "
      "same\n"
      "  contacts and distances, with pairs proved apart (or, without contact geometry, touching)\n"
      "  by tight volumes kept per object before FCL, and the hardware's threads where FCL's\n"
      "  calls on meshes pay for them. Use it for FCL's default callbacks' answers.\n"
      "  Ratios: fcl ms / ms; one run, timings move between runs.\n");
  std::printf("\n%s\n", all_same ? "All results identical to FCL's."
                                 : "MISMATCH: the cube manager disagrees with FCL.");
  return all_same ? 0 : 1;
}
