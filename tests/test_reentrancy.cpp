// A manager used from inside a callback of one of its own queries: const queries answer as
// outside, the guard holds after nested queries and on every thread, an uninvolved manager may be
// mutated, user exceptions pass unchanged; and user code off the query path (the pair predicate
// of continuous queries and of a split collideAll, collideConcurrently's callbacks) cannot mutate.
//
// Oracles: brute force over the objects' AABBs and fcl::NaiveCollisionManager (support/oracle.h).

#include <fcl/geometry/shape/box.h>
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cube_collision/continuous.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "support/reentrancy_world.h"

namespace {

using namespace reentrancy;

// Reference answers of every query kind over a scene's current objects, by brute force.
template <typename T>
std::vector<RePair<T>> reBruteFor(ReScene<T>& sc, ReQuery q) {
  switch (q) {
    case ReQuery::collideObj:
    case ReQuery::fnCollideObj:
      return reBruteCross<T>(sc.mine, {sc.query});
    case ReQuery::collideSelf:
    case ReQuery::collideThis:
    case ReQuery::fnCollideSelf:
      return cube::oracle::bruteSelfPairs(sc.mine);
    case ReQuery::collideOther:
    case ReQuery::collideNaive:
    case ReQuery::fnCollideOther:
      return reBruteCross<T>(sc.mine, sc.theirs);
    default:
      return {};  // distance queries: compared with a run outside any callback
  }
}

bool reIsCollide(ReQuery q) {
  return q == ReQuery::collideObj || q == ReQuery::collideSelf || q == ReQuery::collideOther ||
         q == ReQuery::collideThis || q == ReQuery::collideNaive || q == ReQuery::fnCollideSelf ||
         q == ReQuery::fnCollideObj || q == ReQuery::fnCollideOther;
}

// Const queries of the same manager from inside a callback: allowed, and they answer as outside.
TEST(Reentrancy, ConstQueriesInsideACallbackGiveTheRightPairs) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[1], kReScenes[5]}) {
    for (int outer = 0; outer < kReQueries; ++outer) {
      SCOPED_TRACE(std::string(spec.name) + ", outer query " + reQueryName(ReQuery(outer)));
      ReScene<S> sc(spec);
      // What each inner query reports outside any callback.
      std::vector<std::vector<RePair<S>>> want(kReQueries);
      for (int inner = 0; inner < kReQueries; ++inner) {
        ReHook<S> h;
        reRun(sc, ReQuery(inner), h);
        want[inner] = reSorted(h.calls);
        if (reIsCollide(ReQuery(inner))) {
          ASSERT_EQ(want[inner], reBruteFor(sc, ReQuery(inner)))
              << "outside any callback: " << reQueryName(ReQuery(inner));
        }
      }
      ReHook<S> outer_hook;
      std::vector<std::string> wrong;
      outer_hook.on_call = [&](int call) {
        if (call > 2) return;
        for (int inner = 0; inner < kReQueries; ++inner) {
          ReHook<S> h;
          reRun(sc, ReQuery(inner), h);
          if (reSorted(h.calls) != want[inner])
            wrong.push_back(std::string(reQueryName(ReQuery(inner))) + " on call " +
                            std::to_string(call));
        }
      };
      reRun(sc, ReQuery(outer), outer_hook);
      EXPECT_TRUE(wrong.empty()) << "nested queries answering otherwise: " << wrong.size()
                                 << ", first: " << (wrong.empty() ? "" : wrong[0]);
      EXPECT_EQ(reSorted(outer_hook.calls), want[outer]);
      EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
      EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
    }
  }
}

