// The inspection snapshot (inspect.h) against validate(), the raw hierarchy and brute force over
// the objects, before and after incremental changes.

#include <gtest/gtest.h>

#include "support/inspect_suite.h"

namespace {

using namespace inspectsuite;

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

}  // namespace
