// Filter bits (setFilter), the pair predicate (setPairFilter) and filter groups
// (Config::filter_groups), each against brute force over every pair of objects.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/inspect.h"
#include "cube_collision/queries.h"
#include "support/oracle.h"
#include "support/pair_rules_world.h"

namespace {

using namespace pair_rules;

// collideAll runs FCL's narrow phase on exactly the pairs whose boxes overlap and bits pass, and
// finds the contacts fcl::collide finds on them.
void expectNarrowPhaseOnAllowedPairs(const CubeCollisionManager<double>& m,
                                     const std::vector<Obj<double>*>& objs,
                                     const std::map<Obj<double>*, Bits>& bits, int threads) {
  fcl::CollisionRequest<double> req(1000000);
  cube::NarrowPhaseStats stats;
  cube::NarrowPhaseOptions<double> opt;
  opt.stats = &stats;
  opt.threads = threads;
  const auto res = cube::collideAll(m, req, opt);
  const auto allowed = bruteFiltered(objs, bits);
  EXPECT_EQ(stats.candidate_pairs, allowed.size());
  std::size_t contacts = 0;
  for (const auto& p : allowed) {
    fcl::CollisionResult<double> r;
    contacts += fcl::collide(p.first, p.second, req, r) > 0 ? r.numContacts() : 0;
  }
  EXPECT_EQ(res.numContacts(), contacts);
}

TEST(PairFilters, SelfCollideEqualsBruteForceOnEveryPath) {
  for (const std::size_t n : {40u, 700u}) {  // the all-pairs kernel and the tree walk
    auto sc = scene<double>(n, 7 + n);
    const auto objs = sc.pointers();
    for (const bool keep_pairs : {false, true}) {
      cube::Config cfg;
      cfg.keep_pairs = keep_pairs;
      CubeCollisionManager<double> m(cfg);
      m.registerObjects(objs);
      m.update();  // with keep_pairs the next self-collide reads the pair list
      const auto bits = randomBits(m, objs, 3);
      EXPECT_EQ(m.pairsListed(), keep_pairs) << "setting bits must keep the pair list";
      const auto want = bruteFiltered(objs, bits);
      EXPECT_LT(want.size(), cube::oracle::bruteSelfPairs(objs).size()) << "bits filter nothing";
      EXPECT_EQ(cube::oracle::selfPairs(m), want) << "n " << n << " keep_pairs " << keep_pairs;
      // After motion the list is refreshed and still filtered.
      cube::scenes::jitter(sc, 0.05, cube::scenes::typicalSize({}) * 0.5, true, 11);
      m.update();
      EXPECT_EQ(cube::oracle::selfPairs(m), bruteFiltered(objs, bits));
      std::string why;
      EXPECT_TRUE(m.validate(&why)) << why;
    }
  }
}

TEST(PairFilters, ObjectQueriesAndManagersEqualBruteForce) {
  auto sc = scene<double>(500, 21);
  auto qs = scene<double>(60, 22);
  const auto objs = sc.pointers();
  const auto queries = qs.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const auto bits = randomBits(m, objs, 5);
  // A registered query object brings its own bits; an unregistered one the default.
  for (Obj<double>* q : {objs[3], objs[17], queries[0], queries[1]}) {
    std::vector<Pair<double>> got, want;
    m.collide(q, [&](Obj<double>* a, Obj<double>* b) { got.emplace_back(a, b); });
    for (Obj<double>* o : objs)
      if (o != q && o->getAABB().overlap(q->getAABB()) && pass(bitsOf(bits, o), bitsOf(bits, q)))
        want.emplace_back(o, q);
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want);
  }
  // Against another cube manager: each side's bits from its own manager.
  CubeCollisionManager<double> other;
  other.registerObjects(queries);
  const auto other_bits = randomBits(other, queries, 9);
  std::vector<Pair<double>> got, want;
  m.collide(&other, [&](Obj<double>* a, Obj<double>* b) { got.emplace_back(a, b); });
  for (const auto& p : cube::oracle::bruteCrossPairs(objs, queries))
    if (pass(bitsOf(bits, p.first), bitsOf(other_bits, p.second))) want.push_back(p);
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want);
  // Against an FCL manager: its objects have the default bits.
  fcl::DynamicAABBTreeCollisionManager<double> fcl_other;
  fcl_other.registerObjects(queries);
  fcl_other.setup();
  got.clear();
  want.clear();
  m.collide(&fcl_other, [&](Obj<double>* a, Obj<double>* b) { got.emplace_back(a, b); });
  for (const auto& p : cube::oracle::bruteCrossPairs(objs, queries))
    if (pass(bitsOf(bits, p.first), Bits{})) want.push_back(p);
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want);
}

