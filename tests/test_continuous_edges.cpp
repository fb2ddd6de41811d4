// Continuous edges (cube_collision/batch.h, "Continuous edges"): checkMotion(s) with motion
// bounds against a fine subdivision of every edge (100 times its resolution, the poses
// interpolated in SE(3)) checked by brute force with fcl::collide, and against the documented
// rule (each state checked with its links' margins raised by half their motion bounds).

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/batch.h"
#include "support/mesh_box.h"

namespace {

using S = double;
using Object = fcl::CollisionObjectd;
using Geometry = std::shared_ptr<fcl::CollisionGeometryd>;
using meshbox::meshBox;
constexpr int kFine = 100;  // fine steps per interval of an edge

Geometry randomLinkShape(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.2, 0.7);
  switch (std::uniform_int_distribution<int>(0, 4)(rng)) {
    case 0:
      return std::make_shared<fcl::Boxd>(u(rng), u(rng), u(rng));
    case 1:
      return std::make_shared<fcl::Sphered>(0.5 * u(rng));
    case 2:
      return std::make_shared<fcl::Cylinderd>(0.3 * u(rng), u(rng));
    case 3:
      return std::make_shared<fcl::Capsuled>(0.25 * u(rng), u(rng));
    default:
      return meshBox(fcl::Vector3d(u(rng), 0.5 * u(rng), 0.5 * u(rng)), fcl::Vector3d(0.6, 0, 0));
  }
}

fcl::Quaterniond randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return fcl::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
}

struct World {
  std::vector<std::unique_ptr<Object>> objects;
  cube::CubeCollisionManagerd manager;
};

// Shapes in a cube of half-size 5, a third of them thin plates (0.02 thick) that a coarse edge
// steps over.
void fillWorld(World& w, std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> p(-5, 5), u(0.2, 0.8), plate(0.8, 2.0);
  for (std::size_t i = 0; i < n; ++i) {
    Geometry g;
    if (i % 3 == 0)
      g = std::make_shared<fcl::Boxd>(plate(rng), plate(rng), 0.02);
    else
      g = randomLinkShape(rng);
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = randomRotation(rng).toRotationMatrix();
    tf.translation() = fcl::Vector3d(p(rng), p(rng), p(rng));
    w.objects.push_back(std::make_unique<Object>(g, tf));
    w.objects.back()->computeAABB();
  }
  std::vector<Object*> ptrs;
  for (const auto& o : w.objects) ptrs.push_back(o.get());
  w.manager.registerObjects(ptrs);
  w.manager.setup();
}

cube::BodySet<S> randomBody(std::size_t links, std::uint32_t seed) {
  std::mt19937 rng(seed);
  cube::BodySet<S> body;
  for (std::size_t l = 0; l < links; ++l) body.addLink(randomLinkShape(rng));
  for (std::size_t l = 0; l + 1 < links; ++l) body.excludePair(l, l + 1);
  return body;
}

// Edges whose links each move from a random pose to another (up to 2.5 away, turning up to 1.5
// rad), in SE(3): translation linear, rotation along the geodesic.
struct Edge {
  std::vector<fcl::Vector3d> t0, t1;
  std::vector<fcl::Quaterniond> q0, q1;
  std::size_t states = 0;
  // Link l's pose at s in [0, 1] along the edge.
  fcl::Transform3d at(std::size_t l, double s) const {
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = q0[l].slerp(s, q1[l]).toRotationMatrix();
    tf.translation() = t0[l] + s * (t1[l] - t0[l]);
    return tf;
  }
  // The poses of its states (s = k / (states - 1)), or of `per` times as many intervals.
  std::vector<fcl::Transform3d> poses(std::size_t links, int per = 1) const {
    const std::size_t n = (states - 1) * per + 1;
    std::vector<fcl::Transform3d> out;
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t l = 0; l < links; ++l) out.push_back(at(l, double(k) / double(n - 1)));
    return out;
  }
};

