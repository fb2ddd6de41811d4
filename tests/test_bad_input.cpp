// Bad input: every documented case gives its documented answer, and nothing else
// changes. The oracle for "nothing else changed" is brute force over the objects' AABBs and
// fcl::NaiveCollisionManager's narrow phase.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "support/oracle.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Manager = cube::CubeCollisionManager<S>;
using cube::oracle::Pair;

struct Boom {};

bool noCollide(Object*, Object*, void*) {
  return false;
}
bool noDistance(Object*, Object*, void*, S&) {
  return false;
}

// A row of unit boxes at x = 0, spacing, 2 spacing...: with 0.9, neighbours overlap, others not.
struct World {
  std::vector<std::unique_ptr<Object>> objs;
  explicit World(int n, double spacing = 0.9) {
    auto box = std::make_shared<fcl::Box<S>>(1, 1, 1);
    for (int i = 0; i < n; ++i) {
      objs.push_back(std::make_unique<Object>(box));
      place(i, spacing * i);
    }
  }
  Object* operator[](int i) const { return objs[i].get(); }
  std::vector<Object*> all() const {
    std::vector<Object*> out;
    for (const auto& o : objs) out.push_back(o.get());
    return out;
  }
  void place(int i, double x) {
    objs[i]->setTranslation(fcl::Vector3<S>(x, 0, 0));
    objs[i]->computeAABB();
  }
  void poison(int i) {
    objs[i]->setTranslation(fcl::Vector3<S>(std::nan(""), 0, 0));
    objs[i]->computeAABB();
  }
};

std::vector<Object*> objectsOf(const Manager& m) {
  std::vector<Object*> out;
  m.getObjects(out);
  return out;
}

// The manager answers every query as Naive over `objs` would (self pairs, narrow phase).
void expectAnswersLikeNaive(const Manager& m, const std::vector<Object*>& objs) {
  std::string why;
  ASSERT_TRUE(m.validate(&why)) << why;
  EXPECT_EQ(objectsOf(m), objs);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(objs));
  auto naive = cube::oracle::naiveOf(objs);
  EXPECT_EQ(cube::oracle::collidingPairs(m), cube::oracle::collidingPairs(naive));
}

std::string messageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no std::invalid_argument>";
}

TEST(BadInput, RegisterNullThrowsAndChangesNothing) {
  World w(3);
  Manager m;
  m.registerObject(w[0]);
  const std::string msg = messageOf([&] { m.registerObject(nullptr); });
  EXPECT_NE(msg.find("null"), std::string::npos) << msg;
  expectAnswersLikeNaive(m, {w[0]});
}

TEST(BadInput, RegisterObjectsWithNullRegistersNothingOfTheBatch) {
  World w(4);
  Manager m;
  m.registerObject(w[0]);
  const std::string msg = messageOf([&] { m.registerObjects({w[1], w[2], nullptr, w[3]}); });
  EXPECT_NE(msg.find("entry #2"), std::string::npos) << msg;
  expectAnswersLikeNaive(m, {w[0]});
  // Also on an empty manager, where a batch would be a full build.
  Manager e;
  EXPECT_THROW(e.registerObjects({nullptr, w[1]}), std::invalid_argument);
  expectAnswersLikeNaive(e, {});
}

TEST(BadInput, RegisterNaNThrowsNamingTheObject) {
  World w(3);
  Manager m;
  m.registerObjects({w[0], w[1]});
  w.poison(2);
  const std::string msg = messageOf([&] { m.registerObject(w[2]); });
  EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
  EXPECT_NE(msg.find("#2"), std::string::npos) << msg;  // the index it would have had
  expectAnswersLikeNaive(m, {w[0], w[1]});
}

TEST(BadInput, RegisterGeometryWithNaNSizeThrows) {
  World w(1);
  Manager m;
  m.registerObject(w[0]);
  Object nan_sphere(std::make_shared<fcl::Sphere<S>>(std::nan("")));
  nan_sphere.computeAABB();
  EXPECT_THROW(m.registerObject(&nan_sphere), std::invalid_argument);
  EXPECT_THROW(m.registerObjects({&nan_sphere}), std::invalid_argument);
  expectAnswersLikeNaive(m, {w[0]});
}

