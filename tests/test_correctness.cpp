// Scenes against fcl::NaiveCollisionManager: candidate pairs, colliding pairs, contact counts and
// minimum distances of the cube manager equal what Naive (or brute force over the AABBs) gives
// on the same objects, for self queries, object queries and manager-vs-manager queries, in double
// and float.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"
#include "support/correctness.h"

namespace cube {
namespace testing {
namespace {

enum class Scalar { d, f };

struct Case {
  std::string name;
  Scalar scalar;
  scenes::SceneOptions scene;
  /// Query objects for the candidate checks: about half registered scene objects, the rest from
  /// another scene of the same kind.
  std::size_t queries;
  /// How many of those are also checked through the narrow phase against Naive (Naive runs the
  /// narrow phase on every object for each query, so this is the expensive part).
  std::size_t narrow_queries;
  /// Register objects one at a time after an initial setup() instead of in one batch.
  bool incremental = false;
  /// Config::all_pairs_limit of the cube manager (0: small scenes walk the cubes too).
  std::size_t all_pairs_limit = cube::Config().all_pairs_limit;
};

std::ostream& operator<<(std::ostream& os, const Case& c) {
  return os << c.name;
}

std::string caseName(const ::testing::TestParamInfo<Case>& info) {
  return info.param.name;
}

Case makeCase(Scalar s, scenes::Layout layout, bool meshes, std::size_t n, std::size_t queries,
              std::size_t narrow_queries, double size_scale = 1.0, bool incremental = false) {
  Case c;
  c.scalar = s;
  c.scene.n = n;
  c.scene.layout = layout;
  c.scene.meshes = meshes;
  c.scene.seed = static_cast<std::uint32_t>(17 + n);
  c.scene.size_scale = size_scale;
  c.queries = queries;
  c.narrow_queries = narrow_queries;
  c.incremental = incremental;
  const char* lay = layout == scenes::Layout::uniform     ? "uniform"
                    : layout == scenes::Layout::clustered ? "clustered"
                                                          : "thin";
  c.name = std::string(s == Scalar::d ? "double_" : "float_") + lay +
           (meshes ? "_meshes_" : "_prims_") + std::to_string(n) +
           (incremental ? "_incremental" : "");
  return c;
}

std::vector<Case> collideCases() {
  using L = scenes::Layout;
  std::vector<Case> out;
  for (Scalar s : {Scalar::d, Scalar::f}) {
    for (std::size_t n : {0, 1, 2, 32, 300, 1000})
      out.push_back(makeCase(s, L::uniform, false, n, n == 0 ? 4 : 1000, n >= 1000 ? 40 : 100));
    for (std::size_t n : {32, 300, 1000})
      out.push_back(makeCase(s, L::clustered, false, n, 1000, n >= 1000 ? 40 : 100));
    out.push_back(makeCase(s, L::thin, false, 300, 300, 60));
    out.push_back(makeCase(s, L::uniform, false, 300, 300, 60, 1.0, true));
    out.push_back(makeCase(s, L::clustered, false, 1000, 300, 20, 1.0, true));
    // Meshes: the narrow phase is much slower, so fewer objects and queries.
    for (std::size_t n : {0, 1, 2, 32, 200})
      out.push_back(makeCase(s, L::uniform, true, n, n == 0 ? 4 : 200, 20));
    out.push_back(makeCase(s, L::clustered, true, 200, 200, 20));
    // Small scenes self-collide through the all-pairs kernel by default; these walk the cubes.
    for (Case c : {makeCase(s, L::uniform, false, 32, 100, 40),
                   makeCase(s, L::clustered, false, 60, 100, 40),
                   makeCase(s, L::uniform, true, 32, 32, 10)}) {
      c.all_pairs_limit = 0;
      c.name += "_walk";
      out.push_back(c);
    }
  }
  return out;
}

std::vector<Case> distanceCases() {
  using L = scenes::Layout;
  std::vector<Case> out;
  // size_scale small: nothing touches, so the minimum distance is positive and well defined.
  for (Scalar s : {Scalar::d, Scalar::f}) {
    for (std::size_t n : {2, 32, 300, 1000})
      out.push_back(makeCase(s, L::uniform, false, n, n >= 1000 ? 300 : 200, 0, 0.02));
    for (std::size_t n : {32, 1000})
      out.push_back(makeCase(s, L::clustered, false, n, 200, 0, 0.02));
    out.push_back(makeCase(s, L::uniform, false, 300, 100, 0, 0.02, true));
    for (std::size_t n : {32, 150}) out.push_back(makeCase(s, L::uniform, true, n, 60, 0, 0.02));
  }
  for (auto& c : out) c.name = "far_" + c.name;
  return out;
}

/// The scene, a cube manager and a Naive manager over it, and query objects.
template <typename S>
struct World {
  scenes::Scene<S> scene;
  scenes::Scene<S> others;  // unregistered query objects, and the second manager's objects
  std::vector<Obj<S>*> objs;
  std::vector<Obj<S>*> queries;  // registered ones first
  std::size_t registered_queries = 0;
  CubeCollisionManager<S> cube;
  fcl::NaiveCollisionManager<S> naive;