std::vector<Edge> randomEdges(std::size_t count, std::size_t links, std::uint32_t seed,
                              std::size_t min_states = 2, std::size_t max_states = 8) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> p(-3.5, 3.5), step(-2.5, 2.5);
  std::uniform_real_distribution<double> turn(-0.75, 0.75);
  std::uniform_int_distribution<std::size_t> states(min_states, max_states);
  std::vector<Edge> edges(count);
  for (Edge& e : edges) {
    e.states = states(rng);
    const fcl::Vector3d base(p(rng), p(rng), p(rng));
    const fcl::Vector3d move(step(rng), step(rng), step(rng));
    for (std::size_t l = 0; l < links; ++l) {
      const fcl::Vector3d at = base + 0.6 * fcl::Vector3d(p(rng), p(rng), p(rng)) / 3.5;
      e.t0.push_back(at);
      e.t1.push_back(at + move + 0.3 * fcl::Vector3d(step(rng), step(rng), step(rng)));
      const fcl::Quaterniond q = randomRotation(rng);
      e.q0.push_back(q);
      e.q1.push_back(q * fcl::Quaterniond(Eigen::AngleAxisd(
                             turn(rng), fcl::Vector3d(turn(rng), turn(rng), 1).normalized())));
    }
  }
  return edges;
}

// Brute force: a contact (fcl::collide) of a link with a world object or, with `self`, of two
// checked links, in one state. AABBs first (FCL's own, conservative).
bool bruteContact(const World& w, const cube::BodySet<S>& body, const fcl::Transform3d* poses,
                  bool self) {
  std::vector<std::unique_ptr<Object>> links;
  for (std::size_t l = 0; l < body.size(); ++l) {
    links.push_back(std::make_unique<Object>(body.geometry(l), poses[l]));
    links.back()->computeAABB();
  }
  fcl::CollisionRequestd request;
  for (std::size_t l = 0; l < links.size(); ++l) {
    for (const auto& o : w.objects) {
      if (!links[l]->getAABB().overlap(o->getAABB())) continue;
      fcl::CollisionResultd result;
      if (fcl::collide(links[l].get(), o.get(), request, result) > 0) return true;
    }
    for (std::size_t j = l + 1; self && j < links.size(); ++j) {
      if (!body.checked(l, j) || !links[l]->getAABB().overlap(links[j]->getAABB())) continue;
      fcl::CollisionResultd result;
      if (fcl::collide(links[l].get(), links[j].get(), request, result) > 0) return true;
    }
  }
  return false;
}

// Whether the fine subdivision of an edge finds a contact.
bool fineContact(const World& w, const cube::BodySet<S>& body, const Edge& e, bool self) {
  const auto fine = e.poses(body.size(), kFine);
  for (std::size_t k = 0; k * body.size() < fine.size(); ++k)
    if (bruteContact(w, body, fine.data() + k * body.size(), self)) return true;
  return false;
}

// The test's own SE(3) bound of link l between two poses: translation plus angle times the
// farthest corner of the link's local AABB from its origin.
S se3Bound(const cube::BodySet<S>& body, std::size_t l, const fcl::Transform3d& a,
           const fcl::Transform3d& b) {
  const fcl::AABBd& box = body.geometry(l)->aabb_local;
  S reach = 0;
  for (int i = 0; i < 8; ++i) {
    const fcl::Vector3d c((i & 1 ? box.max_ : box.min_)[0], (i & 2 ? box.max_ : box.min_)[1],
                          (i & 4 ? box.max_ : box.min_)[2]);
    reach = std::max(reach, c.norm());
  }
  const S angle = fcl::Quaterniond(a.linear()).angularDistance(fcl::Quaterniond(b.linear()));
  return (b.translation() - a.translation()).norm() + angle * reach;
}

// Bounds laid out as batch.h says: [k * links + l] from state k to k + 1 of an edge, `scale` (>= 1)
// times the SE(3) bound; 0 for an edge's last state.
std::vector<S> se3Bounds(const cube::BodySet<S>& body, const std::vector<fcl::Transform3d>& poses,
                         const std::vector<std::size_t>& starts, S scale) {
  const std::size_t n = body.size(), states = poses.size() / n;
  std::vector<S> out(poses.size(), 0);
  for (std::size_t e = 0; e < starts.size(); ++e) {
    const std::size_t end = e + 1 < starts.size() ? starts[e + 1] : states;
    for (std::size_t k = starts[e]; k + 1 < end; ++k)
      for (std::size_t l = 0; l < n; ++l)
        out[k * n + l] = scale * se3Bound(body, l, poses[k * n + l], poses[(k + 1) * n + l]);
  }
  return out;
}

