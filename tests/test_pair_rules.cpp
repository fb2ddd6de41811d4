// Filter bits, excluded pairs, the pair predicate, margins and canonical pair order, each
// against brute force over every pair of objects.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/plane.h>
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
#include <tuple>
#include <vector>

#include "cube_collision/batch.h"
#include "cube_collision/continuous.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/inspect.h"
#include "cube_collision/margins.h"
#include "cube_collision/queries.h"
#include "cube_collision/spatial_queries.h"
#include "scenes.h"
#include "support/oracle.h"

namespace {

using cube::CubeCollisionManager;
using cube::oracle::Pair;
using cube::oracle::unordered;

template <typename S>
using Obj = fcl::CollisionObject<S>;

struct Bits {
  std::uint64_t category = 1, mask = ~std::uint64_t(0);
};

bool pass(const Bits& a, const Bits& b) {
  return (a.category & b.mask) != 0 && (b.category & a.mask) != 0;
}

// Random bits over four groups for about two thirds of the objects; the others keep the default.
template <typename S>
std::map<Obj<S>*, Bits> randomBits(CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs,
                                   std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::map<Obj<S>*, Bits> bits;
  for (Obj<S>* o : objs) {
    Bits b;
    if (rng() % 3 != 0) {
      b.category = std::uint64_t(1) << (rng() % 4);
      b.mask = rng() % 16;
      m.setFilter(o, b.category, b.mask);
      std::string why;
      EXPECT_TRUE(m.validate(&why)) << why;
    }
    bits[o] = b;
  }
  return bits;
}

template <typename S>
Bits bitsOf(const std::map<Obj<S>*, Bits>& bits, Obj<S>* o) {
  const auto it = bits.find(o);
  return it == bits.end() ? Bits{} : it->second;
}

// Brute force: overlapping AABBs that pass the bits, as sorted unordered pairs.
template <typename S>
std::vector<Pair<S>> bruteFiltered(const std::vector<Obj<S>*>& objs,
                                   const std::map<Obj<S>*, Bits>& bits) {
  std::vector<Pair<S>> out;
  for (const auto& p : cube::oracle::bruteSelfPairs(objs))
    if (pass(bitsOf(bits, p.first), bitsOf(bits, p.second))) out.push_back(p);
  return out;
}

// The least narrow-phase distance over the pairs (i < j) that `allowed` keeps, by brute force
// with the function the manager's distance query is given.
template <class Allowed>
double bruteSelfDistance(const std::vector<Obj<double>*>& objs, Allowed&& allowed) {
  double brute = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      if (!allowed(i, j)) continue;
      double d = std::numeric_limits<double>::max();
      double tmp = d;
      cube::oracle::narrowDistance<double>(objs[i], objs[j], &tmp, d);
      brute = std::min(brute, tmp);
    }
  return brute;
}

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

template <typename S>
cube::scenes::Scene<S> scene(std::size_t n, std::uint32_t seed, double overlaps = 3.0) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.overlaps_per_object = overlaps;
  return cube::scenes::makeScene<S>(o);
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

// Margins: brute force on boxes grown by each object's margin, computed as the core defines it.
template <typename S>
fcl::AABB<S> grownBox(const Obj<S>* o, S m) {
  fcl::AABB<S> b = o->getAABB();
  for (int k = 0; k < 3; ++k) {
    b.min_[k] = b.min_[k] - m;
    b.max_[k] = b.max_[k] + m;
  }
  return b;
}