  static cube::Config configFor(const Case& c) {
    cube::Config config;
    config.all_pairs_limit = c.all_pairs_limit;
    return config;
  }

  explicit World(const Case& c) : cube(configFor(c)) {
    scene = scenes::makeScene<S>(c.scene);
    objs = scene.pointers();
    scenes::SceneOptions o = c.scene;
    o.seed += 1000;
    o.n = std::max<std::size_t>(c.queries - std::min(c.queries / 2, objs.size()), c.scene.n / 2);
    others = scenes::makeScene<S>(o);
    registerInto(cube, objs, c.incremental);
    for (auto* p : objs) naive.registerObject(p);
    naive.setup();
    // Registered query objects spread over the scene, then unregistered ones.
    registered_queries = std::min(c.queries / 2, objs.size());
    for (std::size_t i = 0; i < registered_queries; ++i)
      queries.push_back(objs[i * objs.size() / registered_queries]);
    const auto other_ptrs = others.pointers();
    for (std::size_t i = 0; queries.size() < c.queries && i < other_ptrs.size(); ++i)
      queries.push_back(other_ptrs[i]);
  }

  /// Whether query #i also gets the narrow-phase comparison: the first `narrow_queries` of the
  /// registered ones and of the unregistered ones.
  bool narrow(const Case& c, std::size_t i) const {
    return i < registered_queries ? i < c.narrow_queries
                                  : i - registered_queries < c.narrow_queries;
  }

