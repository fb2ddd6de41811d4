// The self walk of a large scene split over threads: collideAll and
// collideConcurrently with split_walk, on a CubeCollisionManager of thousands of objects, gather
// their candidate pairs with the walk cut into tasks that OpenMP threads walk. The cut tasks,
// concatenated, are the serial walk (the same pairs in the same order); the callback sees the
// serial sequence on every thread count, with filter bits, a pair predicate, canonical order,
// culling, unbounded objects, the pair list and early stops; collideAll's contacts are bit-equal on
// 1, 2, 3 and 8 threads. Runs under ThreadSanitizer too (.ci/run).

#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

#include "adapter/manager_access.h"
#include "adapter/manager_walks.h"
#include "core/broadphase.h"
#include "core/traversal.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "pipeline/fcl_narrow.h"
#include "scenes.h"
#include "support/fcl_contacts.h"
#include "support/oracle.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Pair = cube::oracle::Pair<S>;
using cube::scenes::Layout;
using Calls = cube::oracle::Calls<S>;
using fclcontacts::sameContacts;

constexpr std::size_t kObjects = 5000;  // above Broadphase::kSplitMin
static_assert(kObjects >= cube::detail::Broadphase<S>::kSplitMin, "the split must run");

// A scene of kObjects boxes, spheres and cylinders, and with `planes` two planes and a halfspace
// (unbounded: the manager's unbounded list, which the split walks too).
struct World {
  cube::scenes::Scene<S> scene;
  std::vector<std::unique_ptr<Object>> extra;
  std::vector<Object*> all;
};

World world(Layout layout, bool planes, std::uint32_t seed, std::size_t n = kObjects) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.layout = layout;
  o.seed = seed;
  o.overlaps_per_object = 2.0;
  World w{cube::scenes::makeScene<S>(o), {}, {}};
  w.all = w.scene.pointers();
  if (planes) {
    const auto add = [&](std::shared_ptr<fcl::CollisionGeometry<S>> g) {
      w.extra.push_back(std::make_unique<Object>(g, fcl::Transform3<S>::Identity()));
      w.extra.back()->computeAABB();
      w.all.push_back(w.extra.back().get());
    };
    add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 0, 1), 10));
    add(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(1, 1, 0).normalized(), -300));
    add(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 1, 0), -1900));
  }
  return w;
}

// Filter bits on a third of the objects (four groups, some masks leaving groups out) and a
// predicate dropping a fifth of the pairs by a rule on both objects.
void addRules(cube::CubeCollisionManager<S>& m, const std::vector<Object*>& objs, bool predicate) {
  std::mt19937 rng(11);
  for (std::size_t i = 0; i < objs.size(); i += 3) {
    const std::uint64_t group = std::uint64_t(1) << (rng() % 4);
    m.setFilter(objs[i], group, ~(group << 1));
  }
  if (predicate)
    m.setPairFilter([](Object* a, Object* b) {
      return (reinterpret_cast<std::uintptr_t>(a) ^ reinterpret_cast<std::uintptr_t>(b)) % 5 != 0;
    });
}

// The pairs the rules let through among all the objects: brute force over the AABBs.
std::vector<Pair> bruteKept(const cube::CubeCollisionManager<S>& m,
                            const std::vector<Object*>& objs, bool predicate) {
  std::vector<Pair> out;
  for (const Pair& p : cube::oracle::bruteSelfPairs(objs)) {
    const auto fa = m.filter(p.first), fb = m.filter(p.second);
    if ((fa.first & fb.second) == 0 || (fb.first & fa.second) == 0) continue;
    // The predicate is symmetric: the orientation it is called with does not change its answer.
    if (predicate &&
        (reinterpret_cast<std::uintptr_t>(p.first) ^ reinterpret_cast<std::uintptr_t>(p.second)) %
                5 ==
            0)
      continue;
    out.push_back(p);
  }
  return out;
}

Calls serialCalls(const cube::CubeCollisionManager<S>& m) {
  Calls c;
  m.collide(&c, &Calls::record);
  return c;
}

Calls splitCalls(const cube::CubeCollisionManager<S>& m, int threads) {
  Calls c;
  cube::detail::collideSelfOnThreads(m, &c, &Calls::record, threads);
  return c;
}