template <typename S>
void checkMargins() {
  auto sc = scene<S>(600, 61, 1.0);
  auto qs = scene<S>(40, 62, 1.0);
  const auto objs = sc.pointers();
  const S size = S(cube::scenes::typicalSize({}));
  CubeCollisionManager<S> m;
  m.registerObjects(objs);
  std::map<Obj<S>*, S> own;
  std::mt19937 rng(5);
  for (std::size_t i = 0; i < objs.size(); i += 3) {
    own[objs[i]] = S(rng() % 100) / S(100) * size;
    m.setMargin(objs[i], own[objs[i]]);
  }
  const S all = size / S(4);
  m.setMargin(all);
  const auto marginOf = [&](Obj<S>* o) { return own.count(o) ? own[o] : all; };
  for (Obj<S>* o : objs) EXPECT_EQ(m.margin(o), marginOf(o));
  for (int step = 0; step < 2; ++step) {
    std::vector<Pair<S>> want;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j)
        if (grownBox(objs[i], marginOf(objs[i])).overlap(grownBox(objs[j], marginOf(objs[j]))))
          want.push_back(unordered(objs[i], objs[j]));
    std::sort(want.begin(), want.end());
    EXPECT_GT(want.size(), cube::oracle::bruteSelfPairs(objs).size()) << "margins grow nothing";
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    // Query objects: a registered one grows by its margin, another by the manager-wide one.
    for (Obj<S>* q : {objs[0], objs[1], qs.objects[0].get(), qs.objects[1].get()}) {
      const S mq = std::find(objs.begin(), objs.end(), q) != objs.end() ? marginOf(q) : all;
      std::vector<Obj<S>*> got, expect;
      m.collide(q, [&](Obj<S>* a, Obj<S>*) { got.push_back(a); });
      for (Obj<S>* o : objs)
        if (o != q && grownBox(o, marginOf(o)).overlap(grownBox(q, mq))) expect.push_back(o);
      std::sort(got.begin(), got.end());
      std::sort(expect.begin(), expect.end());
      EXPECT_EQ(got, expect);
    }
    std::string why;
    EXPECT_TRUE(m.validate(&why)) << why;
    cube::scenes::jitter(sc, 0.1, double(size), true, 71);
    m.update();
  }
}

TEST(Margins, EqualBruteForceOnGrownBoxes) {
  checkMargins<double>();
  checkMargins<float>();
}

// Swept pairs follow the same rules: swept boxes grown by the margins, bits and predicate.
TEST(Margins, SweptPairsFollowMarginsBitsAndPredicate) {
  auto sc = scene<double>(400, 131, 1.0);
  const auto objs = sc.pointers();
  const double size = cube::scenes::typicalSize({});
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const auto bits = randomBits(m, objs, 29);
  m.setMargin(0.2 * size);
  for (std::size_t i = 0; i < objs.size(); i += 7) m.setMargin(objs[i], 0.5 * size);
  m.setPairFilter([&](Obj<double>* a, Obj<double>* b) { return a != objs[1] && b != objs[1]; });
  std::vector<cube::Motion<double>> motions;
  std::map<Obj<double>*, fcl::AABB<double>> box;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> step(-2 * size, 2 * size);
  for (Obj<double>* o : objs) box[o] = grownBox(o, m.margin(o));
  for (std::size_t i = 0; i < objs.size(); i += 4) {
    fcl::Transform3d end = objs[i]->getTransform();
    end.translation() += fcl::Vector3d(step(rng), step(rng), step(rng));
    motions.push_back({objs[i], end});
    const fcl::AABB<double> sw = cube::sweptBox(*objs[i], end, fcl::CCDM_TRANS);
    fcl::AABB<double> g = sw;
    const double mg = m.margin(objs[i]);
    for (int k = 0; k < 3; ++k) {
      g.min_[k] = sw.min_[k] - mg;
      g.max_[k] = sw.max_[k] + mg;
    }
    box[objs[i]] = g;
  }
  std::vector<Pair<double>> want;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      if ((i % 4 == 0 || j % 4 == 0) && box[objs[i]].overlap(box[objs[j]]) &&
          pass(bitsOf(bits, objs[i]), bitsOf(bits, objs[j])) && i != 1 && j != 1)
        want.push_back(unordered(objs[i], objs[j]));
  std::sort(want.begin(), want.end());
  std::vector<Pair<double>> got;
  for (const auto& p : cube::sweptPairs(m, motions)) got.push_back(unordered(p.first, p.second));
  std::sort(got.begin(), got.end());
  EXPECT_FALSE(want.empty());
  EXPECT_EQ(got, want);
}

