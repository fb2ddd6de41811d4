// pairPasses: whether a manager's queries hand a pair to their callback, against brute force over
// filter bits, excluded pairs and a pair filter drawn at random, and against what collide(),
// collide(obj) and collide(other) report for the pairs whose AABBs overlap.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "support/oracle.h"
#include "support/pair_rules_world.h"

namespace {

using namespace pair_rules;

// A collide's callbacks as (first, second) pairs, sorted.
template <typename S, class Query>
std::vector<Pair<S>> reported(Query&& query) {
  std::vector<Pair<S>> out;
  query([&](Obj<S>* a, Obj<S>* b) { out.emplace_back(a, b); });
  std::sort(out.begin(), out.end());
  return out;
}

// The self rule by brute force: the bits, the exclusions, then the pair filter in the order the
// self query asks it (registration order under canonical_pairs).
template <typename S>
bool bruteSelf(const Rules<S>& r, Obj<S>* a, Obj<S>* b, bool canonical) {
  if (a == b || !pass(r.bitsOf(a), r.bitsOf(b)) || r.isExcluded(a, b)) return false;
  if (canonical && r.number->at(b) < r.number->at(a)) std::swap(a, b);
  return r.keep(a, b);
}

template <typename S>
void checkSelfPairs(std::uint32_t seed) {
  const RulesScene<S> world(160, seed);
  const auto& objs = world.objs;
  for (const bool canonical : {false, true}) {
    SCOPED_TRACE(canonical ? "canonical_pairs, an asymmetric pair filter" : "walk order");
    cube::Config cfg;
    cfg.canonical_pairs = canonical;
    // An asymmetric pair filter under canonical_pairs only: walk order asks either order, and
    // only a symmetric one agrees.
    RuledManager<S> ruled(world, objs, seed + (canonical ? 10 : 0), canonical, cfg);
    CubeCollisionManager<S>& m = ruled.manager;
    Rules<S>& rules = ruled.rules;
    std::size_t passing = 0, held = 0;
    for (Obj<S>* a : objs)
      for (Obj<S>* b : objs) {
        rules.calls = 0;
        const bool got = m.pairPasses(a, b);
        EXPECT_EQ(got, bruteSelf(rules, a, b, canonical));
        // The pair filter is asked exactly when the bits pass and the pair is not excluded.
        const bool asked =
            a != b && pass(rules.bitsOf(a), rules.bitsOf(b)) && !rules.isExcluded(a, b);
        EXPECT_EQ(rules.calls, asked ? 1 : 0);
        EXPECT_EQ(m.pairPasses(a, b, &m), got) << "other == this is the self query";
        passing += got;
        held += asked && !got;
      }
    EXPECT_GT(passing, 0u);
    EXPECT_GT(held, 0u) << "the pair filter dropped nothing";
    // The self query reports exactly the overlapping pairs that pass.
    std::vector<Pair<S>> want;
    for (const auto& p : cube::oracle::bruteSelfPairs(objs))
      if (m.pairPasses(p.first, p.second)) {
        EXPECT_TRUE(bruteSelf(rules, p.first, p.second, canonical));
        want.push_back(p);
      }
    EXPECT_FALSE(want.empty());
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    expectValid(m);
  }
}

TEST(PairPasses, SelfPairsFollowBitsExclusionsAndPairFilter) {
  checkSelfPairs<double>(41);
  checkSelfPairs<float>(43);
}

TEST(PairPasses, QueryObjectsPairAsCollideWithTheObjectPairsThem) {
  const RulesScene<double> world(200, 45, 30, 46);
  const auto& objs = world.objs;
  RuledManager<double> ruled(world, objs, 47);
  CubeCollisionManager<double>& m = ruled.manager;
  const Rules<double>& rules = ruled.rules;
  // Registered objects as query objects (their bits and exclusions), and objects of no manager
  // (the default bits, nothing excluded).
  std::vector<Obj<double>*> queries = world.slice(0, 40);
  const std::size_t registered = queries.size();
  for (Obj<double>* q : world.others) queries.push_back(q);
  std::size_t overlapping = 0;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    Obj<double>* q = queries[i];
    const Bits qbits = i < registered ? rules.bitsOf(q) : Bits{};
    std::vector<Pair<double>> want;
    for (Obj<double>* a : objs) {
      const bool brute =
          a != q && pass(rules.bitsOf(a), qbits) && !rules.isExcluded(a, q) && rules.keep(a, q);
      const bool got = m.pairPasses(a, q);
      EXPECT_EQ(got, brute);
      EXPECT_EQ(m.pairPasses(a, q, &m), got);
      if (a != q && a->getAABB().overlap(q->getAABB()) && got) want.emplace_back(a, q);
    }
    overlapping += want.size();
    std::sort(want.begin(), want.end());
    EXPECT_EQ(reported<double>([&](auto f) { m.collide(q, f); }), want);
  }
  EXPECT_GT(overlapping, 0u);
}