// The tasks of a split, concatenated, are collectPairs' walk, pair for pair, whatever the number
// of tasks asked for; with and without a gate, on the cubes and the unbounded list's view pairs.
TEST(SplitWalk, TasksConcatenateToTheSerialWalk) {
  for (Layout layout : {Layout::uniform, Layout::clustered}) {
    const World w = world(layout, true, 3);
    for (bool rules : {false, true}) {
      cube::CubeCollisionManager<S> m;
      m.registerObjects(w.all);
      if (rules) addRules(m, w.all, false);
      ASSERT_TRUE(m.validate());
      const cube::detail::Scene<S> scene = ::cube::detail::coreOf(m).scene();
      ASSERT_NE(scene.unbounded.root, cube::detail::kNone);
      cube::detail::PairGate<S> gate;
      gate.filters_a = gate.filters_b = ::cube::detail::coreOf(m).table().filters();
      const cube::detail::PairGate<S>* g = rules ? &gate : nullptr;
      std::vector<std::uint64_t> all_serial;
      cube::detail::forSelfViews(scene, [&](const auto& a, const auto& b, bool self) {
        std::vector<std::uint64_t> serial;
        cube::detail::collectPairs(a, b, self, scene.all_pairs_limit, serial, g);
        for (std::size_t min_tasks : {1, 7, 64, 1000, 100000}) {
          const cube::detail::SplitWalk<S> split(a, b, self, scene.all_pairs_limit, g, min_tasks);
          if (self && a.slots > 1000) {
            EXPECT_GE(split.tasks(), std::min<std::size_t>(min_tasks, 64)) << "too few tasks";
          }
          std::vector<std::uint64_t> joined;
          for (std::size_t i = 0; i < split.tasks(); ++i) split.collect(i, joined);
          EXPECT_EQ(joined, serial) << "layout " << int(layout) << " rules " << rules << " self "
                                    << self << " min_tasks " << min_tasks;
        }
        all_serial.insert(all_serial.end(), serial.begin(), serial.end());
        return false;
      });
      // And the walk is right: brute force over every object.
      std::vector<Pair> got;
      for (const std::uint64_t p : all_serial)
        got.push_back(cube::oracle::unordered(
            ::cube::detail::coreOf(m).table().object(cube::detail::ObjectId(p >> 32)),
            ::cube::detail::coreOf(m).table().object(cube::detail::ObjectId(p))));
      std::sort(got.begin(), got.end());
      EXPECT_EQ(got, bruteKept(m, w.all, false));
    }
  }
}

// The callback of a split self-collide sees the serial walk's calls, in order, on every thread
// count: plain, with filter bits and a predicate, in canonical order, culled, from the pair list.
TEST(SplitWalk, CallbackSeesTheSerialSequenceOnEveryThreadCount) {
  for (Layout layout : {Layout::uniform, Layout::clustered}) {
    const World w = world(layout, true, 5);
    for (int variant = 0; variant < 5; ++variant) {
      cube::Config config;
      config.canonical_pairs = variant == 2;
      config.cull_pairs = variant == 3;
      config.keep_pairs = variant == 4;
      cube::CubeCollisionManager<S> m(config);
      m.registerObjects(w.all);
      const bool rules = variant == 1 || variant == 2;
      if (rules) addRules(m, w.all, true);
      if (variant == 4) {
        m.update();  // nothing moved: the pair list serves the next self-collide
        ASSERT_TRUE(m.pairsListed());
      }
      ASSERT_TRUE(m.validate());
      const Calls serial = serialCalls(m);
      if (variant != 3) {
        EXPECT_EQ(serial.unorderedSorted(), bruteKept(m, w.all, rules));
      }
      ASSERT_GT(serial.calls.size(), kObjects / 2);
      for (int threads : {1, 2, 3, 8}) {
        EXPECT_EQ(splitCalls(m, threads).calls, serial.calls)
            << "layout " << int(layout) << " variant " << variant << " threads " << threads;
      }
    }
  }
}

// A callback that stops the query sees exactly the first calls of the serial sequence.
TEST(SplitWalk, EarlyStopSeesTheSerialPrefix) {
  const World w = world(Layout::clustered, true, 9);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.all);
  const Calls serial = serialCalls(m);
  struct Stopper {
    std::size_t after;
    std::vector<Pair> calls;
    static bool fn(Object* a, Object* b, void* d) {
      auto& s = *static_cast<Stopper*>(d);
      s.calls.emplace_back(a, b);
      return s.calls.size() >= s.after;
    }
  };
  for (std::size_t after : {std::size_t(1), std::size_t(100), serial.calls.size() / 2})
    for (int threads : {2, 3, 8}) {
      Stopper s{after, {}};
      cube::detail::collideSelfOnThreads(m, &s, &Stopper::fn, threads);
      const std::vector<Pair> want(serial.calls.begin(), serial.calls.begin() + after);
      EXPECT_EQ(s.calls, want) << "after " << after << " threads " << threads;
    }
}