TEST(Margins, BadInputChangesNothing) {
  auto sc = scene<double>(10, 81);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects({objs[0], objs[1]});
  m.setMargin(objs[0], 0.5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {-1.0, nan, inf}) {
    EXPECT_THROW(m.setMargin(objs[0], bad), std::invalid_argument);
    EXPECT_THROW(m.setMargin(bad), std::invalid_argument);
  }
  EXPECT_THROW(m.setMargin(nullptr, 1.0), std::invalid_argument);
  EXPECT_THROW(m.setMargin(objs[2], 1.0), std::invalid_argument);
  EXPECT_EQ(m.margin(objs[0]), 0.5);
  EXPECT_EQ(m.margin(objs[1]), 0.0);
  EXPECT_EQ(m.margin(objs[2]), 0.0);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// contactsWithinMargin against FCL's narrow phase on every pair: colliding, or fcl::distance at
// most the two margins. Canonical order hands pairs over as brute force calls them (i < j).
TEST(Margins, ContactsWithinMarginEqualNarrowPhaseOnEveryPair) {
  for (const bool meshes : {false, true}) {
    cube::scenes::SceneOptions o;
    o.n = meshes ? 150 : 300;
    o.seed = 111;
    o.meshes = meshes;
    o.overlaps_per_object = 1.0;
    auto sc = cube::scenes::makeScene<double>(o);
    const auto objs = sc.pointers();
    cube::Config cfg;
    cfg.canonical_pairs = true;
    CubeCollisionManager<double> m(cfg);
    m.registerObjects(objs);
    const double size = cube::scenes::typicalSize(o);
    m.setMargin(size * 0.2);
    for (std::size_t i = 0; i < objs.size(); i += 5) m.setMargin(objs[i], size * 0.6);
    std::vector<std::tuple<Obj<double>*, Obj<double>*, bool, double>> want;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        fcl::CollisionRequest<double> creq;
        fcl::CollisionResult<double> cres;
        if (fcl::collide(objs[i], objs[j], creq, cres) > 0) {
          want.emplace_back(objs[i], objs[j], true, 0.0);
          continue;
        }
        fcl::DistanceRequest<double> dreq(true);
        fcl::DistanceResult<double> dres;
        const double d = fcl::distance(objs[i], objs[j], dreq, dres);
        if (d <= m.margin(objs[i]) + m.margin(objs[j]))
          want.emplace_back(objs[i], objs[j], false, d);
      }
    for (const int threads : {1, 2}) {
      cube::NarrowPhaseStats stats;
      const auto got =
          cube::contactsWithinMargin(m, fcl::DistanceRequest<double>(true), threads, &stats);
      std::vector<std::tuple<Obj<double>*, Obj<double>*, bool, double>> g;
      for (const auto& c : got) g.emplace_back(c.a, c.b, c.colliding, c.distance);
      std::sort(g.begin(), g.end());
      auto w = want;
      std::sort(w.begin(), w.end());
      EXPECT_EQ(g, w) << "meshes " << meshes << " threads " << threads;
      EXPECT_GT(w.size(), 0u);
      EXPECT_GT(stats.culled, 0u) << "the widened tight volumes proved no pair apart";
    }
    // One object against the manager: (managed, obj).
    std::vector<Obj<double>*> got_q, want_q;
    for (const auto& c : cube::contactsWithinMargin(m, objs[0])) {
      EXPECT_EQ(c.b, objs[0]);
      got_q.push_back(c.a);
    }
    for (const auto& t : want)
      if (std::get<0>(t) == objs[0] || std::get<1>(t) == objs[0])
        want_q.push_back(std::get<0>(t) == objs[0] ? std::get<1>(t) : std::get<0>(t));
    std::sort(got_q.begin(), got_q.end());
    std::sort(want_q.begin(), want_q.end());
    EXPECT_EQ(got_q, want_q);
  }
}

// Canonical order: two managers over the same registrations, with trees built differently,
// make the same calls in the same order, and contacts from FCL's narrow phase are bit-identical.
template <typename S>
std::vector<Pair<S>> calls(const CubeCollisionManager<S>& m) {
  std::vector<Pair<S>> c;
  m.collide([&](Obj<S>* a, Obj<S>* b) { c.emplace_back(a, b); });
  return c;
}

