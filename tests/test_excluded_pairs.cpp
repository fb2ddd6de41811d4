// Excluded pairs (excludePair): every query against fcl::NaiveCollisionManager's pairs, or brute
// force over every pair, minus the excluded ones.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/batch.h"
#include "cube_collision/continuous.h"
#include "cube_collision/queries.h"
#include "support/oracle.h"
#include "support/pair_rules_world.h"

namespace {

using namespace pair_rules;

using PairSet = std::set<Pair<double>>;

bool isIn(const PairSet& excluded, Obj<double>* a, Obj<double>* b) {
  return excluded.count(unordered(a, b)) != 0;
}

// `pairs` without the excluded ones, sorted.
std::vector<Pair<double>> minus(const std::vector<Pair<double>>& pairs, const PairSet& excluded) {
  std::vector<Pair<double>> out;
  for (const auto& p : pairs)
    if (!isIn(excluded, p.first, p.second)) out.push_back(p);
  std::sort(out.begin(), out.end());
  return out;
}

// Excludes about a third of the overlapping pairs among `objs` (all registered in m), and as
// many pairs of random objects (mostly apart), validating after each; returns them.
PairSet excludeSome(CubeCollisionManager<double>& m, const std::vector<Obj<double>*>& objs,
                    std::uint32_t seed) {
  std::mt19937 rng(seed);
  PairSet out;
  for (const auto& p : cube::oracle::bruteSelfPairs(objs))
    if (rng() % 3 == 0 && out.insert(p).second) {
      m.excludePair(p.first, p.second);
      expectValid(m);
    }
  const std::size_t overlapping = out.size();
  for (std::size_t k = 0; k < overlapping; ++k) {
    Obj<double>* a = objs[rng() % objs.size()];
    Obj<double>* b = objs[rng() % objs.size()];
    if (a == b) continue;
    m.excludePair(a, b);
    out.insert(unordered(a, b));
    expectValid(m);
  }
  EXPECT_GT(overlapping, 0u) << "nothing excluded among the overlapping pairs";
  return out;
}

std::vector<Pair<double>> naiveSelfPairs(const std::vector<Obj<double>*>& objs) {
  return cube::oracle::selfPairs(cube::oracle::naiveOf(objs));
}

std::vector<Pair<double>> sortedUnordered(const std::vector<cube::ObjectPair<double>>& pairs) {
  std::vector<Pair<double>> out;
  for (const auto& p : pairs) out.push_back(unordered(p.first, p.second));
  std::sort(out.begin(), out.end());
  return out;
}

// collideAll's candidate pairs (pairs handed to the narrow phase) on `threads` threads.
std::size_t candidatePairs(const CubeCollisionManager<double>& m, int threads) {
  cube::NarrowPhaseStats stats;
  cube::NarrowPhaseOptions<double> opt;
  opt.stats = &stats;
  opt.threads = threads;
  cube::collideAll(m, fcl::CollisionRequest<double>(1000000), opt);
  return stats.candidate_pairs;
}

TEST(ExcludedPairs, SelfCollideEqualsNaiveMinusExcludedOnEveryPath) {
  for (const std::size_t n : {40u, 700u}) {  // the all-pairs kernel and the tree walk
    auto sc = scene<double>(n, 300 + n);
    const auto objs = sc.pointers();
    for (int variant = 0; variant < 4; ++variant) {
      cube::Config cfg;
      cfg.keep_pairs = (variant & 1) != 0;       // the pair list
      cfg.canonical_pairs = (variant & 2) != 0;  // gathered, called in registration order
      CubeCollisionManager<double> m(cfg);
      m.registerObjects(objs);
      m.update();
      const PairSet excluded = excludeSome(m, objs, 7 + variant);
      EXPECT_EQ(m.pairsListed(), cfg.keep_pairs) << "excluding must keep the pair list";
      const auto want = minus(naiveSelfPairs(objs), excluded);
      const std::string where = "n " + std::to_string(n) + " variant " + std::to_string(variant);
      EXPECT_EQ(cube::oracle::selfPairs(m), want) << where;
      EXPECT_EQ(sortedUnordered(cube::overlappingPairs(m)), want) << where;
      EXPECT_EQ(candidatePairs(m, 1), want.size()) << where;
      EXPECT_EQ(candidatePairs(m, 2), want.size()) << where;
      // With filter bits too: the bits' step, then the exclusions.
      const auto bits = randomBits(m, objs, 11 + variant);
      EXPECT_EQ(cube::oracle::selfPairs(m), minus(bruteFiltered(objs, bits), excluded)) << where;
    }
  }
}

TEST(ExcludedPairs, SplitWalkAndItsTasksSkipExcludedPairs) {
  // Enough objects in the cubes for the walk cut into tasks (collideConcurrently with
  // split_walk, collideAll on two threads).
  auto sc = scene<double>(5000, 17, 2.0);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  m.update();
  const PairSet excluded = excludeSome(m, objs, 19);
  const auto want = minus(cube::oracle::bruteSelfPairs(objs), excluded);
  struct Seen {
    std::mutex lock;
    std::vector<Pair<double>> pairs;
  } seen;
  const auto record = [](Obj<double>* a, Obj<double>* b, void* d) {
    auto& s = *static_cast<Seen*>(d);
    const std::lock_guard<std::mutex> hold(s.lock);
    s.pairs.push_back(unordered(a, b));
    return false;
  };
  cube::collideConcurrently<double>(m, &seen, record, 2, true);
  std::sort(seen.pairs.begin(), seen.pairs.end());
  EXPECT_EQ(seen.pairs, want);
  EXPECT_EQ(candidatePairs(m, 2), want.size());
  EXPECT_EQ(cube::oracle::selfPairs(m), want);
}

TEST(ExcludedPairs, RegisteredQueryObjectSkipsItsExcludedPartners) {
  auto sc = scene<double>(500, 23);
  auto qs = scene<double>(20, 24);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const PairSet excluded = excludeSome(m, objs, 25);
  // Registered query objects in excluded pairs, and an unregistered one (nothing excluded).
  std::vector<Obj<double>*> queries;
  for (const auto& p : excluded)
    if (queries.size() < 6) queries.push_back(p.first);
  queries.push_back(qs.pointers()[0]);
  for (Obj<double>* q : queries) {
    std::vector<Pair<double>> got, want;
    m.collide(q, [&](Obj<double>* a, Obj<double>* b) { got.emplace_back(a, b); });
    for (Obj<double>* o : objs)
      if (o != q && o->getAABB().overlap(q->getAABB()) && !isIn(excluded, o, q))
        want.emplace_back(o, q);
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want);
    std::vector<Pair<double>> listed;
    for (const auto& p : cube::overlappingPairs(m, q)) listed.emplace_back(p.first, p.second);
    std::sort(listed.begin(), listed.end());
    EXPECT_EQ(listed, want);
    // Distance: the least narrow-phase distance over the pairs kept.
    double best = std::numeric_limits<double>::max();
    m.distance(q, &best, &cube::oracle::narrowDistance<double>);
    double brute = std::numeric_limits<double>::max();
    for (Obj<double>* o : objs) {
      if (o == q || isIn(excluded, o, q)) continue;
      double d = std::numeric_limits<double>::max();
      double tmp = d;
      cube::oracle::narrowDistance<double>(o, q, &tmp, d);
      brute = std::min(brute, tmp);
    }
    EXPECT_NEAR(best, brute, 1e-9 * (1 + std::fabs(brute)));
  }
}

