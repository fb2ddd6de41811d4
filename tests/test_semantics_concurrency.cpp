// Several threads may query one manager at once (docs/guarantees.md) and get
// fcl::NaiveCollisionManager's answers.

#include <gtest/gtest.h>
#include <pthread.h>

#include <utility>
#include <vector>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

// 9. Several threads may query one manager at once and get Naive's answers.
TYPED_TEST(Semantics, TwoThreadsQueryingAtOnceGetNaiveAnswers) {
  using S = TypeParam;
  auto sc = scene<S>(600, 41);
  auto qs = scene<S>(200, 42);
  const auto objs = sc.pointers();
  const auto queries = qs.pointers();
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  fcl::NaiveCollisionManager<S> naive;
  for (auto* o : objs) naive.registerObject(o);
  // Expected answers first, single-threaded.
  const auto self_expected = oracle::bruteSelfPairs(objs);
  Colliding<S> naive_hits;
  naive.collide(&naive_hits, &Colliding<S>::record);
  std::vector<std::vector<Pair<S>>> obj_expected;
  std::vector<S> dist_expected;
  for (auto* q : queries) {
    obj_expected.push_back(bruteCrossPairs<S>(objs, {q}));
    dist_expected.push_back(
        fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { naive.distance(q, d, f); }));
  }
  const CubeCollisionManager<S>& shared = cube;
  auto work = [&](int which, std::vector<std::string>* errors) {
    for (int round = 0; round < 4; ++round) {
      if (oracle::selfPairs<S>(shared) != self_expected) errors->push_back("self pairs");
      Colliding<S> hits;
      shared.collide(&hits, &Colliding<S>::record);
      if (hits.result() != naive_hits.result()) errors->push_back("colliding pairs");
      // The two threads walk the queries in opposite orders.
      for (std::size_t k = 0; k < queries.size(); ++k) {
        const std::size_t i = which == 0 ? k : queries.size() - 1 - k;
        if (cubeObjectCalls<S>(shared, queries[i]) != obj_expected[i])
          errors->push_back("object query " + std::to_string(i));
        const S d = cubeMinDistance<S>(
            [&](void* dd, fcl::DistanceCallBack<S> f) { shared.distance(queries[i], dd, f); });
        // Touching pairs stop the default callback at whichever comes first, with an
        // order-dependent value <= 0; only positive minima are comparable.
        const bool same =
            dist_expected[i] > 0 ? bool(closeDistance<S>(d, dist_expected[i])) : d <= 0;
        if (!same)
          errors->push_back("distance " + std::to_string(i) + ": " + std::to_string(d) + " vs " +
                            std::to_string(dist_expected[i]));
      }
    }
  };
  std::vector<std::string> e0, e1;
  std::thread t0(work, 0, &e0), t1(work, 1, &e1);
  t0.join();
  t1.join();
  EXPECT_TRUE(e0.empty()) << e0.size() << " mismatches, first: " << e0.front();
  EXPECT_TRUE(e1.empty()) << e1.size() << " mismatches, first: " << e1.front();
}

// The header promises a self-collide at most about 100 KB of the caller's stack: one on a thread
// with a 256 KB stack (a quarter of what the smallest common defaults give) of 1,000 to 4,000
// objects, whose float bounds are kept in the walk's frame, gets brute force's pairs.
TYPED_TEST(Semantics, SelfCollideFitsInAThreadWithASmallStack) {
  using S = TypeParam;
  for (std::size_t n : {1000, 3000, 4000}) {
    SCOPED_TRACE(n);
    auto sc = scene<S>(n, 43);
    const auto objs = sc.pointers();
    CubeCollisionManager<S> cube;
    cube.registerObjects(objs);
    cube.setup();
    struct Job {
      const CubeCollisionManager<S>* m;
      std::vector<Pair<S>> pairs;
    } job{&cube, {}};
    pthread_attr_t attr;
    ASSERT_EQ(pthread_attr_init(&attr), 0);
    ASSERT_EQ(pthread_attr_setstacksize(&attr, 256 * 1024), 0);
    pthread_t thread;
    auto run = [](void* arg) -> void* {
      auto* j = static_cast<Job*>(arg);
      j->pairs = oracle::selfPairs<S>(*j->m);
      return nullptr;
    };
    ASSERT_EQ(pthread_create(&thread, &attr, run, &job), 0);
    ASSERT_EQ(pthread_join(thread, nullptr), 0);
    pthread_attr_destroy(&attr);
    EXPECT_EQ(job.pairs, oracle::bruteSelfPairs(objs));
  }
}

}  // namespace
}  // namespace testing
}  // namespace cube