// Contracts stated in the headers, each against what the calls do.
namespace contracts {

std::unique_ptr<Obj<double>> box(double x, double size = 1) {
  auto o = std::make_unique<Obj<double>>(std::make_shared<fcl::Boxd>(size, size, size),
                                         fcl::Transform3d(Eigen::Translation3d(x, 0, 0)));
  o->computeAABB();
  return o;
}

std::size_t pairsBetween(const CubeCollisionManager<double>& m,
                         fcl::BroadPhaseCollisionManagerd& o) {
  std::size_t n = 0;
  m.collide(&o, &n, [](Obj<double>*, Obj<double>*, void* d) {
    ++*static_cast<std::size_t*>(d);
    return false;
  });
  return n;
}

}  // namespace contracts

// setMargin: against another cube manager each side's objects are grown by their own manager's
// margins; against any other manager, its objects by this manager's manager-wide margin.
TEST(Contracts, MarginsBetweenManagers) {
  using contracts::box;
  // Unit boxes whose faces are 1.8 apart: within 1.0 + 1.0, not within 1.0 + 0.5 or 0.5 + 0.5.
  auto a = box(0), b = box(2.8);
  CubeCollisionManager<double> ma, mb;
  ma.registerObject(a.get());
  mb.registerObject(b.get());
  ma.setMargin(1.0);
  mb.setMargin(0.5);
  fcl::DynamicAABBTreeCollisionManagerd fa, fb;
  fa.registerObject(a.get());
  fb.registerObject(b.get());
  fa.setup();
  fb.setup();
  EXPECT_EQ(contracts::pairsBetween(ma, mb), 0u) << "cube-cube: 1.0 + 0.5 < 1.8";
  EXPECT_EQ(contracts::pairsBetween(mb, ma), 0u);
  EXPECT_EQ(contracts::pairsBetween(ma, fb), 1u) << "b grown by ma's margin: 1.0 + 1.0 > 1.8";
  EXPECT_EQ(contracts::pairsBetween(mb, fa), 0u) << "a grown by mb's margin: 0.5 + 0.5 < 1.8";
  mb.setMargin(b.get(), 0.9);  // b's own margin: cube-cube now 1.0 + 0.9 > 1.8
  EXPECT_EQ(contracts::pairsBetween(ma, mb), 1u);
  EXPECT_EQ(contracts::pairsBetween(mb, ma), 1u);
}

// setPairFilter: in distance queries the predicate is asked for pairs whose boxes do not overlap
// (all the branch and bound hands over), and its false keeps a pair out of the minimum.
TEST(Contracts, PredicateInDistanceQueriesSeesPairsApart) {
  using contracts::box;
  auto a = box(0), b = box(3), c = box(10);
  CubeCollisionManager<double> m;
  m.registerObjects({a.get(), b.get(), c.get()});
  std::size_t apart = 0;
  m.setPairFilter([&](Obj<double>* x, Obj<double>* y) {
    apart += !x->getAABB().overlap(y->getAABB());
    return !((x == a.get() && y == b.get()) || (x == b.get() && y == a.get()));
  });
  double best = std::numeric_limits<double>::max();
  m.distance(&best, &cube::oracle::narrowDistance<double>);
  EXPECT_GT(apart, 0u);
  EXPECT_NEAR(best, 6.0, 1e-9) << "a-b (2 apart) dropped: b-c (6 apart) is the nearest";
}

