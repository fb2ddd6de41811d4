// The one-call helpers of queries.h against fcl::NaiveCollisionManager on the same objects.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"
#include "support/oracle.h"

namespace {

template <typename S>
using Obj = fcl::CollisionObject<S>;
template <typename S>
using Pairs = std::vector<cube::oracle::Pair<S>>;

template <typename S>
Pairs<S> unorderedSorted(const std::vector<cube::ObjectPair<S>>& pairs) {
  Pairs<S> out;
  for (const auto& p : pairs) out.push_back(cube::oracle::unordered(p.first, p.second));
  std::sort(out.begin(), out.end());
  return out;
}

// Contacts as sorted unordered geometry pairs: comparable whatever the call order.
template <typename S>
std::vector<std::pair<const void*, const void*>> contactPairs(const fcl::CollisionResult<S>& r) {
  std::vector<std::pair<const void*, const void*>> out;
  for (std::size_t i = 0; i < r.numContacts(); ++i) {
    const void* a = r.getContact(i).o1;
    const void* b = r.getContact(i).o2;
    out.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(out.begin(), out.end());
  return out;
}

template <typename S>
cube::scenes::Scene<S> scene(std::size_t n, std::uint32_t seed, double size_scale = 1.0) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.size_scale = size_scale;
  o.overlaps_per_object = 2.0;
  return cube::scenes::makeScene<S>(o);
}

template <typename S>
fcl::CollisionRequest<S> everyContact() {
  fcl::CollisionRequest<S> r;
  r.num_max_contacts = std::numeric_limits<std::size_t>::max();
  return r;
}

template <typename S>
void expectNear(S actual, S expected) {
  const S tol = std::is_same<S, float>::value ? S(1e-4) : S(1e-6);
  EXPECT_NEAR(actual, expected, tol * std::max(S(1), std::abs(expected)));
}

template <typename S>
class Queries : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Queries, Scalars);

TYPED_TEST(Queries, OverlappingPairsSelfMatchesNaiveAndBruteForce) {
  using S = TypeParam;
  auto sc = scene<S>(400, 11);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  auto naive = cube::oracle::naiveOf(sc.pointers());

  const auto got = unorderedSorted(cube::overlappingPairs(cube_m));
  const auto brute = cube::oracle::bruteSelfPairs(sc.pointers());
  ASSERT_FALSE(brute.empty());
  EXPECT_EQ(got, brute);
  EXPECT_EQ(unorderedSorted(cube::overlappingPairs(naive)), brute);
}

TYPED_TEST(Queries, OverlappingPairsObjectQueryIsManagedThenQuery) {
  using S = TypeParam;
  auto sc = scene<S>(400, 12);
  auto probes = scene<S>(60, 13);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  std::size_t total = 0;
  for (auto* q : probes.pointers()) {
    const auto got = cube::overlappingPairs(cube_m, q);
    for (const auto& p : got) EXPECT_EQ(p.second, q);
    // fcl::NaiveCollisionManager hands every object to an object query's callback, unfiltered,
    // so the expected candidates are filtered here.
    std::vector<cube::ObjectPair<S>> expected;
    for (auto* o : sc.pointers())
      if (o->getAABB().overlap(q->getAABB())) expected.emplace_back(o, q);
    EXPECT_EQ(unorderedSorted(got), unorderedSorted(expected));
    total += got.size();
  }
  EXPECT_GT(total, 0u);
}

