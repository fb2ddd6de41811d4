// QueryStats (inspect.h) counted by hand on tiny scenes: self, object, unbounded and
// manager-against-manager queries.

#include <gtest/gtest.h>

#include "support/inspect_suite.h"

namespace {

using namespace inspectsuite;

// QueryStats, counted by hand from src/traversal.cpp on three unit boxes along x:
//   A = [0,1], B = [0.5,1.5], C = [10,11] (y, z in [0,1]), leaf_size 1, tree R{A, R1{B, C}}.

template <typename S>
struct Tiny {
  std::shared_ptr<fcl::Box<S>> unit = std::make_shared<fcl::Box<S>>(1, 1, 1);
  std::unique_ptr<fcl::CollisionObject<S>> a, b, c;
  CubeCollisionManager<S> m;
  // all_pairs_limit 0: self-collide walks the cubes, as the hand counts below assume.
  explicit Tiny(std::size_t all_pairs_limit = 0) : m(config(all_pairs_limit)) {
    a = make(unit, 0.5);
    b = make(unit, 1.0);
    c = make(unit, 10.5);
    m.registerObjects({a.get(), b.get(), c.get()});
    m.setup();
  }
  static cube::Config config(std::size_t all_pairs_limit) {
    cube::Config cfg;
    cfg.leaf_size = 1;
    cfg.all_pairs_limit = all_pairs_limit;
    return cfg;
  }
  // An object centred at (x, 0.5, 0.5).
  static std::unique_ptr<fcl::CollisionObject<S>> make(std::shared_ptr<fcl::Box<S>> g, S x) {
    fcl::Transform3<S> t = fcl::Transform3<S>::Identity();
    t.translation() = fcl::Vector3<S>(x, 0.5, 0.5);
    auto o = std::make_unique<fcl::CollisionObject<S>>(g, t);
    o->computeAABB();
    return o;
  }
};

template <typename S>
struct Recorder {
  std::vector<std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>> calls;
  static bool collide(fcl::CollisionObject<S>* x, fcl::CollisionObject<S>* y, void* d) {
    static_cast<Recorder*>(d)->calls.emplace_back(x, y);
    return false;
  }
  // Never lowers the distance: every pair is visited, so the counts do not depend on distances.
  static bool distance(fcl::CollisionObject<S>* x, fcl::CollisionObject<S>* y, void* d, S&) {
    static_cast<Recorder*>(d)->calls.emplace_back(x, y);
    return false;
  }
  static bool stop(fcl::CollisionObject<S>* x, fcl::CollisionObject<S>* y, void* d) {
    static_cast<Recorder*>(d)->calls.emplace_back(x, y);
    return true;
  }
};

TYPED_TEST(InspectTest, QueryStatsSelfCollide) {
  using S = TypeParam;
  Tiny<S> t;
  {
    HierarchyView<S> v(t.m);
    ASSERT_EQ(v.getNumberCells(), 5);  // the tree the counts below assume
    ASSERT_EQ(v.getLeafIndex(t.a.get()), 1);
  }
  Recorder<S> r;
  cube::QueryStats st;
  t.m.collide(&r, &Recorder<S>::collide, &st);
  // Pops: (R,R) (A,A) (R1,R1) (B,B) (C,C) (A,R1) (A,B) = 7. Box tests: A-R1, B-C, A-B, A-C when
  // descending, then the objects A-B = 5. One callback: A-B.
  EXPECT_EQ(st.cubes_visited, 7u);
  EXPECT_EQ(st.box_tests, 5u);
  EXPECT_EQ(st.callbacks, 1u);
  EXPECT_EQ(st.callbacks, r.calls.size());
  // Stats add up across queries.
  t.m.collide(&r, &Recorder<S>::collide, &st);
  EXPECT_EQ(st.cubes_visited, 14u);
  EXPECT_EQ(st.box_tests, 10u);
  EXPECT_EQ(st.callbacks, 2u);
  // The same callbacks as without statistics.
  Recorder<S> plain;
  t.m.collide(&plain, &Recorder<S>::collide);
  ASSERT_EQ(plain.calls.size(), 1u);
  EXPECT_EQ(plain.calls[0], r.calls[0]);
}

// The all-pairs kernel (the default for small scenes): the three pairs are tested in float,
// then the one that passes (A-B) exactly; no cube is visited.
TYPED_TEST(InspectTest, QueryStatsSelfCollideAllPairs) {
  using S = TypeParam;
  Tiny<S> t(cube::Config().all_pairs_limit);
  Recorder<S> r;
  cube::QueryStats st;
  t.m.collide(&r, &Recorder<S>::collide, &st);
  EXPECT_EQ(st.cubes_visited, 0u);
  EXPECT_EQ(st.box_tests, 4u);
  EXPECT_EQ(st.callbacks, 1u);
  ASSERT_EQ(r.calls.size(), 1u);
  const std::set<fcl::CollisionObject<S>*> pair{r.calls[0].first, r.calls[0].second};
  EXPECT_EQ(pair, (std::set<fcl::CollisionObject<S>*>{t.a.get(), t.b.get()}));

  // With a halfspace in the unbounded list: the cubes (3 objects) against the list (1), both
  // small, take the all-pairs kernel too: their roots (1 test), each object against the other
  // side's root (3 + 1), the 3 pairs in float (3), each again exactly (3), 3 calls; no cube
  // visited. The list against itself holds one object, so no
  // pair. (Walked, as in QueryStatsWithUnboundedObject, the cubes against the list are 5 pops.)
  fcl::CollisionObject<S> half(
      std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 0, 1), S(0.5)));
  half.computeAABB();
  t.m.registerObject(&half);
  cube::QueryStats su;
  Recorder<S> ru;
  t.m.collide(&ru, &Recorder<S>::collide, &su);
  EXPECT_EQ(su.cubes_visited, 0u);
  EXPECT_EQ(su.box_tests, 4u + 1u + 4u + 3u + 3u);
  EXPECT_EQ(su.callbacks, 4u);
  EXPECT_EQ(ru.calls.size(), 4u);
}