// setFilter / setMargin: unregistering an object forgets its bits and its own margin.
TEST(Contracts, UnregisterForgetsBitsAndMargin) {
  using contracts::box;
  auto a = box(0), b = box(1.5);
  CubeCollisionManager<double> m;
  m.registerObjects({a.get(), b.get()});
  m.setFilter(a.get(), 2, 2);
  m.setMargin(a.get(), 3.0);
  EXPECT_EQ(m.filter(a.get()), std::make_pair(std::uint64_t(2), std::uint64_t(2)));
  EXPECT_EQ(m.margin(a.get()), 3.0);
  m.unregisterObject(a.get());
  m.registerObject(a.get());
  EXPECT_EQ(m.filter(a.get()), std::make_pair(std::uint64_t(1), ~std::uint64_t(0)));
  EXPECT_EQ(m.margin(a.get()), 0.0);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// contactsWithinMargin: a pair with a plane gets the distance of the objects' own AABBs, not
// of the boxes grown by the margins.
TEST(Contracts, PlaneContactsUseTheObjectsOwnAabbs) {
  using contracts::box;
  auto b = box(0);  // spans z in [-0.5, 0.5]
  Obj<double> plane(std::make_shared<fcl::Planed>(fcl::Vector3d(0, 0, 1), 2.0));
  plane.computeAABB();
  CubeCollisionManager<double> m;
  m.registerObjects({b.get(), &plane});
  m.setMargin(1.0);  // 1.5 apart, within 1.0 + 1.0
  const auto found = cube::contactsWithinMargin<double>(m);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_FALSE(found[0].colliding);
  EXPECT_EQ(found[0].distance, b->getAABB().distance(plane.getAABB()));
  EXPECT_NEAR(found[0].distance, 1.5, 1e-12);
}

// raycastObject's box test: the intersection of [0, 1] with every axis' interval. A segment that
// ends before the box or starts after it misses; one that ends on its face touches it at t = 1.
TEST(Contracts, RayBoxTestIsTheIntersectionOfTheIntervals) {
  auto o = contracts::box(0.5);  // the unit cube [0, 1]^3
  cube::RayOptions<double> box_only;
  box_only.narrow_phase = false;
  const auto hit = [&](double x0, double x1) {
    return cube::raycastObject<double>(*o, o->getAABB(), fcl::Vector3d(x0, 0.5, 0.5),
                                       fcl::Vector3d(x1, 0.5, 0.5), box_only);
  };
  EXPECT_FALSE(hit(-3, -1).has_value()) << "ends before the box";
  EXPECT_FALSE(hit(2, 3).has_value()) << "starts after it";
  EXPECT_FALSE(hit(-1, -3).has_value()) << "moves away from it";
  ASSERT_TRUE(hit(-1, 0).has_value());
  EXPECT_EQ(hit(-1, 0)->t, 1.0) << "ends on its face";
  ASSERT_TRUE(hit(-1, 3).has_value());
  EXPECT_EQ(hit(-1, 3)->t, 0.25);
  ASSERT_TRUE(hit(0.5, 3).has_value());
  EXPECT_EQ(hit(0.5, 3)->t, 0.0) << "starts inside";
}

TEST(CanonicalPairs, SameCallsWhateverTheTree) {
  auto sc = scene<double>(800, 91, 3.0);
  auto qs = scene<double>(50, 92, 3.0);
  const auto objs = sc.pointers();
  cube::Config a_cfg;
  a_cfg.canonical_pairs = true;
  cube::Config b_cfg = a_cfg;
  b_cfg.leaf_size = 2;
  b_cfg.keep_pairs = false;
  b_cfg.update_policy = cube::UpdatePolicy::refit;
  CubeCollisionManager<double> a(a_cfg), b(b_cfg);
  a.registerObjects(objs);
  for (auto* o : objs) b.registerObject(o);
  // b's tree is refitted after motions away and back, a's built once.
  auto saved = std::vector<fcl::Transform3<double>>();
  for (auto* o : objs) saved.push_back(o->getTransform());
  cube::scenes::jitter(sc, 1.0, 500.0, true, 3);
  b.update();
  for (std::size_t i = 0; i < objs.size(); ++i) {
    objs[i]->setTransform(saved[i]);
    objs[i]->computeAABB();
  }
  b.update();
  a.update();
  const auto ca = calls(a), cb = calls(b);
  EXPECT_EQ(ca, cb);
  // Oriented by registration (creation order here) and sorted.
  std::map<Obj<double>*, std::size_t> seq;
  for (std::size_t i = 0; i < objs.size(); ++i) seq[objs[i]] = i;
  for (std::size_t i = 0; i < ca.size(); ++i) {
    ASSERT_LT(seq[ca[i].first], seq[ca[i].second]);
    if (i > 0) {
      EXPECT_LT(std::make_pair(seq[ca[i - 1].first], seq[ca[i - 1].second]),
                std::make_pair(seq[ca[i].first], seq[ca[i].second]));
    }
  }
  EXPECT_EQ(cube::oracle::unorderedSorted(ca), cube::oracle::bruteSelfPairs(objs));
  // FCL's narrow phase on the pairs as handed over: the same contacts, bit for bit.
  const auto contacts = [](const CubeCollisionManager<double>& m) {
    fcl::CollisionRequest<double> req(1000000, true);
    fcl::CollisionResult<double> res;
    m.collide([&](Obj<double>* x, Obj<double>* y) { fcl::collide(x, y, req, res); });
    std::vector<double> out;
    for (std::size_t i = 0; i < res.numContacts(); ++i) {
      const auto& c = res.getContact(i);
      for (int k = 0; k < 3; ++k) out.insert(out.end(), {c.pos[k], c.normal[k]});
      out.push_back(c.penetration_depth);
    }
    return out;
  };
  const auto xa = contacts(a), xb = contacts(b);
  EXPECT_FALSE(xa.empty());
  EXPECT_TRUE(xa == xb) << "contacts differ";
  // Object queries and manager against manager, in order too.
  for (auto* q : {objs[5], qs.objects[0].get()}) {
    std::vector<Pair<double>> qa, qb;
    a.collide(q, [&](Obj<double>* x, Obj<double>* y) { qa.emplace_back(x, y); });
    b.collide(q, [&](Obj<double>* x, Obj<double>* y) { qb.emplace_back(x, y); });
    EXPECT_EQ(qa, qb);
    for (std::size_t i = 1; i < qa.size(); ++i) EXPECT_LT(seq[qa[i - 1].first], seq[qa[i].first]);
  }
  CubeCollisionManager<double> other(a_cfg);
  other.registerObjects(qs.pointers());
  std::vector<Pair<double>> ma, mb;
  a.collide(&other, [&](Obj<double>* x, Obj<double>* y) { ma.emplace_back(x, y); });
  b.collide(&other, [&](Obj<double>* x, Obj<double>* y) { mb.emplace_back(x, y); });
  EXPECT_EQ(ma, mb);
  EXPECT_EQ(cube::oracle::unorderedSorted(ma),
            cube::oracle::unorderedSorted(cube::oracle::bruteCrossPairs(objs, qs.pointers())));
  // An early stop stops at the first pair in that order.
  std::vector<Pair<double>> first;
  a.collide([&](Obj<double>* x, Obj<double>* y) {
    first.emplace_back(x, y);
    return true;
  });
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0], ca[0]);
}

TEST(CanonicalPairs, WithFiltersAndPairList) {
  auto sc = scene<double>(300, 101, 3.0);
  const auto objs = sc.pointers();
  cube::Config cfg;
  cfg.canonical_pairs = true;
  cfg.keep_pairs = true;
  CubeCollisionManager<double> m(cfg);
  m.registerObjects(objs);
  m.update();
  const auto bits = randomBits(m, objs, 23);
  EXPECT_TRUE(m.pairsListed());
  const auto c = calls(m);
  EXPECT_EQ(cube::oracle::unorderedSorted(c), bruteFiltered(objs, bits));
  cube::Config plain_cfg = cfg;
  plain_cfg.keep_pairs = false;
  CubeCollisionManager<double> plain(plain_cfg);
  plain.registerObjects(objs);
  for (auto* o : objs) {
    const Bits b = bitsOf(bits, o);
    plain.setFilter(o, b.category, b.mask);
  }
  EXPECT_EQ(calls(plain), c);
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

// ---------------------------------------------------------------------------------------------
// Excluded pairs (excludePair): every query against fcl::NaiveCollisionManager's pairs, or brute
// force over every pair, minus the excluded ones.

template <typename S>
void expectValid(const CubeCollisionManager<S>& m) {
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

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
