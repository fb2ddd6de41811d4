// The inspection snapshot against validate(), the raw hierarchy and brute force over the objects,
// before and after incremental changes; QueryStats counted by hand on tiny scenes.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/halfspace.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/inspect.h"
#include "scenes.h"

namespace {

using cube::CubeCollisionManager;
using cube::HierarchyView;

bool isDead(const cube::detail::Node& n) {
  return n.first == cube::detail::kNone && n.count == 0;
}

// Checks every promise of HierarchyView on `m` and returns the view for further checks.
template <typename S>
HierarchyView<S> checkView(const CubeCollisionManager<S>& m) {
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
  const auto& h = ::cube::detail::coreOf(m).tree();
  HierarchyView<S> v(m);
  const int n = v.getNumberCells();

  // Dense numbering over the live cubes only.
  std::size_t live = 0;
  for (const auto& node : h.nodes()) live += !isDead(node);
  EXPECT_EQ(std::size_t(n), live);
  EXPECT_EQ(n == 0, h.root() == cube::detail::kNone);

  // Levels partition [0, n) in order; parents, children and levels agree.
  int next = 0;
  for (int l = 0; l < v.levelCount(); ++l) {
    const auto r = v.levelCubes(l);
    EXPECT_EQ(r.first, next);
    EXPECT_LT(r.first, r.second) << "empty level " << l;
    for (int i = r.first; i < r.second; ++i) EXPECT_EQ(v.getCubeData(i).level, l);
    next = r.second;
  }
  EXPECT_EQ(next, n);
  EXPECT_EQ(v.depth(), v.levelCount() - 1);
  EXPECT_EQ(v.levelCubes(v.levelCount()), std::make_pair(0, 0));
  if (m.config().max_depth > 0) {
    EXPECT_LE(v.depth(), m.config().max_depth);
  }

  std::vector<int> parent_seen(std::size_t(n), 0);
  for (int i = 0; i < n; ++i) {
    const cube::CubeData& c = v.getCubeData(i);
    const auto kids = v.getInternalChildren(i);
    EXPECT_EQ(kids, std::make_pair(c.first_child, c.end_child));
    if (i == 0) {
      EXPECT_EQ(c.parent, -1);
    }
    if (v.isLeaf(i)) {
      EXPECT_EQ(kids.first, kids.second);
      EXPECT_GE(c.end_object - c.first_object, 1) << "empty leaf " << i;
      if (m.config().max_depth == 0 || c.level < m.config().max_depth) {
        EXPECT_LE(c.end_object - c.first_object, m.config().leaf_size);
      }
    } else {
      EXPECT_EQ(kids.second - kids.first, 2);
      EXPECT_GT(kids.first, i);
      if (kids.second > n) {
        ADD_FAILURE() << "children of " << i << " out of range";
        continue;
      }
      // The subtree's objects are exactly its children's, contiguous.
      EXPECT_EQ(c.first_object, v.getCubeData(kids.first).first_object);
      EXPECT_EQ(v.getCubeData(kids.first).end_object, v.getCubeData(kids.first + 1).first_object);
      EXPECT_EQ(c.end_object, v.getCubeData(kids.first + 1).end_object);
      for (int k = kids.first; k < kids.second; ++k) {
        const cube::CubeData& ch = v.getCubeData(k);
        ++parent_seen[std::size_t(k)];
        EXPECT_EQ(ch.parent, i);
        EXPECT_EQ(ch.level, c.level + 1);
        for (int a = 0; a < 3; ++a) {
          EXPECT_LE(c.min[a], ch.min[a]);
          EXPECT_GE(c.max[a], ch.max[a]);
        }
      }
    }
    const auto ext = v.getExternalChildren(i);
    EXPECT_EQ(int(ext.size()), c.end_object - c.first_object);
    // Every object below a cube lies inside it (exact AABB from FCL, not the cached copy).
    for (const auto* o : ext) {
      const auto& bb = o->getAABB();
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(c.min[a], double(bb.min_[a])) << "cube " << i;
        EXPECT_GE(c.max[a], double(bb.max_[a])) << "cube " << i;
      }
    }
  }
  for (int i = 1; i < n; ++i) EXPECT_EQ(parent_seen[std::size_t(i)], 1) << "cube " << i;
  if (n > 0) {
    EXPECT_EQ(v.getCubeData(0).first_object, 0);
    EXPECT_EQ(v.getCubeData(0).end_object, int(v.objects().size()));
  }