// A nested query returning must not release the outer query's guard: a mutation after it, still
// inside the outer callback, throws as well; once the outer query is over, mutations work.
TEST(Reentrancy, GuardHoldsAfterANestedQueryReturns) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[3]}) {
    SCOPED_TRACE(spec.name);
    ReScene<S> sc(spec);
    ReHook<S> ref;
    reRun(sc, ReQuery::collideOther, ref);
    // Outer: m against other. Inner (on call 1): a self-collide of m and one of other, then a
    // mutation of each.
    ReHook<S> outer;
    std::vector<std::string> messages;
    bool went_through = false;
    outer.on_call = [&](int call) {
      if (call != 1) return;
      EXPECT_EQ(cube::oracle::selfPairs(*sc.m), cube::oracle::bruteSelfPairs(sc.mine));
      EXPECT_EQ(cube::oracle::selfPairs(*sc.other), cube::oracle::bruteSelfPairs(sc.theirs));
      for (ReManager<S>* target : {sc.m.get(), sc.other.get()}) {
        try {
          target->clear();
        } catch (const std::logic_error& e) {
          messages.push_back(e.what());
          continue;
        }
        went_through = true;
        throw ReAbort{};
      }
    };
    try {
      reRun(sc, ReQuery::collideOther, outer);
    } catch (const ReAbort&) {
    }
    ASSERT_FALSE(went_through) << "clear() went through inside the outer callback after a nested "
                                  "query had returned";
    ASSERT_EQ(messages.size(), 2u);
    for (const auto& msg : messages) {
      EXPECT_NE(msg.find("clear"), std::string::npos) << msg;
      EXPECT_NE(msg.find("inside a callback"), std::string::npos) << msg;
    }
    EXPECT_EQ(reSorted(outer.calls), reSorted(ref.calls));
    EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
    EXPECT_EQ(reAnswersLike(*sc.other, sc.theirs, "the other manager"), "");
    EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
    EXPECT_EQ(reMutatesNormally(*sc.other, sc.theirs, "the other manager"), "");
  }
}

// A cube manager that takes no part in the running query may be mutated from its callback.
TEST(Reentrancy, MutatingAnUninvolvedManagerIsAllowed) {
  using Obj = ReObj<S>;
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[5]}) {
    for (int q = 0; q < kReQueries; ++q) {
      SCOPED_TRACE(std::string(spec.name) + ", query " + reQueryName(ReQuery(q)));
      ReScene<S> sc(spec);
      // A third manager with its own objects: a row of unit boxes 0.5 apart.
      std::vector<std::unique_ptr<Obj>> own;
      std::vector<Obj*> xs;
      for (int i = 0; i < 8; ++i) {
        own.push_back(std::make_unique<Obj>(std::make_shared<fcl::Box<S>>(1, 1, 1)));
        own.back()->setTranslation(fcl::Vector3<S>(0.5 * i, 0, 0));
        own.back()->computeAABB();
        xs.push_back(own.back().get());
      }
      ReManager<S> x;
      x.registerObjects({xs[0], xs[1], xs[2], xs[3], xs[4]});
      x.setup();
      ReHook<S> ref;
      reRun(sc, ReQuery(q), ref);

      std::vector<std::string> problems;
      ReHook<S> h;
      h.on_call = [&](int call) {
        if (call != 1) return;
        auto check = [&](const std::vector<Obj*>& want, const char* step) {
          const std::string why = reAnswersLike(x, want, "the third manager");
          if (!why.empty()) problems.push_back(std::string(step) + ": " + why);
        };
        try {
          x.registerObject(xs[5]);
          check({xs[0], xs[1], xs[2], xs[3], xs[4], xs[5]}, "registerObject");
          x.registerObjects({xs[6], xs[7]});
          check({xs[0], xs[1], xs[2], xs[3], xs[4], xs[5], xs[6], xs[7]}, "registerObjects");
          x.unregisterObject(xs[2]);
          const std::vector<Obj*> left = {xs[0], xs[1], xs[3], xs[4], xs[5], xs[6], xs[7]};
          check(left, "unregisterObject");
          x.setup();
          check(left, "setup");
          xs[0]->setTranslation(fcl::Vector3<S>(2.2, 0, 0));
          xs[0]->computeAABB();
          x.update(xs[0]);
          check(left, "update(obj)");
          xs[1]->setTranslation(fcl::Vector3<S>(100, 0, 0));
          xs[1]->computeAABB();
          xs[3]->setTranslation(fcl::Vector3<S>(100.5, 0, 0));
          xs[3]->computeAABB();
          x.update(std::vector<Obj*>{xs[1], xs[3]});
          check(left, "update(vector)");
          xs[4]->setTranslation(fcl::Vector3<S>(99.8, 0, 0));
          xs[4]->computeAABB();
          x.update();
          check(left, "update()");
          x.clear();
          check({}, "clear");
        } catch (const std::exception& e) {
          problems.push_back(std::string("the third manager threw: ") + e.what());
        }
        // The other cube manager, when the query does not walk it, is uninvolved too.
        if (!reWalksOther(ReQuery(q))) {
          try {
            sc.other->unregisterObject(sc.theirs[0]);
            sc.other->registerObject(sc.theirs[0]);
            sc.other->update();
          } catch (const std::exception& e) {
            problems.push_back(std::string("the other manager threw: ") + e.what());
          }
        }
      };
      EXPECT_NO_THROW(reRun(sc, ReQuery(q), h));
      EXPECT_TRUE(problems.empty())
          << problems.size() << " problems, first: " << (problems.empty() ? "" : problems[0]);
      EXPECT_EQ(reSorted(h.calls), reSorted(ref.calls));
      EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
      if (!reWalksOther(ReQuery(q))) {
        std::vector<Obj*> theirs(sc.theirs.begin() + 1, sc.theirs.end());
        theirs.push_back(sc.theirs[0]);
        EXPECT_EQ(reAnswersLike(*sc.other, theirs, "the other manager"), "");
      }
    }
  }
  // The other way round: this manager is mutated from a callback of the other one's query that
  // does not involve it.
  ReScene<S> sc(kReScenes[0]);
  std::string problem;
  sc.other->collide(sc.query, [&](ReObj<S>*, ReObj<S>*) {
    try {
      sc.m->unregisterObject(sc.mine[0]);
      sc.m->registerObject(sc.mine[0]);
    } catch (const std::exception& e) {
      problem = e.what();
    }
  });
  EXPECT_EQ(problem, "");
  std::vector<ReObj<S>*> now(sc.mine.begin() + 1, sc.mine.end());
  now.push_back(sc.mine[0]);
  EXPECT_EQ(reAnswersLike(*sc.m, now, "this manager"), "");
}