TYPED_TEST(InspectTest, QueryStatsObjectQueries) {
  using S = TypeParam;
  Tiny<S> t;
  // Q = [0.9, 1.2] x [0,1] x [0,1] overlaps A and B.
  auto q = Tiny<S>::make(std::make_shared<fcl::Box<S>>(S(0.3), 1, 1), S(1.05));
  Recorder<S> r;
  cube::QueryStats st;
  t.m.collide(q.get(), &r, &Recorder<S>::collide, &st);
  // Tests R-Q, A-Q, R1-Q, (leaf) A-Q, B-Q, C-Q, (leaf) B-Q = 7; pops (R,Q) (A,Q) (R1,Q) (B,Q) = 4.
  EXPECT_EQ(st.cubes_visited, 4u);
  EXPECT_EQ(st.box_tests, 7u);
  EXPECT_EQ(st.callbacks, 2u);
  EXPECT_EQ(r.calls.size(), 2u);

  // Distance with a callback that never lowers the bound: every cube pair is kept.
  Recorder<S> rd;
  cube::QueryStats sd;
  t.m.distance(q.get(), &rd, &Recorder<S>::distance, &sd);
  EXPECT_EQ(sd.cubes_visited, 5u);
  EXPECT_EQ(sd.box_tests, 8u);
  EXPECT_EQ(sd.callbacks, 3u);
  EXPECT_EQ(rd.calls.size(), 3u);

  // A callback that stops at once: one call counted.
  Recorder<S> rs;
  cube::QueryStats ss;
  t.m.collide(q.get(), &rs, &Recorder<S>::stop, &ss);
  EXPECT_EQ(ss.callbacks, 1u);
  EXPECT_EQ(rs.calls.size(), 1u);
  EXPECT_LT(ss.cubes_visited, 4u);
}