  // Brute force over the registered objects: each bounded one in exactly one leaf, and
  // getLeafIndex agrees with the leaves' ranges and with the hierarchy's own parentOf.
  std::vector<fcl::CollisionObject<S>*> all;
  m.getObjects(all);
  const std::set<fcl::CollisionObject<S>*> unbounded(v.unboundedObjects().begin(),
                                                     v.unboundedObjects().end());
  EXPECT_EQ(unbounded.size(), v.unboundedObjects().size());
  EXPECT_EQ(v.objects().size() + unbounded.size(), all.size());
  std::map<const fcl::CollisionObject<S>*, int> leaf_count;
  for (int i = 0; i < n; ++i)
    if (v.isLeaf(i))
      for (const auto* o : v.getExternalChildren(i)) {
        ++leaf_count[o];
        EXPECT_EQ(v.getLeafIndex(o), i);
      }
  for (auto* o : all) {
    if (unbounded.count(o)) {
      EXPECT_EQ(v.getLeafIndex(o), -1);
      EXPECT_EQ(leaf_count.count(o), 0u);
    } else {
      EXPECT_EQ(leaf_count[o], 1);
    }
  }
  for (const auto& it : h.items()) {
    if (it.obj == nullptr) continue;
    const int leaf = v.getLeafIndex(it.obj);
    if (leaf < 0) {
      ADD_FAILURE() << "live object in no leaf";
      continue;
    }
    const auto& node = h.nodes()[it.leaf];
    const cube::CubeData& c = v.getCubeData(leaf);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(c.min[a], double(node.lo[a]));
      EXPECT_EQ(c.max[a], double(node.hi[a]));
    }
    EXPECT_EQ(std::uint32_t(c.end_object - c.first_object), node.count);
  }
  for (int k = 0; k < int(v.objects().size()); ++k) {
    const auto& bb = v.objects()[std::size_t(k)]->getAABB();
    const cube::BoundingBox& b = v.objectBox(k);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(b.first[a], double(bb.min_[a]));
      EXPECT_EQ(b.second[a], double(bb.max_[a]));
    }
  }

  std::vector<cube::BoundingBox> tree{{{1, 2, 3}, {4, 5, 6}}};  // replaced, not appended to
  v.getBoundingTree(tree);
  EXPECT_EQ(int(tree.size()), n);
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(tree[std::size_t(i)].first, v.getCubeData(i).min);
    EXPECT_EQ(tree[std::size_t(i)].second, v.getCubeData(i).max);
  }

  // Statistics.
  const cube::HierarchyStats& s = v.stats();
  EXPECT_EQ(s.cubes, std::size_t(n));
  EXPECT_EQ(s.cubes + s.dead_cubes, h.nodes().size());
  EXPECT_EQ(s.objects, v.objects().size());
  EXPECT_EQ(s.unbounded_objects, unbounded.size());
  EXPECT_EQ(s.depth, v.depth());
  std::size_t leaves = 0, in_leaves = 0, hist_leaves = 0, max_leaf = 0;
  double volume = 0;
  for (int i = 0; i < n; ++i) {
    const cube::CubeData& c = v.getCubeData(i);
    volume += (c.max[0] - c.min[0]) * (c.max[1] - c.min[1]) * (c.max[2] - c.min[2]);
    if (!v.isLeaf(i)) continue;
    ++leaves;
    in_leaves += std::size_t(c.end_object - c.first_object);
    max_leaf = std::max(max_leaf, std::size_t(c.end_object - c.first_object));
  }
  EXPECT_EQ(s.leaves, leaves);
  for (std::size_t k = 0; k < s.leaf_size_histogram.size(); ++k)
    hist_leaves += s.leaf_size_histogram[k];
  EXPECT_EQ(hist_leaves, leaves);
  std::size_t weighted = 0;
  for (std::size_t k = 0; k < s.leaf_size_histogram.size(); ++k)
    weighted += k * s.leaf_size_histogram[k];
  EXPECT_EQ(weighted, in_leaves);
  EXPECT_EQ(s.max_leaf_size, max_leaf);
  std::size_t per_level = 0;
  for (std::size_t c : s.cubes_per_level) per_level += c;
  EXPECT_EQ(per_level, std::size_t(n));
  EXPECT_NEAR(s.volume, volume, 1e-9 * std::max(1.0, volume));
  EXPECT_NEAR(s.surface_area, h.area(), 1e-6 * std::max(1.0, h.area()));
  EXPECT_DOUBLE_EQ(s.quality_ratio, h.quality());
  EXPECT_EQ(s.bytes, m.bytes());
  EXPECT_EQ(s.builds, h.buildCount());
  if (!all.empty()) {
    EXPECT_DOUBLE_EQ(s.bytes_per_object, double(m.bytes()) / double(all.size()));
  }
  std::size_t dead_slots = 0;
  for (const auto& it : h.items()) dead_slots += it.obj == nullptr;
  EXPECT_EQ(s.dead_object_slots, dead_slots);
  return v;
}

