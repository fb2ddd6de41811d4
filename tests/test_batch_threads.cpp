// The batch's threads: a negative thread count means the hardware's, and batches on threads run
// while other threads query the same world (under ThreadSanitizer too, .ci/run).

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

// A negative thread count means the hardware's, as 0 does, with the same answers as one thread.
TEST(Batch, NegativeThreadCountsMeanTheHardwares) {
  World w;
  fillWorld(w, 300, 8, false, false);
  const cube::BodySet<S> body = randomBody(6, 2, false);
  const auto poses = randomStates(400, body.size(), 3);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  const auto one = cube::checkStates(w.manager, body, poses, o);
  std::vector<std::size_t> starts;
  for (std::size_t k = 0; k < one.size(); k += 25) starts.push_back(k);
  const auto one_edges =
      cube::checkMotions(w.manager, body, poses, starts, cube::MotionOrder::bisection, o);
  for (const int t : {-1, -8, 0}) {
    o.threads = t;
    const auto got = cube::checkStates(w.manager, body, poses, o);
    ASSERT_EQ(got.size(), one.size());
    for (std::size_t k = 0; k < one.size(); ++k) {
      EXPECT_EQ(got[k].colliding, one[k].colliding);
      EXPECT_EQ(got[k].link, one[k].link);
      EXPECT_EQ(got[k].object, one[k].object);
    }
    EXPECT_EQ(cube::checkMotions(w.manager, body, poses, starts, cube::MotionOrder::bisection, o),
              one_edges);
  }
}

// ThreadSanitizer runs this one (.ci/run): batches on two threads while other threads query the
// same world.
TEST(Batch, ThreadsWithConcurrentReadersOfTheWorld) {
  World w;
  fillWorld(w, 500, 12, false, true);
  const cube::BodySet<S> body = randomBody(6, 4, false);
  const auto poses = randomStates(64, body.size(), 6);
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  const auto expected = cube::checkStates(w.manager, body, poses, o);
  o.threads = 2;
  std::atomic<bool> stop{false};
  std::atomic<std::size_t> reads{0};
  std::thread reader([&] {
    Object q(std::make_shared<fcl::Sphered>(2));
    q.computeAABB();
    while (!stop.load()) {
      fcl::DefaultCollisionData<S> d;
      w.manager.collide(&q, &d, fcl::DefaultCollisionFunction<S>);
      reads.fetch_add(1);
    }
  });
  // Until the reader has queried during several batches.
  for (int round = 0; round < 3 || (reads.load() < 20 && round < 100000); ++round) {
    const auto got = cube::checkStates(w.manager, body, poses, o);
    for (std::size_t k = 0; k < got.size(); ++k) EXPECT_EQ(got[k].colliding, expected[k].colliding);
  }
  stop.store(true);
  reader.join();
  EXPECT_GT(reads.load(), 0u);
}

}  // namespace