  static void registerInto(CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& v,
                           bool incremental) {
    if (!incremental) {
      m.registerObjects(v);
      m.setup();
      return;
    }
    // A quarter in one batch and built, the rest one by one with no further setup().
    const std::size_t first = v.size() / 4;
    m.registerObjects(std::vector<Obj<S>*>(v.begin(), v.begin() + first));
    m.setup();
    for (std::size_t i = first; i < v.size(); ++i) m.registerObject(v[i]);
  }
};

// Each test is written once as a template and dispatched on the case's scalar type.
#define CUBE_DISPATCH(fn)                 \
  do {                                    \
    if (GetParam().scalar == Scalar::d) { \
      fn<double>(GetParam());             \
    } else {                              \
      fn<float>(GetParam());              \
    }                                     \
  } while (0)

class SceneCollide : public ::testing::TestWithParam<Case> {};
class SceneDistance : public ::testing::TestWithParam<Case> {};

template <typename S>
void selfCandidates(const Case& c) {
  World<S> w(c);
  ASSERT_TRUE(valid(w.cube));
  ASSERT_EQ(w.cube.size(), w.objs.size());
  const auto brute = oracle::bruteSelfPairs(w.objs);
  const auto got = oracle::selfPairs<S>(w.cube);
  EXPECT_EQ(got.size(), brute.size());
  EXPECT_TRUE(got == brute) << "self-collide candidates differ from brute-force AABB pairs";
  EXPECT_TRUE(oracle::selfPairs<S>(w.naive) == brute);
  // The scene must exercise something: with 32 objects or more some AABBs overlap.
  if (c.scene.n >= 32) {
    EXPECT_FALSE(brute.empty());
  }
  // collide(this) is the same self query.
  Calls<S> self, via_this;
  w.cube.collide(&self, &Calls<S>::record);
  w.cube.collide(&w.cube, &via_this, &Calls<S>::record);
  EXPECT_TRUE(self.calls == via_this.calls);
}

template <typename S>
void selfColliding(const Case& c) {
  World<S> w(c);
  Colliding<S> mine, theirs;
  w.cube.collide(&mine, &Colliding<S>::record);
  w.naive.collide(&theirs, &Colliding<S>::record);
  EXPECT_EQ(mine.result().size(), theirs.result().size());
  EXPECT_TRUE(mine.result() == theirs.result());
  if (c.scene.n >= 300) {
    EXPECT_FALSE(theirs.hits.empty()) << "scene has no collision to find";
  }
}

template <typename S>
void selfContacts(const Case& c) {
  World<S> w(c);
  for (std::size_t budget : contactBudgets()) {
    SCOPED_TRACE("num_max_contacts " + std::to_string(budget));
    const ContactOutcome expected = fclContacts<S>(
        budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.naive.collide(d, f); });
    const ContactOutcome with_fcl =
        fclContacts<S>(budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.cube.collide(d, f); });
    const ContactOutcome with_ours = cubeContacts<S>(
        budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.cube.collide(d, f); });
    EXPECT_EQ(with_fcl, expected);
    EXPECT_EQ(with_ours, expected);
  }
}

template <typename S>
void objectQueries(const Case& c) {
  World<S> w(c);
  std::size_t nonempty = 0;
  for (std::size_t i = 0; i < w.queries.size(); ++i) {
    Obj<S>* q = w.queries[i];
    SCOPED_TRACE("query #" + std::to_string(i));
    // Candidates, with the argument order (managed, query).
    const auto expected = bruteCrossPairs<S>(w.objs, {q});
    const auto got = cubeObjectCalls<S>(w.cube, q);
    ASSERT_TRUE(got == expected) << got.size() << " calls, " << expected.size() << " expected";
    nonempty += !expected.empty();
    if (!w.narrow(c, i)) continue;
    Colliding<S> mine, theirs;
    w.cube.collide(q, &mine, &Colliding<S>::record);
    w.naive.collide(q, &theirs, &Colliding<S>::record);
    ASSERT_TRUE(mine.result() == theirs.result());
  }
  if (c.scene.n >= 32) {
    EXPECT_GT(nonempty, 0u) << "no query overlaps anything";
  }
}

template <typename S>
void objectContacts(const Case& c) {
  World<S> w(c);
  // Registered and unregistered queries alike.
  std::vector<Obj<S>*> qs;
  for (std::size_t i = 0; i < w.queries.size(); ++i)
    if (w.narrow(c, i)) qs.push_back(w.queries[i]);
  for (std::size_t budget : contactBudgets()) {
    for (std::size_t i = 0; i < qs.size(); ++i) {
      Obj<S>* q = qs[i];
      SCOPED_TRACE("num_max_contacts " + std::to_string(budget) + ", query #" + std::to_string(i));
      const ContactOutcome expected = fclContacts<S>(
          budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.naive.collide(q, d, f); });
      const ContactOutcome with_fcl = fclContacts<S>(
          budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.cube.collide(q, d, f); });
      const ContactOutcome with_ours = cubeContacts<S>(
          budget, [&](void* d, fcl::CollisionCallBack<S> f) { w.cube.collide(q, d, f); });
      ASSERT_EQ(with_fcl, expected);
      ASSERT_EQ(with_ours, expected);
    }
  }
}