// The documented rule by brute force: the first state in `order` (OMPL's bisection: last, then
// middles breadth first) whose check with each link's margin raised by half the larger bound of
// its two intervals fails (contact, or fcl::distance within the raised margins).
// The states of an edge in `order`.
std::vector<std::size_t> visitingOrder(std::size_t states, cube::MotionOrder order) {
  std::vector<std::size_t> visit;
  if (order == cube::MotionOrder::path || states < 2) {
    for (std::size_t k = 0; k < states; ++k) visit.push_back(k);
  } else {
    visit.push_back(states - 1);
    std::deque<std::pair<std::size_t, std::size_t>> open{{0, states - 2}};
    while (!open.empty()) {
      const auto [lo, hi] = open.front();
      open.pop_front();
      const std::size_t mid = lo + (hi - lo) / 2;
      visit.push_back(mid);
      if (mid > lo) open.emplace_back(lo, mid - 1);
      if (mid < hi) open.emplace_back(mid + 1, hi);
    }
  }
  return visit;
}

std::size_t ruleAnswer(const World& w, const cube::BodySet<S>& body, const fcl::Transform3d* poses,
                       const S* bounds, std::size_t states, cube::MotionOrder order, bool self) {
  const std::size_t n = body.size();
  for (const std::size_t k : visitingOrder(states, order)) {
    std::vector<S> raise(n, 0);
    for (std::size_t l = 0; l < n; ++l) {
      if (k > 0) raise[l] = std::max(raise[l], bounds[(k - 1) * n + l] / 2);
      if (k + 1 < states) raise[l] = std::max(raise[l], bounds[k * n + l] / 2);
    }
    std::vector<std::unique_ptr<Object>> links;
    for (std::size_t l = 0; l < n; ++l)
      links.push_back(std::make_unique<Object>(body.geometry(l), poses[k * n + l]));
    const auto touch = [](const Object& a, const Object& b, S m) {
      fcl::CollisionRequestd cr;
      fcl::CollisionResultd cres;
      if (fcl::collide(&a, &b, cr, cres) > 0) return true;
      fcl::DistanceRequestd dr;
      fcl::DistanceResultd dres;
      return m > 0 && fcl::distance(&a, &b, dr, dres) <= m;
    };
    for (std::size_t l = 0; l < n; ++l) {
      for (const auto& o : w.objects)
        if (touch(*links[l], *o, raise[l])) return k;
      for (std::size_t j = l + 1; self && j < n; ++j)
        if (body.checked(l, j) && touch(*links[l], *links[j], raise[l] + raise[j])) return k;
    }
  }
  return cube::kNoIndex;
}

struct Tally {
  std::size_t edges = 0, fine_hits = 0, continuous_hits = 0, extra_hits = 0, discrete_misses = 0;
};

