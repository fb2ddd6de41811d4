// Batched state and motion checks (cube_collision/batch.h) against brute force: every link
// against every world object and every checked pair of links, with FCL's narrow phase; motions
// give the serial scan's answer; poses written on demand give the array forms' answers; on every
// thread count.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// Worlds of 60 objects (a small world: records of moved objects go stale) and 400, with and
// without meshes, planes in the small one (one tilted: clearance then reads exact gaps).
class BatchWorlds : public ::testing::TestWithParam<std::tuple<std::size_t, bool>> {};

TEST_P(BatchWorlds, StatesEqualBruteForce) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 7 + std::uint32_t(n), meshes, n < 100);
  const cube::BodySet<S> body = randomBody(8, 3, meshes);
  const auto poses = randomStates(60, body.size(), 11);
  std::size_t free_states = 0;
  for (const bool self : {false, true})
    for (const bool first : {false, true}) {
      cube::BatchOptions o;
      o.self_collision = self;
      o.first_pair = first;
      o.clearance = !first;
      o.threads = 1;
      std::size_t hits = 0;
      expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
      free_states = poses.size() / body.size() - hits;
      // The scene must exercise both answers.
      EXPECT_GT(hits, 5u);
      EXPECT_GT(free_states, 5u);
    }
}

TEST_P(BatchWorlds, ThreadCountsGiveTheSameAnswers) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 5, meshes, false);
  const cube::BodySet<S> body = randomBody(6, 9, meshes);
  const auto poses = randomStates(80, body.size(), 13);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  const auto one = cube::checkStates(w.manager, body, poses, o);
  for (const int t : {2, 3, 8}) {
    o.threads = t;
    expectSameAnswers(cube::checkStates(w.manager, body, poses, o), one);
  }
}

INSTANTIATE_TEST_SUITE_P(Batch, BatchWorlds,
                         ::testing::Combine(::testing::Values(std::size_t(60), std::size_t(400)),
                                            ::testing::Bool()));

// A small world keeps records from its first check. An object that update(objects) moves gets a
// stale record, which the checks replace by volumes built from the object, until update() finds
// it standing and builds the record again. The states equal brute force after each step.
TEST(Batch, StatesAgainstASmallWorldThatMovesEqualBruteForce) {
  World w;
  fillWorld(w, 60, 67, false, true);
  const cube::BodySet<S> body = randomBody(8, 3, false);
  const auto poses = randomStates(60, body.size(), 23);
  cube::BatchOptions o;
  o.threads = 1;
  std::size_t hits = 0;
  // Both answers occur in each step.
  const auto both = [&] {
    EXPECT_GT(hits, 5u);
    EXPECT_LT(hits, 55u);
  };
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
  both();
  // A third of the objects onto their neighbours' poses.
  std::vector<Object*> moved;
  for (std::size_t i = 0; i + 1 < w.objects.size(); i += 3) {
    w.objects[i]->setTransform(w.objects[i + 1]->getTransform());
    w.objects[i]->computeAABB();
    moved.push_back(w.objects[i].get());
  }
  w.manager.update(moved);
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
  both();
  w.manager.update();
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
  both();
}

// The serial scan of an edge in an order, from per-state answers.
std::size_t serialScan(const std::vector<cube::StateResult<S>>& states, std::size_t begin,
                       std::size_t end, cube::MotionOrder order) {
  for (const std::size_t i : visitOrder(end - begin, order))
    if (states[begin + i].colliding) return i;
  return cube::kNoIndex;
}

TEST(Batch, MotionsGiveTheSerialScansAnswer) {
  World w;
  fillWorld(w, 400, 31, false, true);
  const cube::BodySet<S> body = randomBody(5, 17, false);
  // Edges of 1 to 40 states: a straight sweep of the robot's rigid pose across the world.
  std::mt19937 rng(2);
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
  std::vector<fcl::Transform3d> shape;
  for (std::size_t l = 0; l < body.size(); ++l) shape.push_back(randomPose(rng, 1.5));
  for (int e = 0; e < 30; ++e) {
    starts.push_back(poses.size() / body.size());
    const fcl::Vector3d from = randomPose(rng, 9).translation(),
                        to = randomPose(rng, 9).translation();
    const std::size_t n = 1 + std::size_t(e * 13 % 40);
    for (std::size_t k = 0; k < n; ++k) {
      const double t = n == 1 ? 0 : double(k) / double(n - 1);
      for (const auto& s : shape) {
        fcl::Transform3d tf = s;
        tf.translation() += from + t * (to - from);
        poses.push_back(tf);
      }
    }
  }
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  const auto states = cube::checkStates(w.manager, body, poses, o);
  expectSame(states, w, body, poses, o);
  std::size_t edges_hit = 0;
  for (const auto order : {cube::MotionOrder::path, cube::MotionOrder::bisection})
    for (const int t : {1, 2, 3, 8}) {
      o.threads = t;
      const auto first = cube::checkMotions(w.manager, body, poses, starts, order, o);
      ASSERT_EQ(first.size(), starts.size());
      edges_hit = 0;
      for (std::size_t e = 0; e < starts.size(); ++e) {
        const std::size_t end = e + 1 < starts.size() ? starts[e + 1] : states.size();
        EXPECT_EQ(first[e], serialScan(states, starts[e], end, order)) << "edge " << e;
        edges_hit += first[e] != cube::kNoIndex;
      }
      // One edge alone, from the array and from poses written on demand.
      for (std::size_t e = 0; e + 1 < starts.size(); ++e) {
        const std::vector<fcl::Transform3d> edge(poses.begin() + starts[e] * body.size(),
                                                 poses.begin() + starts[e + 1] * body.size());
        const std::size_t want = serialScan(states, starts[e], starts[e + 1], order);
        EXPECT_EQ(cube::checkMotion(w.manager, body, edge, order, o), want);
        std::atomic<std::size_t> calls{0};
        const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
          ++calls;
          for (std::size_t l = 0; l < body.size(); ++l) out[l] = edge[k * body.size() + l];
        };
        const std::size_t n = edge.size() / body.size();
        EXPECT_EQ(cube::checkMotion(w.manager, body, n, pose_of, order, o), want);
        EXPECT_LE(calls.load(), n);
        // On one thread, the states computed past the answer (at rank r of the order) are
        // fewer than those before it: at most 2 r + 3 in all, all of them for a free edge.
        if (t == 1) {
          const std::vector<std::size_t> visit = visitOrder(n, order);
          const std::size_t rank =
              std::size_t(std::find(visit.begin(), visit.end(), want) - visit.begin());
          if (want == cube::kNoIndex)
            EXPECT_EQ(calls.load(), n);
          else
            EXPECT_LE(calls.load(), std::min(n, std::max<std::size_t>(5, 2 * rank + 3)));
          EXPECT_GE(calls.load(), want == cube::kNoIndex ? n : rank + 1);
        }
      }
    }
  // The scene must exercise both answers (ThreadSanitizer's clang build met 28 of 30).
  EXPECT_GT(edges_hit, 3u);
  EXPECT_LT(edges_hit, starts.size());
}