/// Both directions of manager-vs-manager between the scene and the other scene, with Naive, a
/// DynamicAABBTree and another cube manager on the other side.
template <typename S>
void managerVsManager(const Case& c) {
  World<S> w(c);
  const auto other_objs = w.others.pointers();
  struct Side {
    std::vector<Obj<S>*> objs;
    fcl::NaiveCollisionManager<S> naive;
    fcl::DynamicAABBTreeCollisionManager<S> tree;
    CubeCollisionManager<S> cube;
  };
  Side a, b;
  a.objs = w.objs;
  b.objs = other_objs;
  for (Side* s : {&a, &b}) {
    for (auto* o : s->objs) s->naive.registerObject(o);
    s->tree.registerObjects(s->objs);
    s->tree.setup();
    World<S>::registerInto(s->cube, s->objs, c.incremental);
  }
  for (int dir = 0; dir < 2; ++dir) {
    Side& me = dir == 0 ? a : b;
    Side& them = dir == 0 ? b : a;
    const auto expected = bruteCrossPairs<S>(me.objs, them.objs);
    ASSERT_TRUE(managerCalls<S>(me.naive, &them.naive) == expected);
    if (c.scene.n >= 300) {
      EXPECT_FALSE(expected.empty());
    }
    Colliding<S> naive_hits;
    me.naive.collide(&them.naive, &naive_hits, &Colliding<S>::record);
    std::vector<std::pair<const char*, Manager<S>*>> others{
        {"naive", &them.naive}, {"dynamic AABB tree", &them.tree}, {"cube", &them.cube}};
    for (const auto& entry : others) {
      const char* name = entry.first;
      Manager<S>* other = entry.second;  // a plain variable: lambdas capture it (C++17)
      SCOPED_TRACE(std::string(dir == 0 ? "scene vs other, " : "other vs scene, ") + name);
      // Sorted ordered pairs: equal means every call was (this object, other object).
      const auto got = managerCalls<S>(me.cube, other);
      EXPECT_EQ(got.size(), expected.size());
      EXPECT_TRUE(got == expected);
      Colliding<S> hits;
      me.cube.collide(other, &hits, &Colliding<S>::record);
      EXPECT_TRUE(hits.result() == naive_hits.result());
      for (std::size_t budget : contactBudgets()) {
        SCOPED_TRACE("num_max_contacts " + std::to_string(budget));
        const ContactOutcome exp = fclContacts<S>(
            budget,
            [&](void* d, fcl::CollisionCallBack<S> f) { me.naive.collide(&them.naive, d, f); });
        EXPECT_EQ(fclContacts<S>(
                      budget,
                      [&](void* d, fcl::CollisionCallBack<S> f) { me.cube.collide(other, d, f); }),
                  exp);
        EXPECT_EQ(cubeContacts<S>(
                      budget,
                      [&](void* d, fcl::CollisionCallBack<S> f) { me.cube.collide(other, d, f); }),
                  exp);
      }
    }
  }
}

TEST_P(SceneCollide, SelfCandidatesEqualBruteForceAndNaive) {
  CUBE_DISPATCH(selfCandidates);
}
TEST_P(SceneCollide, SelfCollidingPairsEqualNaive) {
  CUBE_DISPATCH(selfColliding);
}
TEST_P(SceneCollide, SelfContactCountsEqualNaive) {
  CUBE_DISPATCH(selfContacts);
}
TEST_P(SceneCollide, ObjectQueriesEqualBruteForceAndNaive) {
  CUBE_DISPATCH(objectQueries);
}
TEST_P(SceneCollide, ObjectContactCountsEqualNaive) {
  CUBE_DISPATCH(objectContacts);
}
TEST_P(SceneCollide, ManagerVsManagerEqualsNaive) {
  CUBE_DISPATCH(managerVsManager);
}