template <typename S>
class InspectTest : public ::testing::Test {};
using Scalars = ::testing::Types<float, double>;
TYPED_TEST_SUITE(InspectTest, Scalars);

TYPED_TEST(InspectTest, EmptyManager) {
  using S = TypeParam;
  CubeCollisionManager<S> m;
  m.setup();
  HierarchyView<S> v = checkView(m);
  EXPECT_EQ(v.getNumberCells(), 0);
  EXPECT_EQ(v.depth(), -1);
  EXPECT_EQ(v.levelCount(), 0);
  EXPECT_EQ(v.stats().leaves, 0u);
  EXPECT_THROW(v.getCubeData(0), std::out_of_range);
  EXPECT_THROW(v.isLeaf(-1), std::out_of_range);
}

TYPED_TEST(InspectTest, HandBuiltTree) {
  using S = TypeParam;
  // Three unit boxes along x, leaf_size 1: the root splits [A] | [B, C], then [B] | [C].
  auto g = std::make_shared<fcl::Box<S>>(1, 1, 1);
  auto at = [&](S x) {
    fcl::Transform3<S> t = fcl::Transform3<S>::Identity();
    t.translation() = fcl::Vector3<S>(x, S(0.5), S(0.5));
    auto o = std::make_unique<fcl::CollisionObject<S>>(g, t);
    o->computeAABB();
    return o;
  };
  auto a = at(0.5), b = at(1.0), c = at(10.5);
  cube::Config cfg;
  cfg.leaf_size = 1;
  CubeCollisionManager<S> m(cfg);
  m.registerObjects({a.get(), b.get(), c.get()});
  m.setup();
  HierarchyView<S> v = checkView(m);
  ASSERT_EQ(v.getNumberCells(), 5);
  EXPECT_EQ(v.depth(), 2);
  EXPECT_EQ(v.levelCubes(0), std::make_pair(0, 1));
  EXPECT_EQ(v.levelCubes(1), std::make_pair(1, 3));
  EXPECT_EQ(v.levelCubes(2), std::make_pair(3, 5));
  EXPECT_EQ(v.getInternalChildren(0), std::make_pair(1, 3));
  EXPECT_TRUE(v.isLeaf(1));
  EXPECT_FALSE(v.isLeaf(2));
  EXPECT_EQ(v.getInternalChildren(2), std::make_pair(3, 5));
  EXPECT_EQ(v.getLeafIndex(a.get()), 1);
  EXPECT_EQ(v.getLeafIndex(b.get()), 3);
  EXPECT_EQ(v.getLeafIndex(c.get()), 4);
  const auto below = v.getExternalChildren(2);
  EXPECT_EQ(std::vector<fcl::CollisionObject<S>*>(below.begin(), below.end()),
            (std::vector<fcl::CollisionObject<S>*>{b.get(), c.get()}));
  // Bounds: rounded outward to float, never inward.
  const cube::CubeData& root = v.getCubeData(0);
  EXPECT_LE(root.min[0], 0.0);
  EXPECT_NEAR(root.min[0], 0.0, 1e-6);
  EXPECT_GE(root.max[0], 11.0);
  EXPECT_NEAR(root.max[0], 11.0, 1e-5);
  EXPECT_EQ(v.stats().leaf_size_histogram, (std::vector<std::size_t>{0, 3}));
  EXPECT_EQ(v.stats().cubes_per_level, (std::vector<std::size_t>{1, 2, 2}));
  EXPECT_DOUBLE_EQ(v.stats().quality_ratio, 1.0);
  // An unregistered object has no leaf.
  auto d = at(3);
  EXPECT_EQ(v.getLeafIndex(d.get()), -1);
  EXPECT_EQ(v.getLeafIndex(nullptr), -1);
  std::ostringstream text;
  text << v.stats();
  EXPECT_NE(text.str().find("5 (3 leaves), depth 2"), std::string::npos) << text.str();
}