// An exception of the user's own type leaves every query kind unchanged, also from a nested
// query, and the managers take mutations afterwards (whatever guard there is was released).
TEST(Reentrancy, UserExceptionsPropagateUnchanged) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[4], kReScenes[5]}) {
    for (int q = 0; q < kReQueries; ++q) {
      for (bool nested : {false, true}) {
        SCOPED_TRACE(std::string(spec.name) + ", query " + reQueryName(ReQuery(q)) +
                     (nested ? ", thrown from a nested self-collide" : ""));
        ReScene<S> sc(spec);
        const bool listed = sc.m->pairsListed();
        ReHook<S> h;
        h.on_call = [&](int call) {
          if (call != 2) return;
          if (!nested) throw ReUserError{q, "from the callback"};
          sc.m->collide([&](ReObj<S>*, ReObj<S>*) { throw ReUserError{q, "from the callback"}; });
        };
        bool caught = false;
        try {
          reRun(sc, ReQuery(q), h);
        } catch (const ReUserError& e) {
          caught = true;
          EXPECT_EQ(e.code, q);
          EXPECT_EQ(e.text, "from the callback");
        } catch (...) {
          ADD_FAILURE() << "another exception than the user's";
        }
        EXPECT_TRUE(caught);
        EXPECT_EQ(h.calls.size(), 2u);
        EXPECT_EQ(sc.m->pairsListed(), listed);
        EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
        EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
        EXPECT_EQ(reMutatesNormally(*sc.other, sc.theirs, "the other manager"), "");
      }
    }
  }
}