TEST(PairPasses, ObjectsOfAnotherCubeManagerPairAsTheManagerQueryPairsThem) {
  const RulesScene<double> world(300, 51);
  const auto& objs = world.objs;
  // Objects 120-199 are registered in both managers: each manager's exclusions reach them.
  const auto one = world.slice(0, 200), two = world.slice(120, 300);
  RuledManager<double> ruled1(world, one, 53), ruled2(world, two, 57, true);
  CubeCollisionManager<double>& m1 = ruled1.manager;
  CubeCollisionManager<double>& m2 = ruled2.manager;
  const Rules<double>& r1 = ruled1.rules;
  const Rules<double>& r2 = ruled2.rules;
  const auto check = [&](CubeCollisionManager<double>& here, const Rules<double>& rh,
                         const std::vector<Obj<double>*>& as, CubeCollisionManager<double>& there,
                         const Rules<double>& rt, const std::vector<Obj<double>*>& bs) {
    std::vector<Pair<double>> want;
    std::size_t passing = 0;
    for (Obj<double>* a : as)
      for (Obj<double>* b : bs) {
        rt.calls = 0;
        const bool brute = a != b && pass(rh.bitsOf(a), rt.bitsOf(b)) && !rh.isExcluded(a, b) &&
                           !rt.isExcluded(a, b) && rh.keep(a, b);
        const bool got = here.pairPasses(a, b, &there);
        EXPECT_EQ(got, brute);
        EXPECT_EQ(rt.calls, 0) << "only this manager's pair filter is asked";
        passing += got;
        if (got && a->getAABB().overlap(b->getAABB())) want.emplace_back(a, b);
      }
    EXPECT_GT(passing, 0u);
    EXPECT_FALSE(want.empty());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(reported<double>([&](auto f) { here.collide(&there, f); }), want);
  };
  check(m1, r1, one, m2, r2, two);
  check(m2, r2, two, m1, r1, one);
  // An object the other manager does not hold is no pair of a query against it.
  EXPECT_TRUE(m1.pairPasses(objs[0], objs[1]) || m1.pairPasses(objs[0], objs[2]));
  for (Obj<double>* b : {objs[1], objs[2], objs[3]}) EXPECT_FALSE(m1.pairPasses(objs[0], b, &m2));
}

TEST(PairPasses, ObjectsOfAnotherKindOfManagerPairAsQueryObjects) {
  const RulesScene<double> world(300, 61);
  const auto one = world.slice(0, 200), two = world.slice(120, 300);
  RuledManager<double> ruled(world, one, 63);
  CubeCollisionManager<double>& m = ruled.manager;
  const Rules<double>& rules = ruled.rules;
  fcl::DynamicAABBTreeCollisionManager<double> other;
  other.registerObjects(two);
  other.setup();
  std::vector<Pair<double>> want;
  for (Obj<double>* a : one)
    for (Obj<double>* b : two) {
      // b's bits and exclusions are this manager's where it is registered here too.
      const bool brute = a != b && pass(rules.bitsOf(a), rules.bitsOf(b)) &&
                         !rules.isExcluded(a, b) && rules.keep(a, b);
      const bool got = m.pairPasses(a, b, &other);
      EXPECT_EQ(got, brute);
      if (got && a->getAABB().overlap(b->getAABB())) want.emplace_back(a, b);
    }
  EXPECT_FALSE(want.empty());
  std::sort(want.begin(), want.end());
  EXPECT_EQ(reported<double>([&](auto f) { m.collide(&other, f); }), want);
}

TEST(PairPasses, EdgeCasesAskNothingAndBadInputThrows) {
  auto sc = scene<double>(20, 67);
  const auto objs = sc.pointers();
  const std::vector<Obj<double>*> some(objs.begin(), objs.begin() + 10);
  CubeCollisionManager<double> m;
  m.registerObjects(some);
  int calls = 0;
  m.setPairFilter([&](Obj<double>*, Obj<double>*) { return ++calls > 0; });
  EXPECT_THROW(m.pairPasses(nullptr, objs[1]), std::invalid_argument);
  EXPECT_THROW(m.pairPasses(objs[0], nullptr), std::invalid_argument);
  EXPECT_THROW(m.pairPasses(nullptr, nullptr, &m), std::invalid_argument);
  EXPECT_FALSE(m.pairPasses(objs[0], objs[0]));   // an object never pairs with itself
  EXPECT_FALSE(m.pairPasses(objs[15], objs[0]));  // the first object is not registered
  EXPECT_FALSE(m.pairPasses(objs[15], objs[16]));
  EXPECT_EQ(calls, 0);
  EXPECT_TRUE(m.pairPasses(objs[0], objs[15]));  // a query object of collide(objs[15])
  EXPECT_TRUE(m.pairPasses(objs[0], objs[1]));
  EXPECT_EQ(calls, 2);
  // Unregistered, an object is asked of no query; registered again, it has no rule.
  m.setFilter(objs[1], 2, 2);
  m.excludePair(objs[0], objs[2]);
  EXPECT_FALSE(m.pairPasses(objs[0], objs[1]));
  EXPECT_FALSE(m.pairPasses(objs[2], objs[0]));
  m.unregisterObject(objs[1]);
  EXPECT_FALSE(m.pairPasses(objs[1], objs[0]));
  EXPECT_TRUE(m.pairPasses(objs[0], objs[1]));  // now a query object: the default bits
  m.registerObject(objs[1]);
  EXPECT_TRUE(m.pairPasses(objs[1], objs[0]));
  expectValid(m);
  // The pair filter may not change the manager it is asked for.
  m.setPairFilter([&](Obj<double>* a, Obj<double>*) {
    m.setFilter(a, 4, 4);
    return true;
  });
  EXPECT_THROW(m.pairPasses(objs[0], objs[3]), std::logic_error);
  EXPECT_EQ(m.filter(objs[0]), (std::pair<std::uint64_t, std::uint64_t>(1, ~std::uint64_t(0))));
  expectValid(m);
}

}  // namespace