INSTANTIATE_TEST_SUITE_P(Scenes, SceneCollide, ::testing::ValuesIn(collideCases()), caseName);

template <typename S>
void selfDistance(const Case& c) {
  World<S> w(c);
  const S expected =
      fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.naive.distance(d, f); });
  ASSERT_GT(expected, 0) << "the scene should have nothing touching";
  EXPECT_TRUE(closeDistance<S>(
      cubeMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.cube.distance(d, f); }),
      expected));
  EXPECT_TRUE(closeDistance<S>(
      fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.cube.distance(d, f); }),
      expected));
  EXPECT_TRUE(closeDistance<S>(fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                 w.cube.distance(&w.cube, d, f);
                               }),
                               expected));
}

template <typename S>
void objectDistance(const Case& c) {
  World<S> w(c);
  for (std::size_t i = 0; i < w.queries.size(); ++i) {
    Obj<S>* q = w.queries[i];
    SCOPED_TRACE("query #" + std::to_string(i));
    const S expected =
        fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.naive.distance(q, d, f); });
    if (w.objs.size() > 1 || (w.objs.size() == 1 && q != w.objs[0])) {
      ASSERT_GT(expected, 0);
    }
    ASSERT_TRUE(closeDistance<S>(
        cubeMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.cube.distance(q, d, f); }),
        expected));
    ASSERT_TRUE(closeDistance<S>(
        fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { w.cube.distance(q, d, f); }),
        expected));
  }
}

template <typename S>
void managerDistance(const Case& c) {
  World<S> w(c);
  const auto other_objs = w.others.pointers();
  fcl::NaiveCollisionManager<S> naive_other;
  for (auto* o : other_objs) naive_other.registerObject(o);
  fcl::DynamicAABBTreeCollisionManager<S> tree_other;
  tree_other.registerObjects(other_objs);
  tree_other.setup();
  CubeCollisionManager<S> cube_other;
  World<S>::registerInto(cube_other, other_objs, c.incremental);
  const S expected = fclMinDistance<S>(
      [&](void* d, fcl::DistanceCallBack<S> f) { w.naive.distance(&naive_other, d, f); });
  ASSERT_GT(expected, 0);
  for (Manager<S>* other : std::vector<Manager<S>*>{&naive_other, &tree_other, &cube_other}) {
    EXPECT_TRUE(closeDistance<S>(cubeMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                   w.cube.distance(other, d, f);
                                 }),
                                 expected));
    EXPECT_TRUE(closeDistance<S>(fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                   w.cube.distance(other, d, f);
                                 }),
                                 expected));
  }
  // The other direction.
  const S reverse = fclMinDistance<S>(
      [&](void* d, fcl::DistanceCallBack<S> f) { naive_other.distance(&w.naive, d, f); });
  EXPECT_TRUE(closeDistance<S>(fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                 cube_other.distance(&w.cube, d, f);
                               }),
                               reverse));
  EXPECT_TRUE(closeDistance<S>(fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                 cube_other.distance(&w.naive, d, f);
                               }),
                               reverse));
}

TEST_P(SceneDistance, SelfMinDistanceEqualsNaive) {
  CUBE_DISPATCH(selfDistance);
}
TEST_P(SceneDistance, ObjectMinDistanceEqualsNaive) {
  CUBE_DISPATCH(objectDistance);
}
TEST_P(SceneDistance, ManagerMinDistanceEqualsNaive) {
  CUBE_DISPATCH(managerDistance);
}

INSTANTIATE_TEST_SUITE_P(Scenes, SceneDistance, ::testing::ValuesIn(distanceCases()), caseName);

}  // namespace
}  // namespace testing
}  // namespace cube