// FCL's own accumulation over the manager's serial walk (its narrow phase as the library applies
// it, detail::fclCollide): the reference of collideAll.
struct Accumulate {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  static bool fn(Object* a, Object* b, void* d) {
    auto& x = *static_cast<Accumulate*>(d);
    cube::detail::fclCollide(a, b, x.request, x.result);
    return x.result.isCollision() && x.result.numContacts() >= x.request.num_max_contacts;
  }
};

// collideAll's contacts are the same, bit for bit and in order, on 1, 2, 3 and 8 threads, and
// equal FCL's accumulation over the serial walk: uniform and clustered, with and without rules
// and planes, for "every contact" and for the default "does anything collide?".
TEST(SplitWalk, CollideAllIsBitEqualOnEveryThreadCount) {
  for (Layout layout : {Layout::uniform, Layout::clustered})
    for (bool extras : {false, true}) {
      const World w = world(layout, extras, 21);
      cube::CubeCollisionManager<S> m;
      m.registerObjects(w.all);
      if (extras) addRules(m, w.all, true);
      ASSERT_TRUE(m.validate());
      for (std::size_t max : {std::size_t(1), std::size_t(1) << 30}) {
        Accumulate ref;
        ref.request.num_max_contacts = max;
        ref.request.enable_contact = true;
        m.collide(&ref, &Accumulate::fn);
        if (max > 1) {
          ASSERT_GT(ref.result.numContacts(), kObjects / 4) << "must collide a lot";
        }
        for (int threads : {1, 2, 3, 8}) {
          cube::NarrowPhaseStats stats;
          cube::NarrowPhaseOptions<S> o;
          o.threads = threads;
          o.stats = &stats;
          o.split_walk = true;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, ref.request, o), ref.result))
              << "layout " << int(layout) << " extras " << extras << " max " << max << " threads "
              << threads;
          if (max > 1) {
            EXPECT_EQ(stats.candidate_pairs, serialCalls(m).calls.size());
          }
        }
      }
    }
}

// The core's split walk handing its tasks to a sink (Broadphase::collideSelfTasks): every task
// taken once, then drained in order after all have run; the tasks' pairs, concatenated, are the
// serial walk's calls; a drain that says stop ends the draining there; the split is refused
// (false, nothing handed over) on one thread, with a pair predicate, in canonical order and below
// kSplitMin objects.
struct RecordingSink final : cube::detail::TaskSink<S> {
  using Handed = cube::detail::TaskSink<S>::Pair;
  using Called = cube::oracle::Pair<S>;
  std::size_t stop_at = ~std::size_t(0);  // drain(stop_at) stops, counting tasks of every walk
  std::size_t walks = 0, drained = 0;
  int threads = 0;
  std::vector<std::vector<Called>> tasks;  // of the current walk
  std::vector<Called> joined;              // drained tasks, in order
  std::mutex mutex;
  std::set<std::size_t> taken;

  void begin(std::size_t n, int workers) override {
    ++walks;
    EXPECT_GE(workers, 2);
    threads = workers;
    EXPECT_EQ(taken.size(), tasks.size()) << "every task of the last walk taken";
    tasks.assign(n, {});
    taken.clear();
  }
  void take(int worker, std::size_t task, const Handed* pairs, std::size_t n) override {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(worker >= 0 && worker < threads) << "worker " << worker;
    EXPECT_TRUE(taken.insert(task).second) << "task " << task << " taken twice";
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_EQ(::cube::detail::coreOf(*manager).table().object(pairs[i].ia), pairs[i].a);
      EXPECT_EQ(::cube::detail::coreOf(*manager).table().object(pairs[i].ib), pairs[i].b);
      tasks[task].emplace_back(pairs[i].a, pairs[i].b);
    }
  }
  bool drain(std::size_t task) override {
    EXPECT_EQ(taken.size(), tasks.size()) << "drained before every task ran";
    joined.insert(joined.end(), tasks[task].begin(), tasks[task].end());
    return drained++ == stop_at;
  }
  const cube::CubeCollisionManager<S>* manager = nullptr;
};