TYPED_TEST(Queries, OverlappingPairsManagerVsManagerAnyType) {
  using S = TypeParam;
  auto a = scene<S>(300, 14);
  auto b = scene<S>(300, 15);
  cube::CubeCollisionManager<S> cube_a;
  cube_a.registerObjects(a.pointers());
  auto naive_a = cube::oracle::naiveOf(a.pointers());
  auto naive_b = cube::oracle::naiveOf(b.pointers());
  fcl::DynamicAABBTreeCollisionManager<S> tree_b;
  tree_b.registerObjects(b.pointers());
  tree_b.setup();

  const auto expected = cube::overlappingPairs(naive_a, naive_b);
  ASSERT_FALSE(expected.empty());
  const auto with_naive = cube::overlappingPairs(cube_a, naive_b);
  const auto with_tree = cube::overlappingPairs(cube_a, tree_b);
  // Order within each pair is (object of this manager, object of the other).
  const auto a_objs = a.pointers();
  for (const auto& p : with_tree)
    EXPECT_NE(std::find(a_objs.begin(), a_objs.end(), p.first), a_objs.end());
  auto sorted = [](std::vector<cube::ObjectPair<S>> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  EXPECT_EQ(sorted(with_naive), sorted(expected));
  EXPECT_EQ(sorted(with_tree), sorted(expected));
}

TYPED_TEST(Queries, CollideAllMergesEveryContactLikeNaive) {
  using S = TypeParam;
  auto sc = scene<S>(400, 16);
  auto probes = scene<S>(100, 17);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  auto naive = cube::oracle::naiveOf(sc.pointers());
  auto naive_probes = cube::oracle::naiveOf(probes.pointers());
  const auto req = everyContact<S>();

  const auto self = cube::collideAll(cube_m, req);
  const auto self_naive = cube::collideAll(naive, req);
  ASSERT_TRUE(self_naive.isCollision());
  EXPECT_EQ(contactPairs(self), contactPairs(self_naive));
  // Exhaustive narrow phase over all pairs, as the oracle does it.
  EXPECT_EQ(contactPairs(self).size(), cube::oracle::collidingPairs(naive).size());

  std::size_t query_contacts = 0;
  for (auto* q : probes.pointers()) {
    const auto got = cube::collideAll(cube_m, q, req);
    EXPECT_EQ(contactPairs(got), contactPairs(cube::collideAll(naive, q, req)));
    query_contacts += got.numContacts();
  }
  EXPECT_GT(query_contacts, 0u);

  const auto mvm = cube::collideAll(cube_m, naive_probes, req);
  const auto mvm_naive = cube::collideAll(naive, naive_probes, req);
  EXPECT_TRUE(mvm_naive.isCollision());
  EXPECT_EQ(contactPairs(mvm), contactPairs(mvm_naive));
}

TYPED_TEST(Queries, CollideAllDefaultRequestStopsAtFirstContact) {
  using S = TypeParam;
  auto sc = scene<S>(400, 18);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  auto naive = cube::oracle::naiveOf(sc.pointers());
  ASSERT_GT(cube::oracle::collidingPairs(naive).size(), 1u);
  const auto r = cube::collideAll(cube_m);
  EXPECT_TRUE(r.isCollision());
  EXPECT_EQ(r.numContacts(), 1u);

  // A scene where nothing touches: no contact from either.
  auto sparse = scene<S>(400, 19, 0.05);
  cube::CubeCollisionManager<S> cube_sparse;
  cube_sparse.registerObjects(sparse.pointers());
  auto naive_sparse = cube::oracle::naiveOf(sparse.pointers());
  ASSERT_TRUE(cube::oracle::collidingPairs(naive_sparse).empty());
  EXPECT_FALSE(cube::collideAll(cube_sparse, everyContact<S>()).isCollision());
}

TYPED_TEST(Queries, MinimumDistanceMatchesNaive) {
  using S = TypeParam;
  auto sc = scene<S>(300, 20, 0.1);
  auto probes = scene<S>(40, 21, 0.1);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  auto naive = cube::oracle::naiveOf(sc.pointers());
  auto naive_probes = cube::oracle::naiveOf(probes.pointers());

  const auto self_naive = cube::minimumDistance(naive);
  ASSERT_GT(self_naive.min_distance, S(0));
  const auto self = cube::minimumDistance(cube_m);
  expectNear(self.min_distance, self_naive.min_distance);

  for (auto* q : probes.pointers())
    expectNear(cube::minimumDistance(cube_m, q).min_distance,
               cube::minimumDistance(naive, q).min_distance);

  const auto mvm_naive = cube::minimumDistance(naive, naive_probes);
  ASSERT_GT(mvm_naive.min_distance, S(0));
  expectNear(cube::minimumDistance(cube_m, naive_probes).min_distance, mvm_naive.min_distance);
}

TYPED_TEST(Queries, MinimumDistanceNearestPointsAreOnTheNearestPair) {
  using S = TypeParam;
  auto sc = scene<S>(200, 22, 0.1);
  cube::CubeCollisionManager<S> cube_m;
  cube_m.registerObjects(sc.pointers());
  fcl::DistanceRequest<S> req;
  req.enable_nearest_points = true;
  const auto r = cube::minimumDistance(cube_m, req);
  ASSERT_GT(r.min_distance, S(0));
  ASSERT_NE(r.o1, nullptr);
  ASSERT_NE(r.o2, nullptr);
  const S gap = (r.nearest_points[0] - r.nearest_points[1]).norm();
  expectNear(gap, r.min_distance);
}

TYPED_TEST(Queries, EmptyAndSingleObjectManagers) {
  using S = TypeParam;
  auto sc = scene<S>(1, 23);
  cube::CubeCollisionManager<S> empty, single;
  single.registerObjects(sc.pointers());
  for (auto* m : {&empty, &single}) {
    EXPECT_TRUE(cube::overlappingPairs(*m).empty());
    EXPECT_FALSE(cube::collideAll(*m, everyContact<S>()).isCollision());
    EXPECT_EQ(cube::minimumDistance(*m).min_distance, std::numeric_limits<S>::max());
  }
}

TYPED_TEST(Queries, WorkWithFclsTreeManagerToo) {
  using S = TypeParam;
  auto sc = scene<S>(300, 24);
  fcl::DynamicAABBTreeCollisionManager<S> tree;
  tree.registerObjects(sc.pointers());
  tree.setup();
  auto naive = cube::oracle::naiveOf(sc.pointers());
  EXPECT_EQ(unorderedSorted(cube::overlappingPairs(tree)),
            cube::oracle::bruteSelfPairs(sc.pointers()));
  EXPECT_EQ(contactPairs(cube::collideAll(tree, everyContact<S>())),
            contactPairs(cube::collideAll(naive, everyContact<S>())));
}

}  // namespace