// Poses written on demand (PoseFunction): checkStates' answers are brute force's and
// checkMotions' the serial scan's, on every thread count, each state's poses asked for at most
// once (every state by checkStates).
TEST_P(BatchWorlds, PosesWrittenOnDemandGiveTheArrayFormsAnswers) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 19, meshes, n < 100);
  const cube::BodySet<S> body = randomBody(6, 21, meshes);
  const auto poses = randomStates(150, body.size(), 23);
  const std::size_t states = poses.size() / body.size();
  std::vector<std::atomic<int>> asked(states);
  const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
    ++asked[k];
    for (std::size_t l = 0; l < body.size(); ++l) out[l] = poses[k * body.size() + l];
  };
  const auto reset = [&] {
    for (auto& a : asked) a = 0;
  };
  const std::vector<std::size_t> starts{0, 1, 9, 40, 41, 100};
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  const auto serial = cube::checkStates(w.manager, body, poses, o);
  std::size_t hits = 0;
  for (const int t : {1, 2, 3, 8}) {
    o.threads = t;
    o.first_pair = t % 2 == 1;
    o.clearance = !o.first_pair;
    reset();
    expectSame(cube::checkStates<S>(w.manager, body, states, pose_of, o), w, body, poses, o, &hits);
    for (std::size_t k = 0; k < states; ++k) ASSERT_EQ(asked[k].load(), 1) << "state " << k;
    for (const auto order : {cube::MotionOrder::path, cube::MotionOrder::bisection}) {
      reset();
      const auto first = cube::checkMotions<S>(w.manager, body, states, starts, pose_of, order, o);
      ASSERT_EQ(first.size(), starts.size());
      for (std::size_t e = 0; e < starts.size(); ++e) {
        const std::size_t end = e + 1 < starts.size() ? starts[e + 1] : states;
        EXPECT_EQ(first[e], serialScan(serial, starts[e], end, order)) << "edge " << e;
      }
      for (std::size_t k = 0; k < states; ++k) ASSERT_LE(asked[k].load(), 1) << "state " << k;
    }
  }
  // The scene must exercise both answers.
  EXPECT_GT(hits, 5u);
  EXPECT_LT(hits, states - 5);
  // States that lie close together (a sweep of one rigid shape in small steps: placed and
  // walked as groups) give the array form's answers too.
  std::mt19937 rng(29);
  std::vector<fcl::Transform3d> shape, sweep;
  for (std::size_t l = 0; l < body.size(); ++l) shape.push_back(randomPose(rng, 1.5));
  const fcl::Vector3d from = randomPose(rng, 9).translation(),
                      to = randomPose(rng, 9).translation();
  const std::size_t steps = 120;
  for (std::size_t k = 0; k < steps; ++k)
    for (const auto& p : shape) {
      fcl::Transform3d tf = p;
      tf.translation() += from + (double(k) / double(steps - 1)) * (to - from);
      sweep.push_back(tf);
    }
  const cube::PoseFunction<S> sweep_of = [&](std::size_t k, fcl::Transform3d* out) {
    for (std::size_t l = 0; l < body.size(); ++l) out[l] = sweep[k * body.size() + l];
  };
  o.first_pair = true;
  o.clearance = false;
  for (const int t : {1, 2}) {
    o.threads = t;
    const auto want = cube::checkStates(w.manager, body, sweep, o);
    const auto got = cube::checkStates<S>(w.manager, body, steps, sweep_of, o);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t k = 0; k < steps; ++k) {
      EXPECT_EQ(got[k].colliding, want[k].colliding) << "state " << k;
      EXPECT_EQ(got[k].link, want[k].link) << "state " << k;
      EXPECT_EQ(got[k].object, want[k].object) << "state " << k;
      EXPECT_EQ(got[k].other_link, want[k].other_link) << "state " << k;
    }
  }
}

}  // namespace