TEST(PairFilters, PredicateAndDistance) {
  auto sc = scene<double>(300, 31, 2.0);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const auto bits = randomBits(m, objs, 13);
  // Drop pairs whose two objects were created an even number apart.
  std::map<Obj<double>*, std::size_t> index;
  for (std::size_t i = 0; i < objs.size(); ++i) index[objs[i]] = i;
  std::size_t asked = 0;
  m.setPairFilter([&](Obj<double>* a, Obj<double>* b) {
    ++asked;
    EXPECT_TRUE(pass(bitsOf(bits, a), bitsOf(bits, b))) << "predicate asked before the bits";
    return (index[a] + index[b]) % 2 == 1;
  });
  std::vector<Pair<double>> want;
  for (const auto& p : bruteFiltered(objs, bits))
    if ((index[p.first] + index[p.second]) % 2 == 1) want.push_back(p);
  EXPECT_EQ(cube::oracle::selfPairs(m), want);
  EXPECT_EQ(asked, bruteFiltered(objs, bits).size());
  // Self distance: the minimum over the pairs that pass, by brute force with the same function.
  double best = std::numeric_limits<double>::max();
  m.distance(&best, &cube::oracle::narrowDistance<double>);
  const double brute = bruteSelfDistance(objs, [&](std::size_t i, std::size_t j) {
    return pass(bitsOf(bits, objs[i]), bitsOf(bits, objs[j])) && (i + j) % 2 == 1;
  });
  EXPECT_NEAR(best, brute, 1e-9 * (1 + std::fabs(brute)));
  m.setPairFilter({});
  EXPECT_EQ(cube::oracle::selfPairs(m), bruteFiltered(objs, bits));
}

TEST(PairFilters, NarrowPhaseSeesNoFilteredPair) {
  auto sc = scene<double>(400, 41, 4.0);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const auto bits = randomBits(m, objs, 17);
  expectNarrowPhaseOnAllowedPairs(m, objs, bits, 2);
}