// One scene's edges: the SE(3) option and the caller's bounds never report free where the fine
// subdivision finds a contact, and answer as the documented rule.
void checkScene(std::uint32_t seed, bool self, cube::MotionOrder order, Tally& tally) {
  World w;
  fillWorld(w, 40, seed);
  const cube::BodySet<S> body = randomBody(5, seed + 1);
  const std::size_t n = body.size();
  const std::vector<Edge> edges = randomEdges(100, n, seed + 2);
  cube::BatchOptions discrete;
  discrete.self_collision = self;
  discrete.threads = 1;
  cube::BatchOptions continuous = discrete;
  continuous.continuous = true;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge& e = edges[i];
    const auto poses = e.poses(n);
    const std::vector<S> bounds = se3Bounds(body, poses, {0}, 1);
    const std::vector<S> loose = se3Bounds(body, poses, {0}, 1.5);
    const std::size_t se3 = cube::checkMotion(w.manager, body, poses, order, continuous);
    const std::size_t given = cube::checkMotion(w.manager, body, poses, bounds, order, discrete);
    const std::size_t looser = cube::checkMotion(w.manager, body, poses, loose, order, discrete);
    const std::size_t plain = cube::checkMotion(w.manager, body, poses, order, discrete);
    const bool fine = fineContact(w, body, e, self);
    SCOPED_TRACE("seed " + std::to_string(seed) + " edge " + std::to_string(i));
    if (fine) {
      EXPECT_NE(se3, cube::kNoIndex);
      EXPECT_NE(given, cube::kNoIndex);
      EXPECT_NE(looser, cube::kNoIndex);
    }
    EXPECT_EQ(se3, ruleAnswer(w, body, poses.data(), bounds.data(), e.states, order, self));
    EXPECT_EQ(looser, ruleAnswer(w, body, poses.data(), loose.data(), e.states, order, self));
    EXPECT_EQ(given, se3);
    // The pose function overload with the same bounds: the same answer.
    const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
      std::copy(poses.begin() + k * n, poses.begin() + (k + 1) * n, out);
    };
    EXPECT_EQ(cube::checkMotion(w.manager, body, e.states, pose_of, bounds, order, discrete), se3);
    ++tally.edges;
    tally.fine_hits += fine;
    tally.continuous_hits += se3 != cube::kNoIndex;
    tally.extra_hits += se3 != cube::kNoIndex && !fine;
    tally.discrete_misses += plain == cube::kNoIndex && fine;
  }
}

void print(const char* what, const Tally& t) {
  std::printf(
      "[ continuous edges, %s ] %zu edges: fine subdivision finds %zu in contact; continuous "
      "reports %zu (%zu with no contact found: %.1f%% of the edges the fine subdivision finds "
      "free); the discrete check misses %zu\n",
      what, t.edges, t.fine_hits, t.continuous_hits, t.extra_hits,
      t.edges > t.fine_hits ? 100.0 * double(t.extra_hits) / double(t.edges - t.fine_hits) : 0.0,
      t.discrete_misses);
}

TEST(ContinuousEdges, NeverFreeWhereAFineSubdivisionFindsAContact) {
  Tally tally;
  for (const std::uint32_t seed : {11u, 23u, 37u})
    checkScene(seed, false, cube::MotionOrder::path, tally);
  print("world", tally);
  // The scenes hold edges that a discrete check steps over: the property is not vacuous.
  EXPECT_GT(tally.discrete_misses, 0u);
  EXPECT_GT(tally.fine_hits, tally.edges / 10);
}

TEST(ContinuousEdges, SelfPairsAndBisectionOrderNeverMissAContact) {
  Tally tally;
  for (const std::uint32_t seed : {5u, 71u})
    checkScene(seed, true, cube::MotionOrder::bisection, tally);
  print("world and self pairs", tally);
  EXPECT_GT(tally.discrete_misses, 0u);
}

// Edges of many close states (checked in runs that share the world's walk): the documented rule,
// and nothing the fine subdivision finds is reported free.
TEST(ContinuousEdges, LongEdgesAnswerAsTheRule) {
  World w;
  fillWorld(w, 40, 61);
  const cube::BodySet<S> body = randomBody(5, 62);
  const std::size_t n = body.size();
  std::size_t colliding = 0;
  const std::vector<Edge> edges = randomEdges(24, n, 63, 30, 60);
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge& e = edges[i];
    const auto poses = e.poses(n);
    const std::vector<S> bounds = se3Bounds(body, poses, {0}, 1);
    for (const cube::MotionOrder order : {cube::MotionOrder::path, cube::MotionOrder::bisection})
      for (const bool self : {false, true}) {
        cube::BatchOptions o;
        o.self_collision = self;
        o.continuous = true;
        const std::size_t got = cube::checkMotion(w.manager, body, poses, order, o);
        EXPECT_EQ(got, ruleAnswer(w, body, poses.data(), bounds.data(), e.states, order, self))
            << "edge " << i;
        colliding += got != cube::kNoIndex;
        if (order == cube::MotionOrder::path && got == cube::kNoIndex) {
          EXPECT_FALSE(fineContact(w, body, e, self)) << "edge " << i;
        }
      }
  }
  EXPECT_GT(colliding, 0u);
  EXPECT_LT(colliding, 4 * edges.size());
}

