// Bad input to the manager throws std::invalid_argument and changes nothing; benign misuse has no
// effect.

#include <gtest/gtest.h>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

// Bad input throws std::invalid_argument and changes nothing; benign misuse has no effect.
TYPED_TEST(Semantics, BadInputThrowsAndChangesNothing) {
  using S = TypeParam;
  auto sc = scene<S>(100, 81);
  auto objs = sc.pointers();
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  const auto pairs = oracle::selfPairs<S>(cube);
  auto nan = boxes<S>({{V3<S>(0, 0, 0), V3<S>(1, 1, 1)}, {V3<S>(0, 0, 0), V3<S>(1, 1, 1)}});
  nan[0]->setNaN();
  auto ok = boxes<S>({{V3<S>(0, 0, 0), V3<S>(1, 1, 1)}});
  auto unchanged = [&]() {
    EXPECT_EQ(cube.size(), objs.size());
    EXPECT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), pairs);
  };
  EXPECT_THROW(cube.registerObject(nullptr), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObject(nan[0].get()), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObjects({ok[0].get(), nullptr}), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObjects({ok[0].get(), nan[0].get()}), std::invalid_argument);
  unchanged();
  std::vector<Obj<S>*> big_batch(objs.begin(), objs.end());  // large batch: rebuild path
  big_batch.push_back(ok[0].get());
  big_batch.push_back(nullptr);
  CubeCollisionManager<S> fresh;
  EXPECT_THROW(fresh.registerObjects(big_batch), std::invalid_argument);
  EXPECT_TRUE(fresh.empty());
  EXPECT_THROW(cube.collide(nan[0].get(), [](Obj<S>*, Obj<S>*) {}), std::invalid_argument);
  EXPECT_THROW(cube.distance(nan[0].get(), [](Obj<S>*, Obj<S>*, S&) {}), std::invalid_argument);
  EXPECT_THROW(cube.collide(static_cast<Obj<S>*>(nullptr), [](Obj<S>*, Obj<S>*) {}),
               std::invalid_argument);
  // Registering twice, unregistering or updating an unknown object: no effect.
  cube.registerObject(objs[5]);
  cube.registerObjects({objs[6], objs[6]});
  unchanged();
  cube.unregisterObject(nan[1].get());
  cube.unregisterObject(nullptr);
  cube.update(nan[1].get());
  unchanged();
  // A registered object whose AABB became NaN: update(obj) throws and keeps the old box.
  auto victim = boxes<S>({{V3<S>(0, 0, 0), V3<S>(10, 10, 10)}});
  cube.registerObject(victim[0].get());
  objs.push_back(victim[0].get());
  const auto with_victim = oracle::bruteSelfPairs(objs);
  victim[0]->setNaN();
  EXPECT_THROW(cube.update(victim[0].get()), std::invalid_argument);
  EXPECT_TRUE(valid(cube));
  EXPECT_THROW(cube.update(), std::invalid_argument);
  EXPECT_THROW(cube.update(std::vector<Obj<S>*>{objs[0], victim[0].get()}), std::invalid_argument);
  EXPECT_TRUE(valid(cube));
  EXPECT_EQ(oracle::selfPairs<S>(cube), with_victim) << "the NaN object keeps its old box";
}

}  // namespace
}  // namespace testing
}  // namespace cube
