// The default callbacks, which cull and bound, give the contacts and distances of FCL's narrow
// phase on every pair; Config::cull_pairs keeps a user narrow phase's contacts; pairs beyond the
// records' range are left to FCL.

#include <gtest/gtest.h>

#include "support/culling_kinds.h"

namespace {

using namespace cullingkinds;

// The default callbacks cull: collideAll on a cube manager gives exactly the contacts of
// fcl::collide over every pair (all contacts requested), on scenes of every kind, but for the
// pairs FCL 0.7 answers wrongly (a cylinder or cone against a plane or halfspace), whose truth
// comes from the geometry.
TYPED_TEST(Culling, CollideAllEqualsBruteForceNarrowPhase) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  for (int i = 0; i < 160; ++i) {
    const auto& kind = kinds[std::size_t(i) % kinds.size()];
    if (kind.first == "convex") continue;  // see fclCanCollide: the scene has planes
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        kind.second, randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng))));
    objs.back()->computeAABB();
  }
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 30;
  all.enable_contact = true;
  std::size_t expected = 0, colliding_pairs = 0;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      fcl::CollisionResult<S> r;
      // A cylinder or cone against a plane or halfspace: one contact where the geometry says
      // they meet (FCL 0.7 answers some of these pairs wrongly; queries.h).
      const auto round = [](fcl::NODE_TYPE t) {
        return t == fcl::GEOM_CYLINDER || t == fcl::GEOM_CONE;
      };
      const fcl::NODE_TYPE ti = objs[i]->getNodeType(), tj = objs[j]->getNodeType();
      const std::size_t c =
          (round(ti) && cube::brute::planar(tj)) || (round(tj) && cube::brute::planar(ti))
              ? std::size_t(cube::brute::touch(*objs[i], *objs[j]))
              : fcl::collide(objs[i].get(), objs[j].get(), all, r);
      expected += c;
      colliding_pairs += c > 0;
    }
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  const fcl::CollisionResult<S> got = cube::collideAll<S>(m, all);
  EXPECT_EQ(got.numContacts(), expected);
  EXPECT_GT(colliding_pairs, 100u);
}

// The default distance callback skips pairs the bound rules out: minimumDistance on a cube
// manager, self and against an object, equals the minimum of fcl::distance over every pair.
TYPED_TEST(Culling, MinimumDistanceEqualsBruteForceNarrowPhase) {
  using S = TypeParam;
  auto kinds = allKinds<S>();
  kinds.erase(
      std::remove_if(kinds.begin(), kinds.end(),
                     [](const auto& k) { return k.first == "plane" || k.first == "halfspace"; }),
      kinds.end());  // see fclCanMeasure
  std::mt19937 rng(9);
  int apart_scenes = 0;  // scenes where no two objects touch, so that the search ran its course
  for (int scene = 0; scene < 6; ++scene) {
    std::uniform_real_distribution<double> u(-9.0, 9.0);
    std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
    for (int i = 0; i < 50; ++i) {
      objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
          kinds[std::size_t(i + scene) % kinds.size()].second, randomRotation<S>(rng),
          fcl::Vector3<S>(u(rng), u(rng), u(rng))));
      objs.back()->computeAABB();
    }
    fcl::DistanceRequest<S> req;
    S self_min = std::numeric_limits<S>::max(), query_min = std::numeric_limits<S>::max();
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        fcl::DistanceResult<S> r;
        const S d = fcl::distance(objs[i].get(), objs[j].get(), req, r);
        if (j + 1 == objs.size())
          query_min = std::min(query_min, d);  // the last object is the query
        else
          self_min = std::min(self_min, d);
      }
    cube::CubeCollisionManager<S> m;
    std::vector<fcl::CollisionObject<S>*> ptrs;
    for (std::size_t i = 0; i + 1 < objs.size(); ++i) ptrs.push_back(objs[i].get());
    m.registerObjects(ptrs);
    // FCL's distance for one pair can differ in the last digits with what the result already
    // holds (a mesh's traversal is pruned by it): equal within FCL's own tolerance.
    const S tol = S(req.distance_tolerance) * (S(1) + std::abs(self_min));
    EXPECT_NEAR(cube::minimumDistance<S>(m, req).min_distance, self_min, tol) << "scene " << scene;
    EXPECT_NEAR(cube::minimumDistance<S>(m, objs.back().get(), req).min_distance, query_min, tol)
        << "scene " << scene;
    apart_scenes += self_min > 0;
  }
  EXPECT_GE(apart_scenes, 3);
}

// A user's callback that runs the narrow phase, counting its calls.
template <typename S>
struct UserNarrow {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  std::size_t calls = 0;
  UserNarrow() {
    request.num_max_contacts = 1 << 30;
    request.enable_contact = true;
  }
  static bool fn(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    auto& u = *static_cast<UserNarrow*>(d);
    ++u.calls;
    fcl::collide(a, b, u.request, u.result);
    return false;
  }
};