// Many edges in one call: the same answers on one thread and two, and as edge by edge.
TEST(ContinuousEdges, ThreadCountsGiveTheSameAnswers) {
  World w;
  fillWorld(w, 60, 91);
  const cube::BodySet<S> body = randomBody(5, 92);
  const std::size_t n = body.size();
  const std::vector<Edge> edges = randomEdges(150, n, 93);
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
  for (const Edge& e : edges) {
    starts.push_back(poses.size() / n);
    const auto p = e.poses(n);
    poses.insert(poses.end(), p.begin(), p.end());
  }
  const std::vector<S> bounds = se3Bounds(body, poses, starts, 1);
  for (const cube::MotionOrder order : {cube::MotionOrder::path, cube::MotionOrder::bisection}) {
    for (const bool self : {false, true}) {
      cube::BatchOptions o;
      o.self_collision = self;
      o.continuous = true;
      o.threads = 1;
      const auto one = cube::checkMotions(w.manager, body, poses, starts, order, o);
      const auto given_one = cube::checkMotions(w.manager, body, poses, starts, bounds, order, o);
      o.threads = 2;
      const auto two = cube::checkMotions(w.manager, body, poses, starts, order, o);
      const auto given_two = cube::checkMotions(w.manager, body, poses, starts, bounds, order, o);
      EXPECT_EQ(one, two);
      EXPECT_EQ(given_one, given_two);
      EXPECT_EQ(one, given_one);
      // The pose function overload with the same bounds, on one and two threads: the same
      // answers, and no state after an edge's answer in its order is computed on one thread
      // beyond its run (at most max(5, 2 r + 3) of an edge answered at place r).
      const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
        std::copy(poses.begin() + k * n, poses.begin() + (k + 1) * n, out);
      };
      const std::size_t states = poses.size() / n;
      for (const int threads : {1, 2, 3}) {
        o.threads = threads;
        EXPECT_EQ(cube::checkMotions(w.manager, body, states, starts, pose_of, bounds, order, o),
                  one);
        // Without bounds: the SE(3) bounds from the poses pose_of writes, neighbours included.
        EXPECT_EQ(cube::checkMotions(w.manager, body, states, starts, pose_of, order, o), one);
      }
      std::vector<std::atomic<int>> computed(states);
      const cube::PoseFunction<S> counting = [&](std::size_t k, fcl::Transform3d* out) {
        ++computed[k];
        pose_of(k, out);
      };
      o.threads = 1;
      EXPECT_EQ(cube::checkMotions(w.manager, body, states, starts, counting, bounds, order, o),
                one);
      for (std::size_t e = 0; e < edges.size(); ++e) {
        const std::size_t begin = starts[e], end = begin + edges[e].states;
        std::size_t count = 0;
        for (std::size_t k = begin; k < end; ++k) {
          EXPECT_LE(computed[k].load(), 1);
          count += computed[k].load();
        }
        const std::vector<std::size_t> visit = visitingOrder(edges[e].states, order);
        const std::size_t place =
            one[e] == cube::kNoIndex
                ? visit.size()
                : std::size_t(std::find(visit.begin(), visit.end(), one[e]) - visit.begin());
        EXPECT_LE(count, std::max<std::size_t>(5, 2 * place + 3)) << "edge " << e;
      }
      // SE(3) bounds from the poses, one thread, path order: a state is written once, the
      // neighbour after a run being the next run's first state (one more past the last run).
      if (order == cube::MotionOrder::path) {
        for (auto& c : computed) c = 0;
        EXPECT_EQ(cube::checkMotions(w.manager, body, states, starts, counting, order, o), one);
        for (std::size_t e = 0; e < edges.size(); ++e) {
          const std::size_t begin = starts[e], end = begin + edges[e].states;
          std::size_t count = 0;
          for (std::size_t k = begin; k < end; ++k) {
            EXPECT_LE(computed[k].load(), 1) << "state " << k - begin << " of edge " << e;
            count += computed[k].load();
          }
          const std::size_t place = one[e] == cube::kNoIndex ? edges[e].states : one[e];
          EXPECT_LE(count, std::max<std::size_t>(5, 2 * place + 3) + 1) << "edge " << e;
        }
      }
      o.threads = 1;
      std::size_t colliding = 0;
      for (std::size_t e = 0; e < edges.size(); ++e) {
        const auto p = edges[e].poses(n);
        EXPECT_EQ(cube::checkMotion(w.manager, body, p, order, o), one[e]) << "edge " << e;
        colliding += one[e] != cube::kNoIndex;
      }
      EXPECT_GT(colliding, 0u);
      EXPECT_LT(colliding, edges.size());
    }
  }
}

