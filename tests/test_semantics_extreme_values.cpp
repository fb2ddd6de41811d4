// Values at the ends of the floating-point range: boxes beyond float's range inside the cubes, and
// distances whose squares overflow double; answers stay brute force's.

#include <gtest/gtest.h>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

// With unbounded_limit beyond float's range, boxes past float's range stay in the cubes, where
// their bounds round to float infinities: a box spanning both has no centre (inf - inf). The
// build must still order every object (its centre counts as 0) and answer like brute force.
TEST(Semantics, BoxesBeyondFloatRangeInsideTheCubes) {
  using S = double;
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  for (int i = 0; i < 300; ++i) {
    const S x = S(i % 17), y = S(i % 5), z = S(i / 17);
    if (i % 10 == 0)
      corners.emplace_back(V3<S>(-1e39, y, z), V3<S>(1e39, y + 1, z + 1));  // both infinities
    else if (i % 10 == 5)
      corners.emplace_back(V3<S>(x, 1e39, z), V3<S>(x + 1, 2e39, z + 1));  // +inf only
    else
      corners.emplace_back(V3<S>(x, y, z), V3<S>(x + 1.5, y + 1.5, z + 1.5));
  }
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  const auto brute = oracle::bruteSelfPairs(ptrs);
  Config c;
  c.unbounded_limit = 1e300;
  for (int leaf_size : {1, 4, 16}) {
    c.leaf_size = leaf_size;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(ptrs);
    cube.setup();
    ASSERT_TRUE(valid(cube));
    EXPECT_TRUE(::cube::detail::coreOf(cube).unboundedItems().empty());  // all in the cubes
    EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
    EXPECT_EQ(cubeObjectCalls<S>(cube, ptrs[30]), bruteCrossPairs<S>(ptrs, {ptrs[30]}));
  }
  EXPECT_GT(brute.size(), 500u);
}

// Gaps beyond 1.3e154 square to infinity in double: the walk must still find the nearest pair
// when the best distance so far is itself that large (self, object and manager queries), and
// not stop after the first pair it happens to visit.
TEST(Semantics, DistancesWhoseSquaresOverflow) {
  using S = double;
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  // Boxes 1e200 apart along x, except one pair 3e199 apart (#11, #12), with sizes of 1e199.
  for (int i = 0; i < 40; ++i) {
    const S x = (i <= 11 ? S(i) : S(i) - 0.7) * 1e200;
    const S y = S(i % 3) * 1e199;
    corners.emplace_back(V3<S>(x, y, 0), V3<S>(x + 1e199, y + 1e199, 1e199));
  }
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  // The exact gap of two objects' boxes, without squaring (hypot).
  const auto gap = [](Obj<S>* a, Obj<S>* b) {
    S d[3];
    for (int k = 0; k < 3; ++k)
      d[k] = std::max({S(0), a->getAABB().min_[k] - b->getAABB().max_[k],
                       b->getAABB().min_[k] - a->getAABB().max_[k]});
    return std::hypot(d[0], std::hypot(d[1], d[2]));
  };
  S want = std::numeric_limits<S>::max();
  for (std::size_t i = 0; i < ptrs.size(); ++i)
    for (std::size_t j = i + 1; j < ptrs.size(); ++j) want = std::min(want, gap(ptrs[i], ptrs[j]));
  ASSERT_GT(want, 1e154);
  ASSERT_LT(want, 0.5e200);
  struct Search {
    S (*measure)(Obj<S>*, Obj<S>*);
    S best = std::numeric_limits<S>::max();
  };
  const auto fn = [](Obj<S>* a, Obj<S>* b, void* data, S& dist) {
    auto& s = *static_cast<Search*>(data);
    if (a != b) s.best = std::min(s.best, s.measure(a, b));
    dist = s.best;
    return false;
  };
  Config c;
  c.unbounded_limit = 1e300;  // keep them in the cubes
  for (int leaf_size : {1, 4}) {
    c.leaf_size = leaf_size;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(ptrs);
    cube.setup();
    ASSERT_TRUE(valid(cube));
    Search self{+gap};
    cube.distance(&self, fn);
    EXPECT_EQ(self.best, want) << "self, leaf size " << leaf_size;
    Search one{+gap};
    CubeCollisionManager<S> others(c);
    for (std::size_t i = 0; i < ptrs.size(); ++i)
      if (i != 12) others.registerObject(ptrs[i]);
    others.setup();
    others.distance(ptrs[12], &one, fn);
    EXPECT_EQ(one.best, want) << "object, leaf size " << leaf_size;
    Search cross{+gap};
    CubeCollisionManager<S> single(c);
    single.registerObject(ptrs[12]);
    single.setup();
    others.distance(&single, &cross, fn);
    EXPECT_EQ(cross.best, want) << "manager, leaf size " << leaf_size;
  }
}

}  // namespace
}  // namespace testing
}  // namespace cube