TEST(ExcludedPairs, ManagersDropThePairsEitherExcludes) {
  auto sc = scene<double>(400, 27);
  const auto objs = sc.pointers();
  // Objects 200-299 are registered in both managers.
  const std::vector<Obj<double>*> one(objs.begin(), objs.begin() + 300);
  const std::vector<Obj<double>*> two(objs.begin() + 200, objs.end());
  CubeCollisionManager<double> m1, m2;
  m1.registerObjects(one);
  m2.registerObjects(two);
  const PairSet ex1 = excludeSome(m1, one, 29);
  const PairSet ex2 = excludeSome(m2, two, 31);
  const auto dropped = [&](Obj<double>* a, Obj<double>* b) {
    return isIn(ex1, a, b) || isIn(ex2, a, b);
  };
  const auto cross = [&](const std::vector<Obj<double>*>& as, const std::vector<Obj<double>*>& bs,
                         bool both) {
    std::vector<Pair<double>> want;
    for (const auto& p : cube::oracle::bruteCrossPairs(as, bs))
      if (!(both ? dropped(p.first, p.second) : isIn(ex1, p.first, p.second))) want.push_back(p);
    std::sort(want.begin(), want.end());
    return want;
  };
  const auto got = [](CubeCollisionManager<double>& a, fcl::BroadPhaseCollisionManager<double>* b) {
    std::vector<Pair<double>> out;
    a.collide(b, [&](Obj<double>* x, Obj<double>* y) { out.emplace_back(x, y); });
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(got(m1, &m2), cross(one, two, true));
  EXPECT_EQ(got(m2, &m1), cross(two, one, true));
  std::vector<Pair<double>> listed;
  for (const auto& p : cube::overlappingPairs<double>(m1, m2))
    listed.emplace_back(p.first, p.second);
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(listed, cross(one, two, true));
  // Against an FCL manager: its objects are query objects here; this manager's exclusions only.
  fcl::DynamicAABBTreeCollisionManager<double> fcl_two;
  fcl_two.registerObjects(two);
  fcl_two.setup();
  EXPECT_EQ(got(m1, &fcl_two), cross(one, two, false));
  // Distance between the managers: brute force over the pairs kept.
  double best = std::numeric_limits<double>::max();
  m1.distance(&m2, &best, &cube::oracle::narrowDistance<double>);
  double brute = std::numeric_limits<double>::max();
  for (Obj<double>* a : one)
    for (Obj<double>* b : two) {
      if (a == b || dropped(a, b)) continue;
      double d = std::numeric_limits<double>::max();
      double tmp = d;
      cube::oracle::narrowDistance<double>(a, b, &tmp, d);
      brute = std::min(brute, tmp);
    }
  EXPECT_NEAR(best, brute, 1e-9 * (1 + std::fabs(brute)));
}

TEST(ExcludedPairs, DistanceQueriesSkipExcludedPairs) {
  // Every overlapping pair excluded: the least distance lies between objects apart.
  auto sc = scene<double>(150, 33, 1.0);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  PairSet excluded;
  for (const auto& p : cube::oracle::bruteSelfPairs(objs)) {
    m.excludePair(p.first, p.second);
    excluded.insert(p);
  }
  expectValid(m);
  const double brute = bruteSelfDistance(
      objs, [&](std::size_t i, std::size_t j) { return !isIn(excluded, objs[i], objs[j]); });
  EXPECT_GT(brute, 0.0);
  double best = std::numeric_limits<double>::max();
  m.distance(&best, &cube::oracle::narrowDistance<double>);
  EXPECT_NEAR(best, brute, 1e-9 * (1 + std::fabs(brute)));
  const auto r = cube::minimumDistance(m);
  EXPECT_NEAR(r.min_distance, brute, 1e-6 * (1 + std::fabs(brute)));
  EXPECT_TRUE(sortedUnordered(cube::overlappingPairs(m)).empty());
  EXPECT_FALSE(cube::collideAll(m).isCollision());
}

TEST(ExcludedPairs, SweptPairsSkipExcludedPairs) {
  auto sc = scene<double>(400, 35, 1.0);
  const auto objs = sc.pointers();
  const double size = cube::scenes::typicalSize({});
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  std::vector<cube::Motion<double>> motions;
  std::map<Obj<double>*, fcl::AABB<double>> box;
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> step(-2 * size, 2 * size);
  for (Obj<double>* o : objs) box[o] = o->getAABB();
  for (std::size_t i = 0; i < objs.size(); i += 4) {
    fcl::Transform3d end = objs[i]->getTransform();
    end.translation() += fcl::Vector3d(step(rng), step(rng), step(rng));
    motions.push_back({objs[i], end});
    box[objs[i]] = cube::sweptBox(*objs[i], end, fcl::CCDM_TRANS);
  }
  std::vector<Pair<double>> swept;  // movers with movers and with the objects that stay
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      if ((i % 4 == 0 || j % 4 == 0) && box[objs[i]].overlap(box[objs[j]]))
        swept.push_back(unordered(objs[i], objs[j]));
  // Exclude half of them: pairs of two movers and pairs of a mover and an object that stays.
  PairSet excluded;
  for (std::size_t k = 0; k < swept.size(); k += 2) {
    m.excludePair(swept[k].first, swept[k].second);
    excluded.insert(swept[k]);
  }
  expectValid(m);
  std::vector<Pair<double>> got;
  for (const auto& p : cube::sweptPairs(m, motions)) got.push_back(unordered(p.first, p.second));
  std::sort(got.begin(), got.end());
  const auto want = minus(swept, excluded);
  EXPECT_FALSE(want.empty());
  EXPECT_EQ(got, want);
}

TEST(ExcludedPairs, KeptThroughMotionAndDroppedWithTheirObjects) {
  auto sc = scene<double>(300, 39, 3.0);
  const auto objs = sc.pointers();
  for (const bool keep_pairs : {false, true}) {
    cube::Config cfg;
    cfg.keep_pairs = keep_pairs;
    CubeCollisionManager<double> m(cfg);
    m.registerObjects(objs);
    std::vector<bool> in(objs.size(), true);
    PairSet excluded = excludeSome(m, objs, 41);
    std::mt19937 rng(43);
    const auto registered = [&] {
      std::vector<Obj<double>*> out;
      for (std::size_t i = 0; i < objs.size(); ++i)
        if (in[i]) out.push_back(objs[i]);
      return out;
    };
    for (int step = 0; step < 60; ++step) {
      const std::size_t i = rng() % objs.size(), j = rng() % objs.size();
      switch (rng() % 5) {
        case 0:  // unregister: its pairs go; registered again, it is excluded from nothing
          if (in[i]) {
            m.unregisterObject(objs[i]);
            in[i] = false;
            for (auto it = excluded.begin(); it != excluded.end();)
              it = it->first == objs[i] || it->second == objs[i] ? excluded.erase(it) : ++it;
          } else {
            m.registerObject(objs[i]);
            in[i] = true;
          }
          break;
        case 1:  // exclude or admit again
          if (in[i] && in[j] && i != j) {
            const bool on = rng() % 2 == 0;
            m.excludePair(objs[i], objs[j], on);
            if (on)
              excluded.insert(unordered(objs[i], objs[j]));
            else
              excluded.erase(unordered(objs[i], objs[j]));
          }
          break;
        case 2:  // motion: refits, rebuilds and compactions keep the ids
          cube::scenes::jitter(sc, 0.2, 0.5, false, rng());
          m.update();
          break;
        case 3:
          m.setup();
          break;
        default:  // a whole batch unregistered and registered again (ids reused)
          for (std::size_t k = 0; k < objs.size(); k += 5)
            if (in[k]) m.unregisterObject(objs[k]);
          for (std::size_t k = 0; k < objs.size(); k += 5) {
            if (!in[k]) continue;
            for (auto it = excluded.begin(); it != excluded.end();)
              it = it->first == objs[k] || it->second == objs[k] ? excluded.erase(it) : ++it;
          }
          m.registerObjects(registered());
          break;
      }
      expectValid(m);
      const auto now = registered();
      ASSERT_EQ(cube::oracle::selfPairs(m), minus(naiveSelfPairs(now), excluded))
          << "step " << step << " keep_pairs " << keep_pairs;
      std::vector<Pair<double>> listed;
      for (const auto& p : m.excludedPairs()) listed.push_back(unordered(p.first, p.second));
      std::sort(listed.begin(), listed.end());
      ASSERT_EQ(listed, std::vector<Pair<double>>(excluded.begin(), excluded.end()));
      for (std::size_t k = 0; k < 20; ++k) {
        Obj<double>* a = objs[rng() % objs.size()];
        Obj<double>* b = objs[rng() % objs.size()];
        EXPECT_EQ(m.isExcluded(a, b), a != b && isIn(excluded, a, b));
      }
    }
  }
}

TEST(ExcludedPairs, BatchLinksAreNoObjectsOfTheWorld) {
  // The world's ids 0-9 exclude one another; the links' positions 0-2 are no ids of the world,
  // so every link still meets every world object: brute force with fcl::collide.
  std::vector<std::unique_ptr<Obj<double>>> world_objs;
  for (int i = 0; i < 10; ++i) {
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.translation() = fcl::Vector3d(2.0 * i, 0, 0);
    world_objs.push_back(std::make_unique<Obj<double>>(std::make_shared<fcl::Boxd>(1, 1, 1), tf));
  }
  std::vector<Obj<double>*> world_ptrs;
  for (auto& o : world_objs) world_ptrs.push_back(o.get());
  CubeCollisionManager<double> world;
  world.registerObjects(world_ptrs);
  for (int i = 0; i < 10; ++i)
    for (int j = i + 1; j < 10; ++j) world.excludePair(world_ptrs[i], world_ptrs[j]);
  expectValid(world);
  cube::BodySet<double> body;
  for (int l = 0; l < 3; ++l) body.addLink(std::make_shared<fcl::Boxd>(0.8, 0.8, 0.8));
  std::mt19937 rng(51);
  std::uniform_real_distribution<double> x(-1, 20);
  std::vector<fcl::Transform3d> poses;
  const std::size_t states = 200;
  for (std::size_t k = 0; k < 3 * states; ++k) {
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.translation() = fcl::Vector3d(x(rng), 0.3, 0);
    poses.push_back(tf);
  }
  const auto got = cube::checkStates(world, body, poses);
  std::size_t colliding = 0;
  for (std::size_t k = 0; k < states; ++k) {
    bool want = false;
    for (std::size_t l = 0; l < 3 && !want; ++l) {
      const Obj<double> link(body.geometry(l), poses[3 * k + l]);
      for (Obj<double>* w : world_ptrs) {
        fcl::CollisionResult<double> r;
        if (fcl::collide(&link, w, fcl::CollisionRequest<double>(), r) > 0) want = true;
      }
    }
    EXPECT_EQ(got[k].colliding, want) << "state " << k;
    colliding += want;
  }
  EXPECT_GT(colliding, 0u);
}

TEST(ExcludedPairs, ListedInRegistrationOrder) {
  auto sc = scene<double>(6, 45);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  m.excludePair(objs[4], objs[1]);
  m.excludePair(objs[0], objs[5]);
  m.excludePair(objs[1], objs[2]);
  m.excludePair(objs[0], objs[3]);
  const std::vector<std::pair<Obj<double>*, Obj<double>*>> want{
      {objs[0], objs[3]}, {objs[0], objs[5]}, {objs[1], objs[2]}, {objs[1], objs[4]}};
  EXPECT_EQ(m.excludedPairs(), want);
  EXPECT_TRUE(m.isExcluded(objs[1], objs[4]));
  EXPECT_TRUE(m.isExcluded(objs[4], objs[1]));
  EXPECT_FALSE(m.isExcluded(objs[1], objs[3]));
  m.excludePair(objs[4], objs[1], false);
  m.excludePair(objs[4], objs[1], false);  // not excluded: no effect
  EXPECT_FALSE(m.isExcluded(objs[1], objs[4]));
  EXPECT_EQ(m.excludedPairs().size(), 3u);
  expectValid(m);
}

TEST(ExcludedPairs, BadInputThrowsAndChangesNothing) {
  auto sc = scene<double>(6, 47);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects({objs[0], objs[1], objs[2]});
  m.excludePair(objs[0], objs[1]);
  const auto before = m.excludedPairs();
  EXPECT_THROW(m.excludePair(nullptr, objs[1]), std::invalid_argument);
  EXPECT_THROW(m.excludePair(objs[0], nullptr), std::invalid_argument);
  EXPECT_THROW(m.excludePair(objs[0], objs[4]), std::invalid_argument);  // not registered
  EXPECT_THROW(m.excludePair(objs[4], objs[0], false), std::invalid_argument);
  EXPECT_THROW(m.excludePair(objs[2], objs[2]), std::invalid_argument);  // itself
  EXPECT_EQ(m.excludedPairs(), before);
  EXPECT_FALSE(m.isExcluded(nullptr, objs[1]));
  EXPECT_FALSE(m.isExcluded(objs[0], objs[4]));
  EXPECT_FALSE(m.isExcluded(objs[0], objs[0]));
  // From inside a callback of a query on this manager: refused, nothing changed.
  objs[2]->setTransform(objs[0]->getTransform());
  objs[2]->computeAABB();
  m.update(objs[2]);
  bool threw = false;
  m.collide(objs[0], [&](Obj<double>*, Obj<double>*) {
    try {
      m.excludePair(objs[1], objs[2]);
    } catch (const std::logic_error&) {
      threw = true;
    }
    return true;
  });
  EXPECT_TRUE(threw);
  EXPECT_EQ(m.excludedPairs(), before);
  expectValid(m);
}

TEST(ExcludedPairs, ManagersThatExcludeNothingKeepNoMemoryForIt) {
  auto sc = scene<double>(200, 49);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const std::size_t bytes = m.bytes();
  m.excludePair(objs[3], objs[150]);
  EXPECT_GT(m.bytes(), bytes);
  m.excludePair(objs[150], objs[3], false);
  EXPECT_EQ(m.bytes(), bytes);
  m.excludePair(objs[7], objs[9]);
  m.unregisterObject(objs[9]);  // its pairs, the last ones, go with it
  m.registerObject(objs[9]);
  EXPECT_EQ(m.excludedPairs().size(), 0u);
  EXPECT_FALSE(m.isExcluded(objs[7], objs[9]));
  expectValid(m);
}

}  // namespace