TEST(PairFilters, BadInputChangesNothing) {
  auto sc = scene<double>(50, 51);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects({objs[0], objs[1]});
  m.setFilter(objs[0], 2, 6);
  EXPECT_THROW(m.setFilter(nullptr, 1, 1), std::invalid_argument);
  EXPECT_THROW(m.setFilter(objs[2], 1, 1), std::invalid_argument);
  EXPECT_EQ(m.filter(objs[0]), std::make_pair(std::uint64_t(2), std::uint64_t(6)));
  EXPECT_EQ(m.filter(objs[2]), std::make_pair(std::uint64_t(1), ~std::uint64_t(0)));
  // From inside a callback of a query on this manager: refused.
  bool threw = false;
  m.collide(objs[0], [&](Obj<double>*, Obj<double>*) {
    try {
      m.setFilter(objs[1], 1, 1);
    } catch (const std::logic_error&) {
      threw = true;
    }
  });
  m.registerObject(objs[2]);
  objs[2]->setTransform(objs[0]->getTransform());
  objs[2]->computeAABB();
  m.update(objs[2]);
  m.setFilter(objs[2], 2, ~std::uint64_t(0));  // meets objs[0]'s bits
  m.collide(objs[0], [&](Obj<double>*, Obj<double>*) {
    try {
      m.setPairFilter({});
    } catch (const std::logic_error&) {
      threw = true;
    }
    return true;
  });
  EXPECT_TRUE(threw);
  // An unregistered object that comes back starts with the default bits again.
  m.unregisterObject(objs[0]);
  m.registerObject(objs[0]);
  EXPECT_EQ(m.filter(objs[0]), std::make_pair(std::uint64_t(1), ~std::uint64_t(0)));
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// Filter groups (Config::filter_groups): a few distinct bits, which the cubes keep apart after
// update(). Every answer must equal brute force whether the cubes carry groups or not, through
// registrations, removals, bit changes and motion, with validate() after each mutation.
enum class Arrangement { two_worlds, static_scene, few_random };

Bits arranged(Arrangement a, std::size_t i, std::mt19937& rng, const std::vector<Bits>& kinds) {
  switch (a) {
    case Arrangement::two_worlds:  // each half pairs only within itself
      return Bits{std::uint64_t(1) << (i % 2), std::uint64_t(1) << (i % 2)};
    case Arrangement::static_scene:  // one in ten moves; the rest pair only with movers
      return i % 10 == 0 ? Bits{1, 3} : Bits{2, 1};
    case Arrangement::few_random:
      return kinds[rng() % kinds.size()];
  }
  return Bits{};
}

template <typename S>
std::vector<Pair<S>> objectPairs(const CubeCollisionManager<S>& m, Obj<S>* q) {
  std::vector<Pair<S>> got;
  m.collide(q, [&](Obj<S>* a, Obj<S>* b) { got.push_back(unordered(a, b)); });
  std::sort(got.begin(), got.end());
  return got;
}

template <typename S>
void checkGroups(Arrangement arrangement, std::uint32_t seed) {
  SCOPED_TRACE("arrangement " + std::to_string(int(arrangement)) + " seed " + std::to_string(seed));
  auto sc = scene<S>(600, seed);
  auto more = scene<S>(80, seed + 1);
  std::vector<Obj<S>*> objs = sc.pointers();
  std::mt19937 rng(seed);
  std::vector<Bits> kinds;
  for (int k = 0; k < 5; ++k)
    kinds.push_back(Bits{std::uint64_t(1) << (rng() % 3), std::uint64_t(rng() % 8)});
  cube::Config off;
  off.filter_groups = 0;
  CubeCollisionManager<S> m, ref(off);
  std::map<Obj<S>*, Bits> bits;
  const auto setBits = [&](Obj<S>* o, const Bits& b) {
    bits[o] = b;
    m.setFilter(o, b.category, b.mask);
    ref.setFilter(o, b.category, b.mask);
    std::string why;
    ASSERT_TRUE(m.validate(&why)) << why;
  };
  const auto check = [&](const char* when) {
    SCOPED_TRACE(when);
    std::string why;
    ASSERT_TRUE(m.validate(&why)) << why;
    const auto want = bruteFiltered(objs, bits);
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    EXPECT_EQ(cube::oracle::selfPairs(ref), want);
    for (std::size_t i = 0; i < objs.size(); i += 37) {
      std::vector<Pair<S>> brute;
      for (Obj<S>* o : objs)
        if (o != objs[i] && o->getAABB().overlap(objs[i]->getAABB()) &&
            pass(bitsOf(bits, o), bitsOf(bits, objs[i])))
          brute.push_back(unordered(o, objs[i]));
      std::sort(brute.begin(), brute.end());
      EXPECT_EQ(objectPairs(m, objs[i]), brute) << "object query " << i;
    }
  };
  m.registerObjects(objs);
  ref.registerObjects(objs);
  for (std::size_t i = 0; i < objs.size(); ++i)
    setBits(objs[i], arranged(arrangement, i, rng, kinds));
  const auto groupCubes = [](const CubeCollisionManager<S>& x) {
    return cube::HierarchyView<S>(x).stats().one_group_cubes;
  };
  EXPECT_EQ(groupCubes(m), 0u) << "groups are laid out by update(), not setFilter";
  check("bits set, before update");
  m.update();
  ref.update();
  // Groups are kept apart when some two of the distinct bits in use (or one with itself)
  // cannot pair: always in two worlds and the static scene, by chance with random bits.
  std::vector<Bits> used;
  for (const auto& entry : bits) {
    const Bits& b = entry.second;  // not a structured binding: C++17 lambdas cannot capture one
    if (std::none_of(used.begin(), used.end(),
                     [&](const Bits& u) { return u.category == b.category && u.mask == b.mask; }))
      used.push_back(b);
  }
  bool apart = false;
  for (const Bits& x : used)
    for (const Bits& y : used) apart = apart || !pass(x, y);
  EXPECT_TRUE(apart || arrangement == Arrangement::few_random);
  EXPECT_EQ(groupCubes(m) > 0, apart);
  EXPECT_EQ(groupCubes(ref), 0u);
  check("after update");
  if (arrangement != Arrangement::few_random) {
    // Cube pairs of groups that cannot pair are dropped whole: fewer box tests.
    cube::QueryStats grouped, plain;
    cube::oracle::Calls<S> c1, c2;
    m.collide(&c1, &cube::oracle::Calls<S>::record, &grouped);
    ref.collide(&c2, &cube::oracle::Calls<S>::record, &plain);
    EXPECT_LT(grouped.box_tests, plain.box_tests);
    if (arrangement == Arrangement::static_scene) {
      EXPECT_LT(grouped.box_tests * 2, plain.box_tests) << "the static objects' pairs walked";
    }
  }
  // Registrations one by one go into the cubes of their group.
  const auto extra = more.pointers();
  for (std::size_t i = 0; i < extra.size(); ++i) {
    m.registerObject(extra[i]);
    ref.registerObject(extra[i]);
    objs.push_back(extra[i]);
    setBits(extra[i], arranged(arrangement, i, rng, kinds));
  }
  check("after registrations");
  m.update();
  ref.update();
  check("after registrations and update");
  // Removals, enough to compact the cubes.
  for (std::size_t i = 0; i < objs.size(); i += 1 + (i % 3 != 0)) {
    m.unregisterObject(objs[i]);
    ref.unregisterObject(objs[i]);
    bits.erase(objs[i]);
    objs[i] = nullptr;
    std::string why;
    ASSERT_TRUE(m.validate(&why)) << why;
  }
  objs.erase(std::remove(objs.begin(), objs.end(), nullptr), objs.end());
  check("after removals");
  // Bits changed: groups forgotten until the next update, answers the same either way.
  for (std::size_t i = 0; i < objs.size(); i += 7)
    setBits(objs[i], arranged(arrangement, i + 1, rng, kinds));
  check("bits changed");
  cube::scenes::jitter(sc, 0.3, cube::scenes::typicalSize({}) * 0.5, true, seed + 2);
  m.update();
  ref.update();
  check("after motion and update");
  // Manager against manager, both with groups.
  CubeCollisionManager<S> other;
  std::map<Obj<S>*, Bits> other_bits;
  for (Obj<S>* o : extra) {
    other.registerObject(o);
    const Bits b = arranged(arrangement, other_bits.size(), rng, kinds);
    other.setFilter(o, b.category, b.mask);
    other_bits[o] = b;
  }
  other.update();
  std::vector<Pair<S>> got, want;
  m.collide(&other, [&](Obj<S>* a, Obj<S>* b) { got.emplace_back(a, b); });
  for (const auto& p : cube::oracle::bruteCrossPairs(objs, extra))
    if (pass(bitsOf(bits, p.first), bitsOf(other_bits, p.second))) want.push_back(p);
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want) << "manager against manager";
}