template <typename S>
void cullPairsKnob(std::size_t mine_n, std::size_t n) {
  SCOPED_TRACE(std::to_string(n) + " objects");
  auto kinds = allKinds<S>();
  kinds.erase(std::remove_if(kinds.begin(), kinds.end(),
                             [](const auto& k) {
                               return k.first == "convex" || k.first == "plane" ||
                                      k.first == "halfspace";
                             }),
              kinds.end());  // never culled, they would only dilute the count
  std::mt19937 rng(21);
  // The density of 200 objects in a cube of side 6.
  const double half = 3.0 * std::cbrt(double(n) / 200.0);
  std::uniform_real_distribution<double> u(-half, half);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  for (std::size_t i = 0; i < n; ++i) {
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        kinds[i % kinds.size()].second, randomRotation<S>(rng),
        fcl::Vector3<S>(u(rng), u(rng), u(rng))));
    objs.back()->computeAABB();
  }
  std::vector<fcl::CollisionObject<S>*> mine, theirs;
  for (std::size_t i = 0; i < objs.size(); ++i)
    (i < mine_n ? mine : theirs).push_back(objs[i].get());
  fcl::CollisionObject<S>* query = theirs.back();
  theirs.pop_back();
  cube::Config on;
  on.cull_pairs = true;
  cube::CubeCollisionManager<S> off_m, on_m(on), other;
  fcl::NaiveCollisionManager<S> naive;
  off_m.registerObjects(mine);
  on_m.registerObjects(mine);
  naive.registerObjects(mine);
  naive.setup();
  other.registerObjects(theirs);

  UserNarrow<S> a, b, c;
  off_m.collide(&a, &UserNarrow<S>::fn);
  on_m.collide(&b, &UserNarrow<S>::fn);
  naive.collide(&c, &UserNarrow<S>::fn);
  EXPECT_EQ(b.result.numContacts(), a.result.numContacts());
  EXPECT_EQ(b.result.numContacts(), c.result.numContacts());
  EXPECT_EQ(a.calls, cube::overlappingPairs<S>(off_m).size());
  EXPECT_LT(b.calls * 10, a.calls * 8) << b.calls << " of " << a.calls;  // a fifth or more culled
  EXPECT_GT(a.result.numContacts(), 50u);

  UserNarrow<S> qa, qb;
  off_m.collide(query, &qa, &UserNarrow<S>::fn);
  on_m.collide(query, &qb, &UserNarrow<S>::fn);
  EXPECT_EQ(qb.result.numContacts(), qa.result.numContacts());
  EXPECT_LE(qb.calls, qa.calls);

  UserNarrow<S> ma, mb;
  off_m.collide(&other, &ma, &UserNarrow<S>::fn);
  on_m.collide(&other, &mb, &UserNarrow<S>::fn);
  EXPECT_EQ(mb.result.numContacts(), ma.result.numContacts());
  EXPECT_LT(mb.calls, ma.calls);
}

// Config::cull_pairs: self, object and manager-against-manager collides give a user callback
// that runs fcl::collide the same contacts as without the knob and as fcl::NaiveCollisionManager,
// in fewer calls; without it the callback sees every pair whose boxes overlap. Managers of 170
// and 30 objects (volumes built from the objects) and of 350 and 350 (read from the tables,
// kVolumeMinObjects).
TYPED_TEST(Culling, CullPairsKnobKeepsANarrowPhaseCallbacksContacts) {
  for (const std::size_t mine_n : {std::size_t(170), std::size_t(350)})
    cullPairsKnob<TypeParam>(mine_n, mine_n == 170 ? 200 : 700);
}

// The records' float arithmetic squares differences of coordinates: an object whose centre or
// size is beyond kVolumeMaxScale gets no volumes and its pairs go to FCL. A ball of radius 1e20
// and a unit ball centred on its surface touch; collideAll on a manager that keeps records (300
// more unit balls, apart from everything) finds every contact brute force with fcl::collide finds.
TEST(CullingRange, PairsBeyondTheRecordsRangeAreLeftToFcl) {
  using S = double;
  const S far = 1e20;
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  const auto ball = [&](S r, const fcl::Vector3<S>& at) {
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(std::make_shared<fcl::Sphere<S>>(r),
                                                             fcl::Matrix3<S>::Identity(), at));
    objs.back()->computeAABB();
    return objs.back().get();
  };
  fcl::CollisionObject<S>* big = ball(far, fcl::Vector3<S>::Zero());
  fcl::CollisionObject<S>* small = ball(1, fcl::Vector3<S>(far, 0, 0));
  for (int i = 0; i < 300; ++i) ball(1, fcl::Vector3<S>(S(3 * i), 3 * far, 0));
  ASSERT_TRUE(collides(*big, *small));
  cube::detail::VolumeSphere sphere;
  cube::detail::VolumeShape shape;
  cube::detail::buildVolume(*small, sphere, shape);
  EXPECT_LT(sphere.r, 0.f) << "no volumes beyond the records range";
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 20;
  std::size_t expected = 0;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      fcl::CollisionResult<S> r;
      expected += fcl::collide(objs[i].get(), objs[j].get(), all, r);
    }
  ASSERT_GT(expected, 0u);
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  m.setup();
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(), expected);
}

}  // namespace