TEST(SplitWalk, TasksHandedToASinkAreTheSerialWalk) {
  for (Layout layout : {Layout::uniform, Layout::clustered}) {
    const World w = world(layout, true, 13);
    cube::CubeCollisionManager<S> m;
    m.registerObjects(w.all);
    addRules(m, w.all, false);  // filter bits: the walks test them
    ASSERT_TRUE(m.validate());
    const Calls serial = serialCalls(m);
    ASSERT_GT(serial.calls.size(), kObjects / 2);
    const auto& core = ::cube::detail::coreOf(m);
    for (int threads : {2, 3, 8}) {
      {
        RecordingSink sink;
        sink.manager = &m;
        ASSERT_TRUE(core.collideSelfTasks(sink, threads));
        EXPECT_EQ(sink.walks, 3u) << "cubes, cubes with the unbounded list, the list itself";
        EXPECT_EQ(sink.joined, serial.calls) << "layout " << int(layout) << " threads " << threads;
      }
      // Stopped at the fifth task drained: the tasks drained are the serial walk's prefix, and
      // nothing after the stop is drained.
      RecordingSink stopping;
      stopping.manager = &m;
      stopping.stop_at = 4;
      ASSERT_TRUE(core.collideSelfTasks(stopping, threads));
      EXPECT_EQ(stopping.drained, 5u);
      ASSERT_LE(stopping.joined.size(), serial.calls.size());
      EXPECT_TRUE(std::equal(stopping.joined.begin(), stopping.joined.end(), serial.calls.begin()));
    }
    // Refused: one thread, a predicate, canonical order, a small scene.
    RecordingSink refused;
    refused.manager = &m;
    EXPECT_FALSE(core.collideSelfTasks(refused, 1));
    m.setPairFilter([](Object*, Object*) { return true; });
    EXPECT_FALSE(core.collideSelfTasks(refused, 2));
    cube::Config canonical;
    canonical.canonical_pairs = true;
    cube::CubeCollisionManager<S> c(canonical);
    c.registerObjects(w.all);
    EXPECT_FALSE(::cube::detail::coreOf(c).collideSelfTasks(refused, 2));
    const World small = world(layout, false, 13, 1000);
    cube::CubeCollisionManager<S> few;
    few.registerObjects(small.all);
    EXPECT_FALSE(::cube::detail::coreOf(few).collideSelfTasks(refused, 2));
    EXPECT_EQ(refused.walks, 0u);
  }
}

// FCL's accumulation over the serial walk (detail::fclCollide), with the pairs that added
// contacts.
struct AccumulatePairs {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  std::vector<cube::ObjectPair<S>> colliding;
  std::size_t calls = 0;  // pairs seen, up to the stop
  static bool fn(Object* a, Object* b, void* d) {
    auto& x = *static_cast<AccumulatePairs*>(d);
    ++x.calls;
    const std::size_t before = x.result.numContacts();
    cube::detail::fclCollide(a, b, x.request, x.result);
    if (x.result.numContacts() > before) x.colliding.emplace_back(a, b);
    return x.result.isCollision() && x.result.numContacts() >= x.request.num_max_contacts;
  }
};

// collideAll on a large scene with more than one thread answers the split walk's tasks on the
// threads that walked them (no split_walk option needed): contacts bit-equal to FCL's
// accumulation over the serial walk, the same colliding pairs, the counts adding up, for
// requests that stop early (waves of tasks), that take every contact (num_max_contacts at its
// largest: every task at once) and with or without contact geometry; one contact per query
// and a cache keep their serial paths, with the same answers. On one thread (pairs answered at
// once, in blocks of pairs whose memory is fetched together) the same, and the pairs counted are
// the walk's up to its stop: those the walk gave after the result was full are not.
TEST(SplitWalk, CollideAllInTasksEqualsFcl) {
  for (Layout layout : {Layout::uniform, Layout::clustered}) {
    const World w = world(layout, true, 17);
    cube::CubeCollisionManager<S> m;
    m.registerObjects(w.all);
    addRules(m, w.all, false);
    ASSERT_TRUE(m.validate());
    const std::size_t candidates = serialCalls(m).calls.size();
    for (std::size_t max : {std::size_t(1), std::size_t(7), std::size_t(1) << 30,
                            std::numeric_limits<std::size_t>::max()})
      for (bool contact : {false, true}) {
        AccumulatePairs ref;
        ref.request.num_max_contacts = max;
        ref.request.enable_contact = contact;
        m.collide(&ref, &AccumulatePairs::fn);
        if (max > 7) {
          ASSERT_GT(ref.colliding.size(), kObjects / 4) << "must collide a lot";
        }
        for (int threads : {1, 2, 3, 8})
          for (bool cache : {false, true}) {
            const auto what = ::testing::Message()
                              << "layout " << int(layout) << " max " << max << " contact "
                              << contact << " threads " << threads << " cache " << cache;
            cube::NarrowPhaseCache<S> c;
            cube::NarrowPhaseStats stats;
            std::vector<cube::ObjectPair<S>> pairs(2, {nullptr, nullptr});
            cube::NarrowPhaseOptions<S> o;
            o.threads = threads;
            o.stats = &stats;
            o.colliding = &pairs;
            o.cache = cache ? &c : nullptr;
            const fcl::CollisionResult<S> got = cube::collideAll<S>(m, ref.request, o);
            EXPECT_TRUE(sameContacts(got, ref.result, contact)) << what;
            EXPECT_EQ(pairs, ref.colliding) << what;
            if (threads == 1) {
              EXPECT_EQ(stats.candidate_pairs, ref.calls) << what;
            }
            if (max == 7 && !cache) {
              // Tasks whose predecessors hold 7 contacts are skipped: when a task is handed
              // out, all before it but the other threads' are done.
              EXPECT_LT(stats.candidate_pairs, candidates / 2) << what;
            }
            if (max > 7) {  // no stop, no budget: every pair answered once
              EXPECT_EQ(stats.culled + stats.proved + stats.cached + stats.narrow_calls,
                        stats.candidate_pairs)
                  << what;
              EXPECT_EQ(stats.candidate_pairs, candidates) << what;
            }
          }
      }
  }
}