TEST(FilterGroups, CubesKeepGroupsApartAndAnswersEqualBruteForce) {
  for (const Arrangement a :
       {Arrangement::two_worlds, Arrangement::static_scene, Arrangement::few_random}) {
    checkGroups<double>(a, 61);
    checkGroups<float>(a, 62);
  }
  checkGroups<double>(Arrangement::few_random, 63);
}

TEST(FilterGroups, DistanceAndNarrowPhaseSkipNoAllowedPair) {
  auto sc = scene<double>(200, 71, 2.0);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  std::map<Obj<double>*, Bits> bits;
  std::mt19937 rng(5);
  for (std::size_t i = 0; i < objs.size(); ++i) {
    bits[objs[i]] = arranged(Arrangement::static_scene, i, rng, {});
    m.setFilter(objs[i], bits[objs[i]].category, bits[objs[i]].mask);
  }
  m.update();
  ASSERT_GT(cube::HierarchyView<double>(m).stats().one_group_cubes, 0u);
  double best = std::numeric_limits<double>::max();
  m.distance(&best, &cube::oracle::narrowDistance<double>);
  const double brute = bruteSelfDistance(
      objs, [&](std::size_t i, std::size_t j) { return pass(bits[objs[i]], bits[objs[j]]); });
  EXPECT_NEAR(best, brute, 1e-9 * (1 + std::fabs(brute)));
  expectNarrowPhaseOnAllowedPairs(m, objs, bits, 1);
}

TEST(FilterGroups, ConfigOutOfRangeThrows) {
  cube::Config c;
  c.filter_groups = -1;
  EXPECT_THROW(CubeCollisionManager<double>{c}, std::invalid_argument);
  c.filter_groups = 65;
  EXPECT_THROW(CubeCollisionManager<double>{c}, std::invalid_argument);
}

}  // namespace
