// The pipeline's parallel building blocks (queries.h): forEachPair and collideConcurrently call
// every index or pair once, stop and rethrow as documented, and refuse bad input before any work.

#include <gtest/gtest.h>

#include "support/narrow_phase_world.h"

namespace {

using namespace narrowphase;

// forEachPair calls fn once per index on any thread count and rethrows the first exception
// (by index) after the others ran.
TEST(NarrowPhaseApi, ForEachPairCallsEveryIndexOnceAndRethrows) {
  auto world = cube::scenes::makeScene<double>(cube::scenes::SceneOptions{});
  std::vector<cube::ObjectPair<double>> pairs;
  for (std::size_t i = 0; i + 1 < 300; ++i)
    pairs.emplace_back(world.objects[i].get(), world.objects[i + 1].get());
  for (int threads : {1, 2, 3}) {
    std::vector<std::atomic<int>> calls(pairs.size());
    cube::forEachPair<double>(
        pairs,
        [&](std::size_t i, fcl::CollisionObject<double>* a, fcl::CollisionObject<double>* b) {
          EXPECT_EQ(a, pairs[i].first);
          EXPECT_EQ(b, pairs[i].second);
          ++calls[i];
        },
        threads);
    for (const auto& c : calls) EXPECT_EQ(c.load(), 1);
    std::atomic<int> after{0};
    try {
      cube::forEachPair<double>(
          pairs,
          [&](std::size_t i, fcl::CollisionObject<double>*, fcl::CollisionObject<double>*) {
            if (i == 17 || i == 250) throw std::runtime_error("pair " + std::to_string(i));
            ++after;
          },
          threads);
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "pair 17");
    }
    EXPECT_EQ(after.load(), int(pairs.size()) - 2) << "the other calls ran";
  }
}

// collideConcurrently hands a thread-safe callback every candidate pair once, and stops early
// when it returns true.
TEST(NarrowPhaseApi, CollideConcurrentlySeesEveryPairOnceAndStops) {
  cube::scenes::SceneOptions so;
  so.n = 2000;
  so.overlaps_per_object = 3.0;
  auto world = cube::scenes::makeScene<double>(so);
  cube::CubeCollisionManager<double> m;
  m.registerObjects(world.pointers());
  const auto expected = cube::overlappingPairs<double>(m);
  ASSERT_GT(expected.size(), 1000u);
  struct Seen {
    std::mutex mutex;
    std::multiset<std::pair<const void*, const void*>> pairs;
    std::atomic<std::size_t> calls{0};
    std::size_t stop_after = 0;  // 0: never
  };
  const auto fn = [](fcl::CollisionObject<double>* a, fcl::CollisionObject<double>* b, void* d) {
    auto& s = *static_cast<Seen*>(d);
    const std::size_t k = ++s.calls;
    std::lock_guard<std::mutex> lock(s.mutex);
    s.pairs.emplace(a, b);
    return s.stop_after != 0 && k >= s.stop_after;
  };
  for (int threads : {1, 2, 3}) {
    Seen seen;
    cube::collideConcurrently<double>(m, &seen, fn, threads);
    std::multiset<std::pair<const void*, const void*>> want;
    for (const auto& [a, b] : expected) want.emplace(a, b);
    EXPECT_EQ(seen.pairs, want) << "threads " << threads;
    Seen stopping;
    stopping.stop_after = 10;
    cube::collideConcurrently<double>(m, &stopping, fn, threads);
    EXPECT_GE(stopping.calls.load(), 10u);
    EXPECT_LE(stopping.calls.load(), 256u + 10u) << "at most the running chunk finishes";
  }
}

// Bad input gets a clear error before any work: a null object in a pair list, an empty function,
// a null callback.
TEST(NarrowPhaseApi, BadInputThrowsBeforeAnyPairRuns) {
  auto world = cube::scenes::makeScene<double>(cube::scenes::SceneOptions{});
  cube::CubeCollisionManager<double> m;
  m.registerObjects(world.pointers());
  std::vector<cube::ObjectPair<double>> pairs = cube::overlappingPairs<double>(m);
  ASSERT_GT(pairs.size(), 10u);
  pairs[5].second = nullptr;
  fcl::CollisionRequest<double> req;
  cube::NarrowPhaseCache<double> cache;
  cube::NarrowPhaseOptions<double> o;
  o.cache = &cache;
  EXPECT_THROW(cube::collidePairs<double>(pairs, req, o), std::invalid_argument);
  EXPECT_THROW(cube::collideMerged<double>(pairs, req, o), std::invalid_argument);
  EXPECT_EQ(cache.size(), 0u) << "nothing ran";
  std::size_t calls = 0;
  EXPECT_THROW(cube::forEachPair<double>(pairs, [&](std::size_t, fcl::CollisionObjectd*,
                                                    fcl::CollisionObjectd*) { ++calls; }),
               std::invalid_argument);
  EXPECT_EQ(calls, 0u);
  pairs[5].second = pairs[5].first;
  EXPECT_THROW(cube::forEachPair<double>(pairs, {}), std::invalid_argument);
  EXPECT_THROW(cube::collideConcurrently<double>(m, nullptr, nullptr), std::invalid_argument);
}

}  // namespace
