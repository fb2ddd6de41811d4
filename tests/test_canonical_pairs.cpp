// Canonical pair order (Config::canonical_pairs): the same calls in the same order whatever the
// tree, with filter bits and the pair list too.

#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include "support/oracle.h"
#include "support/pair_rules_world.h"

namespace {

using namespace pair_rules;

// Canonical order: two managers over the same registrations, with trees built differently,
// make the same calls in the same order, and contacts from FCL's narrow phase are bit-identical.
template <typename S>
std::vector<Pair<S>> calls(const CubeCollisionManager<S>& m) {
  std::vector<Pair<S>> c;
  m.collide([&](Obj<S>* a, Obj<S>* b) { c.emplace_back(a, b); });
  return c;
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

}  // namespace