TYPED_TEST(InspectTest, SceneThroughIncrementalChanges) {
  using S = TypeParam;
  cube::scenes::SceneOptions opt;
  opt.n = 400;
  opt.layout = cube::scenes::Layout::clustered;
  opt.seed = 7;
  auto scene = cube::scenes::makeScene<S>(opt);
  auto objs = scene.pointers();

  CubeCollisionManager<S> m;
  m.registerObjects(objs);
  m.setup();
  {
    SCOPED_TRACE("built");
    HierarchyView<S> v = checkView(m);
    EXPECT_EQ(v.objects().size(), objs.size());
    EXPECT_GT(v.depth(), 3);
  }
  // One by one, without setup(): the incremental path.
  auto extra = cube::scenes::makeScene<S>([&] {
    auto o = opt;
    o.n = 60;
    o.seed = 8;
    return o;
  }());
  for (auto* o : extra.pointers()) m.registerObject(o);
  {
    SCOPED_TRACE("incremental registers");
    checkView(m);
  }
  for (std::size_t i = 0; i < objs.size(); i += 3) m.unregisterObject(objs[i]);
  {
    SCOPED_TRACE("unregisters");
    HierarchyView<S> v = checkView(m);
    EXPECT_EQ(v.getLeafIndex(objs[0]), -1);
  }
  // A halfspace goes to the unbounded list.
  auto half = std::make_unique<fcl::CollisionObject<S>>(
      std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 0, 1), S(0)));
  half->computeAABB();
  m.registerObject(half.get());
  {
    SCOPED_TRACE("unbounded");
    HierarchyView<S> v = checkView(m);
    EXPECT_EQ(v.stats().unbounded_objects, 1u);
    EXPECT_EQ(v.getLeafIndex(half.get()), -1);
  }
  // Small moves refit; the quality ratio follows the area.
  const auto moved = cube::scenes::jitter(scene, 0.3, cube::scenes::typicalSize(opt), true, 9);
  for (auto* o : moved) m.update(o);
  {
    SCOPED_TRACE("update(obj)");
    checkView(m);
  }
  cube::scenes::jitter(scene, 1.0, 5 * cube::scenes::typicalSize(opt), false, 10);
  m.update();
  {
    SCOPED_TRACE("update()");
    checkView(m);
  }
  m.setup();
  {
    SCOPED_TRACE("setup again");
    checkView(m);
  }
}

TYPED_TEST(InspectTest, MaxDepthCapsLevels) {
  using S = TypeParam;
  cube::scenes::SceneOptions opt;
  opt.n = 300;
  auto scene = cube::scenes::makeScene<S>(opt);
  cube::Config cfg;
  cfg.max_depth = 3;
  cfg.leaf_size = 1;
  CubeCollisionManager<S> m(cfg);
  m.registerObjects(scene.pointers());
  m.setup();
  HierarchyView<S> v = checkView(m);
  EXPECT_EQ(v.depth(), 3);
  EXPECT_EQ(v.stats().cubes_per_level, (std::vector<std::size_t>{1, 2, 4, 8}));
  EXPECT_EQ(v.stats().leaves, 8u);
  EXPECT_GE(v.stats().max_leaf_size, 300u / 8);
}

TYPED_TEST(InspectTest, NumberingIsStableForTheSameTree) {
  using S = TypeParam;
  cube::scenes::SceneOptions opt;
  opt.n = 200;
  opt.seed = 3;
  auto scene = cube::scenes::makeScene<S>(opt);
  CubeCollisionManager<S> m1, m2;
  m1.registerObjects(scene.pointers());
  m1.setup();
  // The second one gets there by another history: incremental inserts, removals, rebuild.
  auto objs = scene.pointers();
  for (auto* o : objs) m2.registerObject(o);
  for (std::size_t i = 0; i < objs.size(); i += 2) m2.unregisterObject(objs[i]);
  for (std::size_t i = 0; i < objs.size(); i += 2) m2.registerObject(objs[i]);
  m2.setup();
  HierarchyView<S> v1(m1), v2(m2);
  std::vector<cube::BoundingBox> t1, t2;
  v1.getBoundingTree(t1);
  v2.getBoundingTree(t2);
  // Distinct centres: the median splits do not depend on registration order, so same tree.
  EXPECT_EQ(t1, t2);
  ASSERT_EQ(v1.getNumberCells(), v2.getNumberCells());
  for (int i = 0; i < v1.getNumberCells(); ++i) {
    const auto e1 = v1.getExternalChildren(i), e2 = v2.getExternalChildren(i);
    EXPECT_EQ(std::set<fcl::CollisionObject<S>*>(e1.begin(), e1.end()),
              std::set<fcl::CollisionObject<S>*>(e2.begin(), e2.end()));
  }
  HierarchyView<S> again(m1);
  std::vector<cube::BoundingBox> t3;
  again.getBoundingTree(t3);
  EXPECT_EQ(t1, t3);
  EXPECT_EQ(v1.objects(), again.objects());
}

// ---------------------------------------------------------------------------------------------
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