// Bounds of the wrong size, negative, NaN or infinite throw std::invalid_argument naming them
// before any work (no pose function call); the checks answer as before afterwards.
TEST(ContinuousEdges, BadBoundsThrowAndChangeNothing) {
  World w;
  fillWorld(w, 45, 17);
  const cube::BodySet<S> body = randomBody(4, 18);
  const std::size_t n = body.size();
  const Edge e = randomEdges(1, n, 19)[0];
  const auto poses = e.poses(n);
  const std::vector<S> bounds = se3Bounds(body, poses, {0}, 1);
  const std::size_t before = cube::checkMotion(w.manager, body, poses, bounds);
  std::atomic<int> calls{0};
  const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
    ++calls;
    std::copy(poses.begin() + k * n, poses.begin() + (k + 1) * n, out);
  };
  const auto expectThrow = [&](const std::vector<S>& bad, const std::string& says) {
    for (int overload = 0; overload < 4; ++overload) {
      try {
        if (overload == 0) cube::checkMotion(w.manager, body, poses, bad);
        if (overload == 1) cube::checkMotions(w.manager, body, poses, {0}, bad);
        if (overload == 2) cube::checkMotion(w.manager, body, e.states, pose_of, bad);
        if (overload == 3) cube::checkMotions(w.manager, body, e.states, {0}, pose_of, bad);
        ADD_FAILURE() << "no throw for " << says;
      } catch (const std::invalid_argument& error) {
        EXPECT_NE(std::string(error.what()).find(says), std::string::npos) << error.what();
      }
    }
  };
  auto bad = bounds;
  bad.pop_back();
  expectThrow(bad, "motion_bounds");
  bad = bounds;
  bad.push_back(0);
  expectThrow(bad, "motion_bounds");
  for (const S value : {S(-1e-9), std::nan(""), std::numeric_limits<S>::infinity()}) {
    bad = bounds;
    bad[n + 2] = value;
    expectThrow(bad, "motion bound " + std::to_string(n + 2));
  }
  // A view with values but no pointer.
  for (int overload = 0; overload < 2; ++overload) {
    try {
      const cube::MotionBounds<S> null_view(nullptr, bounds.size());
      if (overload == 0) cube::checkMotion(w.manager, body, poses, null_view);
      if (overload == 1) cube::checkMotion(w.manager, body, e.states, pose_of, null_view);
      ADD_FAILURE() << "no throw for a null pointer";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("null"), std::string::npos) << error.what();
    }
  }
  EXPECT_EQ(calls.load(), 0);
  // Bounds read in place from the middle of a larger buffer answer as the vector does.
  std::vector<S> buffer(bounds.size() + 7, std::nan(""));
  std::copy(bounds.begin(), bounds.end(), buffer.begin() + 3);
  const cube::MotionBounds<S> view(buffer.data() + 3, bounds.size());
  EXPECT_EQ(cube::checkMotion(w.manager, body, poses, view), before);
  EXPECT_EQ(cube::checkMotion(w.manager, body, e.states, pose_of, view), before);
  EXPECT_EQ(cube::checkMotions(w.manager, body, poses, {0}, view),
            std::vector<std::size_t>{before});
  calls = 0;
  // A NaN pose next to a state the SE(3) bounds read throws, naming it, from the array and
  // from a pose function.
  cube::BatchOptions o;
  o.continuous = true;
  auto nan = poses;
  nan[n + 1].translation()[2] = std::nan("");
  const cube::PoseFunction<S> nan_of = [&](std::size_t k, fcl::Transform3d* out) {
    std::copy(nan.begin() + k * n, nan.begin() + (k + 1) * n, out);
  };
  for (const bool from_function : {false, true}) {
    try {
      if (from_function)
        cube::checkMotion(w.manager, body, e.states, nan_of, cube::MotionOrder::path, o);
      else
        cube::checkMotion(w.manager, body, nan, cube::MotionOrder::path, o);
      ADD_FAILURE() << "no throw for a NaN pose";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("pose " + std::to_string(n + 1)), std::string::npos)
          << error.what();
    }
  }
  EXPECT_EQ(cube::checkMotion(w.manager, body, poses, bounds), before);
  EXPECT_EQ(cube::checkMotion(w.manager, body, e.states, pose_of, bounds), before);
  EXPECT_EQ(cube::checkMotions(w.manager, body, e.states, {0}, pose_of, bounds),
            std::vector<std::size_t>{before});
  EXPECT_EQ(cube::checkMotion(w.manager, body, poses, cube::MotionOrder::path, o), before);
  EXPECT_EQ(cube::checkMotion(w.manager, body, e.states, pose_of, cube::MotionOrder::path, o),
            before);
}