TYPED_TEST(InspectTest, QueryStatsWithUnboundedObject) {
  using S = TypeParam;
  Tiny<S> t;
  // z <= 0.5 overlaps A, B and C: four overlapping pairs in all.
  fcl::CollisionObject<S> half(
      std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 0, 1), S(0.5)));
  half.computeAABB();
  t.m.registerObject(&half);
  {
    HierarchyView<S> v(t.m);
    ASSERT_EQ(v.getNumberCells(), 5);
    ASSERT_EQ(v.unboundedObjects().size(), 1u);
  }
  Recorder<S> r;
  cube::QueryStats st;
  t.m.collide(&r, &Recorder<S>::collide, &st);
  // cubes x cubes: 7 pops, 5 tests, 1 call. cubes x list: pops (R,U) (A,U) (R1,U) (B,U) (C,U),
  // tests R-U A-U R1-U, A-H, B-U C-U, B-H, C-H = 8, calls 3. list x list: one pop, nothing else.
  EXPECT_EQ(st.cubes_visited, 13u);
  EXPECT_EQ(st.box_tests, 13u);
  EXPECT_EQ(st.callbacks, 4u);
  EXPECT_EQ(r.calls.size(), 4u);
}

// Tree against tree, counted by hand on the current traversal (src/traversal.cpp: both cubes
// opened at once when both are internal, and a leaf-against-leaf prefilter of each object
// against the other leaf's cube when that leaf holds several objects).
TYPED_TEST(InspectTest, QueryStatsManagerPairs) {
  using S = TypeParam;
  Tiny<S> t;  // R{A, R1{B, C}}
  auto unit = std::make_shared<fcl::Box<S>>(S(0.1), 1, 1);
  auto d = Tiny<S>::make(unit, S(0.85));  // D = [0.8, 0.9]: overlaps A and B
  auto e = Tiny<S>::make(unit, S(20.5));  // E = [20.45, 20.55]: overlaps nothing
  {
    // leaf_size 1: the other tree is R2{D, E}.
    cube::Config cfg;
    cfg.leaf_size = 1;
    CubeCollisionManager<S> other(cfg);
    other.registerObjects({d.get(), e.get()});
    other.setup();
    ASSERT_EQ(HierarchyView<S>(other).getNumberCells(), 3);
    Recorder<S> r;
    cube::QueryStats st;
    t.m.collide(&other, &r, &Recorder<S>::collide, &st);
    // Pops (R,R2) (A,D) (R1,D) (B,D) = 4. Tests: R-R2, then A-D A-E R1-D R1-E from opening both,
    // the leaf pair A-D, B-D C-D, the leaf pair B-D = 9. Calls A-D, B-D.
    EXPECT_EQ(st.cubes_visited, 4u);
    EXPECT_EQ(st.box_tests, 9u);
    EXPECT_EQ(st.callbacks, 2u);
    EXPECT_EQ(r.calls.size(), 2u);
  }
  {
    // leaf_size 2: the other tree is one leaf L2 holding D and E.
    cube::Config cfg;
    cfg.leaf_size = 2;
    CubeCollisionManager<S> other(cfg);
    other.registerObjects({d.get(), e.get()});
    other.setup();
    ASSERT_EQ(HierarchyView<S>(other).getNumberCells(), 1);
    Recorder<S> r;
    cube::QueryStats st;
    t.m.collide(&other, &r, &Recorder<S>::collide, &st);
    // Pops (R,L2) (A,L2) (R1,L2) (B,L2) (C,L2) = 5. Tests: R-L2, A-L2, R1-L2, B-L2, C-L2, then
    // per leaf pair both object pairs, without a prefilter (A, B, C: 3 x 2 = 6) = 11. Calls A-D,
    // B-D.
    EXPECT_EQ(st.cubes_visited, 5u);
    EXPECT_EQ(st.box_tests, 11u);
    EXPECT_EQ(st.callbacks, 2u);
    EXPECT_EQ(r.calls.size(), 2u);
  }
}

}  // namespace