// collideConcurrently on a split walk: every candidate pair once, and a stop ends it soon.
TEST(SplitWalk, CollideConcurrentlySeesEveryPairOnceAndStops) {
  const World w = world(Layout::uniform, true, 31);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.all);
  addRules(m, w.all, false);
  const std::vector<Pair> want = bruteKept(m, w.all, false);
  struct Seen {
    std::mutex mutex;
    std::vector<Pair> pairs;
    std::atomic<std::size_t> calls{0};
    std::size_t stop_after = 0;  // 0: never
  };
  const auto fn = [](Object* a, Object* b, void* d) {
    auto& s = *static_cast<Seen*>(d);
    const std::size_t k = ++s.calls;
    std::lock_guard<std::mutex> lock(s.mutex);
    s.pairs.push_back(cube::oracle::unordered(a, b));
    return s.stop_after != 0 && k >= s.stop_after;
  };
  for (int threads : {2, 3, 8}) {
    Seen seen;
    cube::collideConcurrently<S>(m, &seen, fn, threads, true);
    std::sort(seen.pairs.begin(), seen.pairs.end());
    EXPECT_EQ(seen.pairs, want) << "threads " << threads;
    Seen stopping;
    stopping.stop_after = 10;
    cube::collideConcurrently<S>(m, &stopping, fn, threads, true);
    EXPECT_GE(stopping.calls.load(), 10u);
    EXPECT_LE(stopping.calls.load(), 256u + 10u) << "at most the running chunk finishes";
  }
}

// Mutations still work between split queries, and one from inside the callback is refused (on
// the calling thread, where the callback runs); a null callback is refused before any work.
TEST(SplitWalk, MutationsAndBadInput) {
  World w = world(Layout::uniform, false, 41);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.all);
  EXPECT_THROW(cube::detail::collideSelfOnThreads<S>(m, nullptr, nullptr, 2),
               std::invalid_argument);
  struct Mutator {
    cube::CubeCollisionManager<S>* m;
    Object* victim;
    static bool fn(Object*, Object*, void* d) {
      auto& x = *static_cast<Mutator*>(d);
      x.m->unregisterObject(x.victim);
      return true;
    }
  };
  Mutator mut{&m, w.all[0]};
  EXPECT_THROW(cube::detail::collideSelfOnThreads(m, &mut, &Mutator::fn, 2), std::logic_error);
  EXPECT_EQ(m.size(), w.all.size());
  ASSERT_TRUE(m.validate());
  // Move a tenth of the scene, remove some objects: the split still equals the serial walk.
  cube::scenes::jitter(w.scene, 0.1, 5.0, true, 42);
  m.update();
  for (std::size_t i = 0; i < w.all.size(); i += 97) m.unregisterObject(w.all[i]);
  ASSERT_TRUE(m.validate());
  std::vector<Object*> left;
  m.getObjects(left);
  const Calls serial = serialCalls(m);
  EXPECT_EQ(serial.unorderedSorted(), cube::oracle::bruteSelfPairs(left));
  for (int threads : {2, 3}) EXPECT_EQ(splitCalls(m, threads).calls, serial.calls);
}

}  // namespace