// SE(3) bounds computed from a pose function's poses equal those of the pose array, on edges
// whose states lie at uneven steps (each interval's bound its own), in both orders and on 1 to
// 3 threads: the same answers as the array form and as the bounds given.
TEST(ContinuousEdges, PoseFunctionBoundsEqualTheArrayFormsOnUnevenSteps) {
  World w;
  fillWorld(w, 60, 71);
  const cube::BodySet<S> body = randomBody(4, 72);
  const std::size_t n = body.size();
  const std::vector<Edge> edges = randomEdges(120, n, 73, 2, 40);
  std::mt19937 rng(74);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
  for (const Edge& e : edges) {
    starts.push_back(poses.size() / n);
    std::vector<double> at{0, 1};
    for (std::size_t k = 2; k < e.states; ++k) at.push_back(u(rng) * u(rng));
    std::sort(at.begin(), at.end());
    for (const double s : at)
      for (std::size_t l = 0; l < n; ++l) poses.push_back(e.at(l, s));
  }
  const std::size_t states = poses.size() / n;
  const std::vector<S> bounds = se3Bounds(body, poses, starts, 1);
  const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
    std::copy(poses.begin() + k * n, poses.begin() + (k + 1) * n, out);
  };
  std::size_t colliding = 0;
  for (const cube::MotionOrder order : {cube::MotionOrder::path, cube::MotionOrder::bisection}) {
    cube::BatchOptions o;
    o.continuous = true;
    o.threads = 1;
    const auto want = cube::checkMotions(w.manager, body, poses, starts, order, o);
    EXPECT_EQ(cube::checkMotions(w.manager, body, poses, starts, bounds, order, o), want);
    for (const int threads : {1, 2, 3}) {
      o.threads = threads;
      EXPECT_EQ(cube::checkMotions(w.manager, body, states, starts, pose_of, order, o), want)
          << threads << " threads";
    }
    for (const std::size_t f : want) colliding += f != cube::kNoIndex;
  }
  EXPECT_GT(colliding, 0u);
  EXPECT_LT(colliding, 2 * edges.size());
}

// Zero bounds are the discrete check; a lone state has no interval to raise it.
TEST(ContinuousEdges, ZeroBoundsAreTheDiscreteCheck) {
  World w;
  fillWorld(w, 45, 29);
  const cube::BodySet<S> body = randomBody(5, 30);
  const std::size_t n = body.size();
  std::size_t colliding = 0;
  for (const Edge& e : randomEdges(30, n, 31)) {
    const auto poses = e.poses(n);
    const std::size_t plain = cube::checkMotion(w.manager, body, poses);
    EXPECT_EQ(cube::checkMotion(w.manager, body, poses, std::vector<S>(poses.size(), 0)), plain);
    colliding += plain != cube::kNoIndex;
    const std::vector<fcl::Transform3d> lone(poses.begin(), poses.begin() + n);
    cube::BatchOptions o;
    o.continuous = true;
    EXPECT_EQ(cube::checkMotion(w.manager, body, lone, cube::MotionOrder::path, o),
              cube::checkMotion(w.manager, body, lone));
  }
  EXPECT_GT(colliding, 0u);
}

}  // namespace