// Several threads querying one manager at once, each callback attempting a mutation: every
// attempt throws, every query reports its pairs, and afterwards the manager takes mutations (the
// guard's bookkeeping survived concurrent queries).
TEST(Reentrancy, ConcurrentQueriesEachSeeTheGuard) {
  ReScene<S> sc(kReScenes[0]);
  // Precondition on one thread; without it the threads below would mutate a manager others walk.
  {
    bool threw = false;
    try {
      sc.m->collide([&](ReObj<S>*, ReObj<S>*) {
        try {
          sc.m->setup();
        } catch (const std::logic_error&) {
          threw = true;
          return;
        }
        throw ReAbort{};
      });
    } catch (const ReAbort&) {
    }
    ASSERT_TRUE(threw) << "setup() inside a callback did not throw std::logic_error (one thread)";
  }
  const auto want_self = cube::oracle::bruteSelfPairs(sc.mine);
  const auto want_obj = reBruteCross<S>(sc.mine, {sc.query});
  std::atomic<int> attempts{0}, throws{0}, wrong{0};
  auto worker = [&](int seed) {
    for (int i = 0; i < 300; ++i) {
      std::vector<RePair<S>> got;
      auto cb = [&](ReObj<S>* a, ReObj<S>* b) {
        got.push_back(cube::oracle::unordered(a, b));
        if (got.size() != 1) return;
        ++attempts;
        try {
          sc.m->setup();
        } catch (const std::logic_error&) {
          ++throws;
        }
      };
      if ((i + seed) % 2 == 0) {
        sc.m->collide(cb);
        if (reSorted(got) != want_self) ++wrong;
      } else {
        sc.m->collide(sc.query, cb);
        if (reSorted(got) != want_obj) ++wrong;
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) threads.emplace_back(worker, t);
  for (auto& t : threads) t.join();
  EXPECT_EQ(attempts.load(), 4 * 300);
  EXPECT_EQ(throws.load(), attempts.load());
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
  EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
}

// ---------------------------------------------------------------------------------------------
// User code off the manager's own query path: the pair predicate
// during sweptPairs and continuousCollideAll, and a collideConcurrently callback on whichever
// thread runs it. Every kind of mutation is refused with std::logic_error there too, and the
// manager keeps its objects and passes validate().

struct GuardWorld {
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
  std::unique_ptr<fcl::CollisionObjectd> spare;
  cube::CubeCollisionManagerd m;
  explicit GuardWorld(int n) {
    auto box = std::make_shared<fcl::Boxd>(1, 1, 1);
    for (int i = 0; i < n; ++i) {
      // A row of touching boxes: every neighbour pair overlaps.
      objects.push_back(std::make_unique<fcl::CollisionObjectd>(
          box, fcl::Transform3d(Eigen::Translation3d(0.9 * (i % 40), 0.9 * (i / 40), 0))));
      objects.back()->computeAABB();
      m.registerObject(objects.back().get());
    }
    spare = std::make_unique<fcl::CollisionObjectd>(box);
    spare->computeAABB();
  }
};

constexpr int kGuardMutations = 13;

// Mutation k of m; throws what the manager throws.
void guardMutate(GuardWorld& w, int k) {
  fcl::CollisionObjectd* first = w.objects.front().get();
  std::vector<fcl::CollisionObjectd*> some{first};
  switch (k) {
    case 0:
      w.m.registerObject(w.spare.get());
      return;
    case 1:
      w.m.registerObjects({w.spare.get()});
      return;
    case 2:
      w.m.unregisterObject(first);
      return;
    case 3:
      w.m.setup();
      return;
    case 4:
      w.m.update();
      return;
    case 5:
      w.m.update(first);
      return;
    case 6:
      w.m.update(some);
      return;
    case 7:
      w.m.clear();
      return;
    case 8:
      w.m.setFilter(first, 2, 2);
      return;
    case 9:
      w.m.setPairFilter({});
      return;
    case 10:
      w.m.setMargin(0.5);
      return;
    case 11:
      w.m.setMargin(first, 0.5);
      return;
    case 12:
      w.m.registerObjects({});  // an empty batch too: the manager being queried is not empty
      return;
    default:
      return;
  }
}

// Counts the attempts and the refusals; an attempt that got through is a failure.
struct GuardCount {
  std::atomic<int> tried{0}, refused{0};
  void attempt(GuardWorld& w, int k) {
    ++tried;
    try {
      guardMutate(w, k);
    } catch (const std::logic_error&) {
      ++refused;
    }
  }
};

::testing::AssertionResult unchanged(GuardWorld& w, std::size_t n) {
  std::string why;
  if (w.m.size() != n) return ::testing::AssertionFailure() << w.m.size() << " objects, not " << n;
  if (!w.m.validate(&why)) return ::testing::AssertionFailure() << "validate: " << why;
  if (w.m.filter(w.objects.front().get()).first != 1)
    return ::testing::AssertionFailure() << "bits";
  if (w.m.margin(w.objects.front().get()) != 0) return ::testing::AssertionFailure() << "margin";
  return ::testing::AssertionSuccess();
}

TEST(ReentrancyOffThePath, PredicateOfContinuousQueriesCannotMutate) {
  for (int k = 0; k < kGuardMutations; ++k)
    for (const bool full : {false, true}) {  // sweptPairs, continuousCollideAll
      GuardWorld w(40);
      GuardCount count;
      w.m.setPairFilter([&](fcl::CollisionObjectd*, fcl::CollisionObjectd*) {
        if (count.tried.load() == 0) count.attempt(w, k);
        return true;
      });
      std::vector<cube::Motion<double>> motions(1);
      motions[0].object = w.objects[5].get();
      motions[0].end = fcl::Transform3d(Eigen::Translation3d(4.5, 0.3, 0));
      if (full)
        cube::continuousCollideAll(w.m, motions);
      else
        cube::sweptPairs(w.m, motions);
      EXPECT_EQ(count.tried.load(), 1) << "mutation " << k << " full " << full;
      EXPECT_EQ(count.refused.load(), 1) << "mutation " << k << " full " << full;
      EXPECT_TRUE(unchanged(w, 40)) << "mutation " << k << " full " << full;
    }
}

// collideAll runs no user callback, but the manager's pair predicate: with the walk split over
// threads (split_walk, 5,000 objects) it is still asked on the calling thread, inside the
// query's guard, and every mutation from it is refused.
TEST(ReentrancyOffThePath, PredicateDuringASplitCollideAllCannotMutate) {
  for (int k = 0; k < kGuardMutations; ++k) {
    GuardWorld w(5000);
    GuardCount count;
    w.m.setPairFilter([&](fcl::CollisionObjectd*, fcl::CollisionObjectd*) {
      if (count.tried.load() < 50) count.attempt(w, k);
      return true;
    });
    fcl::CollisionRequestd all;
    all.num_max_contacts = 1 << 30;
    cube::NarrowPhaseOptions<double> o;
    o.threads = 2;
    o.split_walk = true;
    const auto r = cube::collideAll<double>(w.m, all, o);
    EXPECT_GT(r.numContacts(), 1000u);
    EXPECT_EQ(count.tried.load(), 50) << "mutation " << k;
    EXPECT_EQ(count.refused.load(), 50) << "mutation " << k;
    EXPECT_TRUE(unchanged(w, 5000)) << "mutation " << k;
  }
}

TEST(ReentrancyOffThePath, CollideConcurrentlyCallbacksCannotMutateOnAnyThread) {
  struct Data {
    GuardWorld* w;
    GuardCount* count;
    int k;
    std::atomic<int> on_other_threads{0};
    std::thread::id caller;
  };
  int on_workers = 0;  // over all runs: one run's worker may get no pair on a loaded machine
  for (int k = 0; k < kGuardMutations; ++k)
    for (const int threads : {1, 2, 3}) {
      GuardWorld w(1500);
      GuardCount count;
      Data d{&w, &count, k, {}, std::this_thread::get_id()};
      cube::collideConcurrently<double>(
          w.m, &d,
          [](fcl::CollisionObjectd*, fcl::CollisionObjectd*, void* p) {
            auto& x = *static_cast<Data*>(p);
            if (std::this_thread::get_id() != x.caller) ++x.on_other_threads;
            x.count->attempt(*x.w, x.k);
            return false;
          },
          threads);
      EXPECT_GT(count.tried.load(), 1000) << "mutation " << k;
      EXPECT_EQ(count.refused.load(), count.tried.load())
          << "mutation " << k << " threads " << threads;
      on_workers += d.on_other_threads.load();
      EXPECT_TRUE(unchanged(w, 1500)) << "mutation " << k << " threads " << threads;
    }
  if (cube::hardwareThreads() > 1) {
    EXPECT_GT(on_workers, 0) << "no callback ran on a worker";
  }
}

}  // namespace