TEST(BadInput, RegisterObjectsWithNaNRegistersNothingOfTheBatch) {
  World w(4);
  Manager m;
  m.registerObject(w[0]);
  w.poison(2);
  const std::string msg = messageOf([&] { m.registerObjects({w[1], w[2], w[3]}); });
  EXPECT_NE(msg.find("entry #1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
  expectAnswersLikeNaive(m, {w[0]});
}

// The AABBs are read once, as the batch is registered: a NaN one late in a large batch undoes
// what was read before it, on a manager that keeps its pipeline records and on an empty one
// (where the batch would have been a build), and the same batch registers once it is mended.
TEST(BadInput, RegisterObjectsWithNaNLateInALargeBatchUndoesEverythingItRead) {
  World w(600);
  const std::vector<Object*> all = w.all();
  const std::vector<Object*> first(all.begin(), all.begin() + 100);
  Manager kept;
  kept.registerObjects(first);
  fcl::CollisionRequest<S> request;
  request.num_max_contacts = 100000;
  const std::size_t before = cube::collideAll<S>(kept, request).numContacts();
  ASSERT_GT(before, 0u);
  Manager empty;
  w.poison(400);
  for (Manager* m : {&kept, &empty}) {
    const std::string msg = messageOf([&] { m->registerObjects(all); });
    EXPECT_NE(msg.find("entry #400"), std::string::npos) << msg;
    EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
  }
  expectAnswersLikeNaive(kept, first);
  EXPECT_EQ(cube::collideAll<S>(kept, request).numContacts(), before);
  expectAnswersLikeNaive(empty, {});
  w.place(400, 0.9 * 400);
  for (Manager* m : {&kept, &empty}) {
    m->registerObjects(all);
    expectAnswersLikeNaive(*m, all);
  }
  fcl::DefaultCollisionData<S> naive_data;
  naive_data.request = request;
  auto naive = cube::oracle::naiveOf(all);
  naive.collide(&naive_data, fcl::DefaultCollisionFunction<S>);
  EXPECT_EQ(cube::collideAll<S>(kept, request).numContacts(), naive_data.result.numContacts());
}

// A batch that names new objects more than once registers each once, in the order of its first
// entry, whether its ids are fresh or recycled from unregistered objects and whether the batch
// is small or large; one with a NaN entry after such repeats is undone whole.
TEST(BadInput, RegisterObjectsWithRepeatsRegistersEachOnceOrUndoesTheBatch) {
  World w(300);
  for (const std::size_t size : {std::size_t(6), std::size_t(120)}) {
    Manager m;
    std::vector<Object*> expected;
    for (int i = 0; i < 40; ++i) expected.push_back(w[i]);
    m.registerObjects(expected);
    // Ids to recycle: every other one of the first 20.
    for (int i = 0; i < 20; i += 2) m.unregisterObject(w[i]);
    std::vector<Object*> kept;
    for (int i = 0; i < 40; ++i)
      if (i >= 20 || i % 2 == 1) kept.push_back(w[i]);
    expectAnswersLikeNaive(m, kept);
    // New objects 100.., each twice (the second time further on), and a registered one.
    std::vector<Object*> batch;
    std::vector<Object*> fresh;
    for (std::size_t k = 0; k < size; ++k) {
      fresh.push_back(w[int(100 + k)]);
      batch.push_back(w[int(100 + k)]);
      if (k % 3 == 0) batch.push_back(w[30]);
      if (k >= 2) batch.push_back(w[int(100 + k - 2)]);
    }
    // With a NaN entry at the end: nothing of the batch stays.
    std::vector<Object*> poisoned = batch;
    poisoned.push_back(w[299]);
    w.poison(299);
    EXPECT_NE(messageOf([&] { m.registerObjects(poisoned); }).find("NaN"), std::string::npos);
    expectAnswersLikeNaive(m, kept);
    w.place(299, 0.9 * 299);
    m.registerObjects(batch);
    std::vector<Object*> all = kept;
    all.insert(all.end(), fresh.begin(), fresh.end());
    expectAnswersLikeNaive(m, all);
  }
}

// Null entries are found before any AABB is read: a batch with a NaN entry before a null one
// names the null one.
TEST(BadInput, RegisterObjectsNamesANullEntryBeforeAnEarlierNaNOne) {
  World w(4);
  Manager m;
  w.poison(1);
  const std::string msg = messageOf([&] { m.registerObjects({w[0], w[1], w[2], nullptr}); });
  EXPECT_NE(msg.find("entry #3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("null"), std::string::npos) << msg;
  expectAnswersLikeNaive(m, {});
}

// Objects 0..4 in a row; object 1 gets a NaN AABB while 3 moves onto 0. The update must throw
// naming object 1, keep 1's previous AABB (it still overlaps 0 and 2) and take 3's new one.
class NaNUpdate : public ::testing::Test {
 protected:
  World w{5};
  Manager m;
  void SetUp() override {
    m.registerObjects(w.all());
    w.poison(1);
    w.place(3, 0.1);
  }
  void expectOneKeptThreeMoved(const std::string& msg) {
    EXPECT_NE(msg.find("object #1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
    std::string why;
    ASSERT_TRUE(m.validate(&why)) << why;
    ASSERT_EQ(objectsOf(m), w.all());
    // Expected pairs with 1 at its old place (x = 0.9) and 3 at its new one (x = 0.1).
    auto u = [](Object* a, Object* b) { return cube::oracle::unordered(a, b); };
    std::vector<Pair<S>> want = {u(w[0], w[1]), u(w[1], w[2]), u(w[0], w[3]), u(w[1], w[3])};
    std::sort(want.begin(), want.end());
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    // Per-object queries see the same cached AABB of object 1.
    cube::oracle::Calls<S> c;
    m.collide(w[2], &c, &cube::oracle::Calls<S>::record);
    EXPECT_EQ(c.unorderedSorted(), std::vector<Pair<S>>({u(w[1], w[2])}));
    // Once its pose is valid again, an update takes it.
    w.place(1, 10);
    m.update(w[1]);
    want = {u(w[0], w[3])};
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    expectAnswersLikeNaive(m, w.all());
  }
};

TEST_F(NaNUpdate, UpdateAll) {
  expectOneKeptThreeMoved(messageOf([&] { m.update(); }));
}

TEST_F(NaNUpdate, UpdateObject) {
  expectOneKeptThreeMoved(messageOf([&] {
    m.update(w[3]);
    m.update(w[1]);
  }));
}

TEST_F(NaNUpdate, UpdateVectorBadOneFirst) {
  expectOneKeptThreeMoved(messageOf([&] { m.update(std::vector<Object*>{w[1], w[3]}); }));
}

TEST_F(NaNUpdate, UpdateVectorBadOneLast) {
  expectOneKeptThreeMoved(messageOf([&] { m.update(std::vector<Object*>{w[3], w[1]}); }));
}

TEST(BadInput, DoubleRegistrationHasNoEffect) {
  World w(4);
  Manager m;
  m.registerObject(w[0]);
  m.registerObject(w[0]);
  m.registerObjects({w[1], w[0], w[1], w[2]});
  m.registerObjects({w[2], w[2]});
  m.registerObject(w[1]);
  EXPECT_EQ(m.size(), 3u);
  expectAnswersLikeNaive(m, {w[0], w[1], w[2]});  // selfPairs keeps duplicates, so they'd show
  // Unregistering once removes it for good: no ghost copy left behind.
  m.unregisterObject(w[1]);
  expectAnswersLikeNaive(m, {w[0], w[2]});
  cube::oracle::Calls<S> c;
  m.collide(w[1], &c, &cube::oracle::Calls<S>::record);
  for (const auto& p : c.calls) EXPECT_NE(p.first, w[1]);
  // The same into an empty manager, where a batch skips the lookups of registered objects.
  Manager fresh;
  fresh.registerObjects({w[3], w[0], w[3], w[0], w[2]});
  EXPECT_EQ(fresh.size(), 3u);
  expectAnswersLikeNaive(fresh, {w[3], w[0], w[2]});
}

TEST(BadInput, RegisteringAgainAnObjectWhoseAABBWentNaNHasNoEffect) {
  World w(3);
  Manager m;
  m.registerObjects({w[0], w[1], w[2]});
  w.poison(1);
  // Already registered: both calls leave it as it was, with its old AABB; neither throws.
  EXPECT_NO_THROW(m.registerObject(w[1]));
  EXPECT_NO_THROW(m.registerObjects({w[1], w[2]}));
  EXPECT_EQ(m.size(), 3u);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
  std::vector<Object*> objs;
  m.getObjects(objs);
  EXPECT_EQ(objs, (std::vector<Object*>{w[0], w[1], w[2]}));
}

TEST(BadInput, UnknownObjectsHaveNoEffectEvenOnAnEmptyManager) {
  World w(4);
  Manager e;
  e.unregisterObject(w[0]);
  e.unregisterObject(nullptr);
  e.update(w[0]);
  e.update(static_cast<Object*>(nullptr));
  e.update(std::vector<Object*>{w[0], nullptr});
  e.update();
  e.setup();
  expectAnswersLikeNaive(e, {});
  EXPECT_TRUE(e.empty());

  Manager m;
  m.registerObjects({w[0], w[1]});
  w.place(3, 0.5);  // unknown and moved: must not appear
  m.unregisterObject(w[3]);
  m.update(w[3]);
  m.update(std::vector<Object*>{w[3], nullptr});
  m.unregisterObject(nullptr);
  expectAnswersLikeNaive(m, {w[0], w[1]});
  // An unknown object with a NaN AABB is ignored too, not reported.
  w.poison(2);
  EXPECT_NO_THROW(m.update(w[2]));
  EXPECT_NO_THROW(m.update(std::vector<Object*>{w[2]}));
  EXPECT_NO_THROW(m.unregisterObject(w[2]));
  expectAnswersLikeNaive(m, {w[0], w[1]});
}

// Every query kind with a callback that throws on its k-th call.
class ThrowingCallback : public ::testing::TestWithParam<int> {};

TEST_P(ThrowingCallback, ExceptionReachesCallerAndManagerStaysUsable) {
  World w(12, 0.3);  // each box overlaps three neighbours on each side
  Manager m;
  m.registerObjects(w.all());
  Manager other;
  World w2(6, 0.3);
  other.registerObjects(w2.all());
  fcl::NaiveCollisionManager<S> naive_other;
  naive_other.registerObjects(w2.all());
  static int countdown;
  auto c = [](Object*, Object*, void*) -> bool {
    if (--countdown <= 0) throw Boom();
    return false;
  };
  auto d = [](Object*, Object*, void*, S&) -> bool {
    if (--countdown <= 0) throw Boom();
    return false;  // dist left as is, so that every pair is visited
  };
  for (int k = 1; k <= 3; ++k) {
    countdown = k;
    switch (GetParam()) {
      case 0:
        EXPECT_THROW(m.collide(nullptr, +c), Boom);
        break;
      case 1:
        EXPECT_THROW(m.distance(nullptr, +d), Boom);
        break;
      case 2:
        EXPECT_THROW(m.collide(w[5], nullptr, +c), Boom);
        break;
      case 3:
        EXPECT_THROW(m.distance(w[5], nullptr, +d), Boom);
        break;
      case 4:
        EXPECT_THROW(m.collide(&other, nullptr, +c), Boom);
        break;
      case 5:
        EXPECT_THROW(m.distance(&other, nullptr, +d), Boom);
        break;
      case 6:
        EXPECT_THROW(m.collide(&naive_other, nullptr, +c), Boom);
        break;
      default:
        EXPECT_THROW(m.distance(&naive_other, nullptr, +d), Boom);
        break;
    }
    expectAnswersLikeNaive(m, w.all());
    // And it keeps working for mutations too.
    w.place(0, 100);
    m.update(w[0]);
    expectAnswersLikeNaive(m, w.all());
    w.place(0, 0);
    m.update();
    expectAnswersLikeNaive(m, w.all());
  }
}

INSTANTIATE_TEST_SUITE_P(EveryQuery, ThrowingCallback, ::testing::Range(0, 8));

TEST(BadInput, QueryObjectWithNaNAABBThrows) {
  World w(3);
  Manager m;
  m.registerObjects({w[0], w[1]});
  w.poison(2);
  EXPECT_NE(messageOf([&] { m.collide(w[2], nullptr, noCollide); }).find("NaN"), std::string::npos);
  EXPECT_THROW(m.distance(w[2], nullptr, noDistance), std::invalid_argument);
  EXPECT_THROW(m.collide(w[2], [](Object*, Object*) {}), std::invalid_argument);
  // A NaN object inside another kind of manager is a query object too.
  fcl::NaiveCollisionManager<S> naive;
  naive.registerObject(w[2]);
  EXPECT_THROW(m.collide(&naive, nullptr, noCollide), std::invalid_argument);
  EXPECT_THROW(m.distance(&naive, nullptr, noDistance), std::invalid_argument);
  // A registered object whose pose went NaN is refused as a query object as well.
  w.poison(0);
  EXPECT_THROW(m.collide(w[0], nullptr, noCollide), std::invalid_argument);
  w.place(0, 0);
  expectAnswersLikeNaive(m, {w[0], w[1]});
}

TEST(BadInput, NullQueryObjectManagerOrCallbackThrows) {
  World w(3);
  Manager m;
  m.registerObjects(w.all());
  Object* none = nullptr;
  fcl::BroadPhaseCollisionManager<S>* no_manager = nullptr;
  EXPECT_THROW(m.collide(none, nullptr, noCollide), std::invalid_argument);
  EXPECT_THROW(m.distance(none, nullptr, noDistance), std::invalid_argument);
  EXPECT_THROW(m.collide(no_manager, nullptr, noCollide), std::invalid_argument);
  EXPECT_THROW(m.distance(no_manager, nullptr, noDistance), std::invalid_argument);
  const fcl::CollisionCallBack<S> no_c = nullptr;
  const fcl::DistanceCallBack<S> no_d = nullptr;
  EXPECT_THROW(m.collide(nullptr, no_c), std::invalid_argument);
  EXPECT_THROW(m.distance(nullptr, no_d), std::invalid_argument);
  EXPECT_THROW(m.collide(w[0], nullptr, no_c), std::invalid_argument);
  EXPECT_THROW(m.distance(w[0], nullptr, no_d), std::invalid_argument);
  EXPECT_THROW(m.collide(&m, nullptr, no_c), std::invalid_argument);
  EXPECT_THROW(m.distance(&m, nullptr, no_d), std::invalid_argument);
  // Also on an empty manager, where a query has nothing to do.
  Manager e;
  EXPECT_THROW(e.collide(nullptr, no_c), std::invalid_argument);
  EXPECT_THROW(e.collide(none, nullptr, noCollide), std::invalid_argument);
  EXPECT_THROW(e.collide(no_manager, nullptr, noCollide), std::invalid_argument);
  expectAnswersLikeNaive(m, w.all());
}

TEST(BadInput, QueryAgainstEmptyManagerReadsNoQueryObject) {
  World w(3);
  w.poison(0);
  int calls = 0;
  auto counting = [](Object*, Object*, void* c) {
    ++*static_cast<int*>(c);
    return false;
  };
  auto counting_d = [](Object*, Object*, void* c, S&) {
    ++*static_cast<int*>(c);
    return false;
  };
  Manager e;
  e.setup();
  EXPECT_NO_THROW(e.collide(w[0], &calls, counting));
  EXPECT_NO_THROW(e.distance(w[0], &calls, counting_d));
  // Another manager's NaN object is not read either while this one is empty.
  fcl::NaiveCollisionManager<S> naive;
  naive.registerObject(w[0]);
  EXPECT_NO_THROW(e.collide(&naive, &calls, counting));
  EXPECT_NO_THROW(e.distance(&naive, &calls, counting_d));
  EXPECT_EQ(calls, 0);
  // Null pointers are still refused, and once there is an object to pair with, so is the NaN.
  const fcl::CollisionCallBack<S> no_c = nullptr;
  EXPECT_THROW(e.collide(static_cast<Object*>(nullptr), nullptr, noCollide), std::invalid_argument);
  EXPECT_THROW(e.collide(w[1], nullptr, no_c), std::invalid_argument);
  e.registerObject(w[1]);
  EXPECT_THROW(e.collide(w[0], &calls, counting), std::invalid_argument);
  EXPECT_THROW(e.distance(w[0], &calls, counting_d), std::invalid_argument);
  EXPECT_THROW(e.collide(&naive, &calls, counting), std::invalid_argument);
  EXPECT_EQ(calls, 0);
  expectAnswersLikeNaive(e, {w[1]});
}

}  // namespace
