// The pairs FCL 0.7's narrow phase crashes on, answered by the library: any kind against a plane
// or a halfspace measured in closed form, planes against each other, a convex against a plane
// from its vertices; against brute force (support/plane_brute.h).

#include <gtest/gtest.h>

#include "support/culling_kinds.h"

namespace {

using namespace cullingkinds;

// FCL 0.7's fcl::distance crashes on a plane or a halfspace (a null support function in
// libccd): the library answers such a pair with its exact distance in closed form (queries.h).
// Every kind, an octree too, against planes and halfspaces at random tilts (in the geometry and
// in the object's pose) about 1000 units from the origin, through minimumDistance (self, object
// query, with a cache), the default distance callback and contactsWithinMargin, against the
// brute force of support/plane_brute.h: -1 for a pair that meets, else the gap, with the nearest
// points on the plane and at the object's extreme, as far apart as the distance.
TYPED_TEST(Culling, DistanceToPlanesAndHalfspacesIsExactForEveryKind) {
  using S = TypeParam;
  auto kinds = allKinds<S>();
  kinds.erase(
      std::remove_if(kinds.begin(), kinds.end(),
                     [](const auto& k) { return k.first == "plane" || k.first == "halfspace"; }),
      kinds.end());
  auto tree = std::make_shared<octomap::OcTree>(0.25);
  for (const auto& p : {octomap::point3d(0.1f, 0.2f, 0.3f), octomap::point3d(-0.6f, 0.1f, 0.0f),
                        octomap::point3d(0.3f, -0.5f, 0.6f), octomap::point3d(0.0f, 0.4f, -0.7f)})
    tree->updateNode(p, true);
  kinds.emplace_back("octree", std::make_shared<fcl::OcTree<S>>(tree));
  const double tol = std::is_same<S, float>::value ? 2e-3 : 1e-8;
  const S margin = S(0.75);
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0), height(-2.0, 4.0);
  const auto unit = [&] { return fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))).normalized(); };
  std::size_t apart = 0, meeting = 0, within = 0;
  for (int rep = 0; rep < 30; ++rep)
    for (const bool solid : {false, true})
      for (const auto& [name, geo] : kinds) {
        const fcl::Vector3<S> local_n = unit();
        const S local_d = S(5 * u(rng));
        Geometry<S> pg;
        if (solid)
          pg = std::make_shared<fcl::Halfspace<S>>(local_n, local_d);
        else
          pg = std::make_shared<fcl::Plane<S>>(local_n, local_d);
        fcl::CollisionObject<S> pl(
            pg, randomRotation<S>(rng),
            fcl::Vector3<S>(S(600 + 9 * u(rng)), S(-700 + 9 * u(rng)), S(500 + 9 * u(rng))));
        Eigen::Vector3d n;
        double d;
        cube::brute::boundary(pl, n, d);
        // The object about `height` from the plane (either side of a plane), near its foot.
        const Eigen::Vector3d foot = n * d + Eigen::Vector3d(u(rng), u(rng), u(rng)).cross(n);
        const double side = !solid && u(rng) < 0 ? -1 : 1;
        fcl::CollisionObject<S> obj(geo, randomRotation<S>(rng),
                                    (foot + side * height(rng) * n).template cast<S>());
        pl.computeAABB();
        obj.computeAABB();
        const double want = cube::brute::distance(pl, obj);
        const double gap = cube::brute::gap(pl, obj);
        if (std::abs(gap) < 10 * tol || std::abs(gap - double(margin)) < 10 * tol) continue;
        (want > 0 ? apart : meeting) += 1;
        const std::string what =
            name + (solid ? " / halfspace" : " / plane") + " rep " + std::to_string(rep);

        // The pair as a manager's self query, and the object as a query against the plane.
        fcl::DistanceRequest<S> req(true);
        for (const bool plane_first : {true, false}) {
          cube::CubeCollisionManager<S> m;
          m.registerObject(plane_first ? &pl : &obj);
          m.registerObject(plane_first ? &obj : &pl);
          m.setup();
          const fcl::DistanceResult<S> r = cube::minimumDistance<S>(m, req);
          ASSERT_NEAR(r.min_distance, want, tol) << what;
          if (want > 0) {
            // Which point is the plane's: the one on the geometry of the plane.
            const bool pl_is_o1 = r.o1 == pg.get();
            const Eigen::Vector3d on_plane =
                r.nearest_points[pl_is_o1 ? 0 : 1].template cast<double>();
            const Eigen::Vector3d on_obj =
                r.nearest_points[pl_is_o1 ? 1 : 0].template cast<double>();
            EXPECT_NEAR(n.dot(on_plane) - d, 0, tol) << what;
            EXPECT_NEAR(std::abs(n.dot(on_obj) - d), want, tol) << what;
            EXPECT_NEAR((on_obj - on_plane).norm(), want, tol) << what;
          }
          cube::NarrowPhaseCache<S> cache;
          cube::NarrowPhaseOptions<S> cached;
          cached.cache = &cache;
          EXPECT_NEAR(cube::minimumDistance<S>(m, req, cached).min_distance, want, tol) << what;
          cube::DistanceData<S> data;
          data.request = req;
          m.distance(&data, cube::defaultDistanceCallback<S>);
          EXPECT_NEAR(data.result.min_distance, want, tol) << what;

          // Within a margin: listed when the gap is at most the margin, with the distance.
          m.setMargin(&obj, margin);
          const auto near = cube::contactsWithinMargin<S>(m, req, 1);
          ASSERT_EQ(near.size(), gap <= double(margin) ? 1u : 0u) << what;
          if (!near.empty()) {
            EXPECT_EQ(near[0].colliding, want < 0) << what;
            if (want > 0) {
              EXPECT_NEAR(near[0].distance, want, tol) << what;
            }
            within += want > 0;
          }
        }
        cube::CubeCollisionManager<S> planes;
        planes.registerObject(&pl);
        planes.setup();
        EXPECT_NEAR(cube::minimumDistance<S>(planes, &obj, req).min_distance, want, tol) << what;
      }
  EXPECT_GT(apart, 100u);
  EXPECT_GT(meeting, 100u);
  EXPECT_GT(within, 20u);
}

// Two planes or halfspaces are apart only when parallel: facing halfspaces and parallel planes
// get their gap, any tilt between them meets (-1), through minimumDistance.
TYPED_TEST(Culling, DistanceBetweenPlanesIsTheGapWhenParallel) {
  using S = TypeParam;
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double tol = std::is_same<S, float>::value ? 2e-3 : 1e-8;
  for (int rep = 0; rep < 40; ++rep) {
    const fcl::Vector3<S> n = fcl::Vector3<S>(S(u(rng)), S(u(rng)), S(u(rng))).normalized();
    const S d1 = S(1000 + 3 * u(rng)), gap = S(2 + u(rng));
    const fcl::Matrix3<S> R = randomRotation<S>(rng);
    // Each in its own frame: R^T n in a frame rotated by R is n in the world.
    const fcl::Vector3<S> ln = R.transpose() * n;
    const auto posed = [&](Geometry<S> g) {
      auto o = std::make_unique<fcl::CollisionObject<S>>(g, R, fcl::Vector3<S>::Zero());
      o->computeAABB();
      return o;
    };
    struct Case {
      Geometry<S> a, b;
      double want;
    };
    const fcl::Vector3<S> tilted = (ln + fcl::Vector3<S>(S(0.3), S(-0.2), S(0.1))).normalized();
    const std::vector<Case> cases = {
        // Parallel planes: n . x = d1 and n . x = d1 + gap (one written with -n).
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Plane<S>>(-ln, -d1 - gap),
         double(gap)},
        // A plane above a halfspace n . x <= d1 - gap, and one inside it.
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Halfspace<S>>(ln, d1 - gap),
         double(gap)},
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Halfspace<S>>(ln, d1 + gap),
         -1},
        // Facing halfspaces n . x <= d1 and -n . x <= -(d1 + gap); same-facing ones meet.
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(-ln, -d1 - gap), double(gap)},
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(ln, d1 + gap), -1},
        // Tilted: they cross.
        {std::make_shared<fcl::Plane<S>>(ln, d1), std::make_shared<fcl::Plane<S>>(tilted, d1), -1},
        {std::make_shared<fcl::Halfspace<S>>(ln, d1),
         std::make_shared<fcl::Halfspace<S>>(-tilted, -d1 - gap), -1},
    };
    for (std::size_t c = 0; c < cases.size(); ++c)
      for (const bool swap : {false, true}) {
        auto a = posed(cases[c].a), b = posed(cases[c].b);
        cube::CubeCollisionManager<S> m;
        m.registerObject(swap ? b.get() : a.get());
        m.registerObject(swap ? a.get() : b.get());
        m.setup();
        const fcl::DistanceResult<S> r = cube::minimumDistance<S>(m, fcl::DistanceRequest<S>(true));
        ASSERT_NEAR(r.min_distance, cases[c].want, tol) << "case " << c << " rep " << rep;
        if (cases[c].want > 0) {
          EXPECT_NEAR((r.nearest_points[0] - r.nearest_points[1]).norm(), cases[c].want, tol);
        }
      }
  }
}

// FCL 0.7's fcl::collide crashes on a convex polytope against a plane: the library answers such
// a pair from the polytope's vertices (fcl_narrow.h). collideAll and the default callback, with
// convexes among planes (one tilted, through the scene), equal brute force: a convex meets a
// plane where its vertices lie on both sides (checked here from the vertices), fcl::collide for
// every other pair; the contact's normal is the plane's and its depth the lesser push.
TYPED_TEST(Culling, ConvexAgainstPlaneAnsweredFromTheVertices) {
  using S = TypeParam;
  const auto kinds = allKinds<S>();
  const auto& convex_geo = std::find_if(kinds.begin(), kinds.end(), [](const auto& k) {
                             return k.first == "convex";
                           })->second;
  const auto& tetra = static_cast<const fcl::Convex<S>&>(*convex_geo);
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objs;
  const fcl::Vector3<S> normals[2] = {fcl::Vector3<S>(0, 0, 1),
                                      fcl::Vector3<S>(1, 2, 2).normalized()};
  for (const auto& n : normals)
    objs.push_back(
        std::make_unique<fcl::CollisionObject<S>>(std::make_shared<fcl::Plane<S>>(n, S(0.3))));
  for (int i = 0; i < 60; ++i)  // each object its own geometry: contacts name the objects
    objs.push_back(std::make_unique<fcl::CollisionObject<S>>(
        std::make_shared<fcl::Convex<S>>(
            std::make_shared<std::vector<fcl::Vector3<S>>>(tetra.getVertices()), 4,
            std::make_shared<std::vector<int>>(tetra.getFaces()), true),
        randomRotation<S>(rng), fcl::Vector3<S>(u(rng), u(rng), u(rng))));
  for (auto& o : objs) o->computeAABB();
  // Brute force over every pair: plane-convex from the vertices, the rest (convex pairs, the two
  // planes) FCL's.
  fcl::CollisionRequest<S> req;
  req.num_max_contacts = 100000;
  req.enable_contact = true;
  using Key = std::pair<const void*, const void*>;
  std::set<Key> want;
  std::map<Key, S> depth;
  const auto key = [](const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b) {
    const void* x = a->collisionGeometry().get();
    const void* y = b->collisionGeometry().get();
    return x < y ? Key{x, y} : Key{y, x};
  };
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      if (i < 2 && j >= 2) {
        const auto& pl = static_cast<const fcl::Plane<S>&>(*objs[i]->collisionGeometry());
        S lo = std::numeric_limits<S>::max(), hi = -lo;
        for (const auto& v : tetra.getVertices()) {
          const S sd = pl.n.dot(objs[j]->getTransform() * v) - pl.d;
          lo = std::min(lo, sd);
          hi = std::max(hi, sd);
        }
        if (lo <= 0 && hi >= 0) {
          want.insert(key(objs[i].get(), objs[j].get()));
          depth[key(objs[i].get(), objs[j].get())] = std::min(-lo, hi);
        }
        continue;
      }
      fcl::CollisionResult<S> r;  // the query's request: FCL's two planes give no contact with it
      if (fcl::collide(objs[i].get(), objs[j].get(), req, r) > 0)
        want.insert(key(objs[i].get(), objs[j].get()));
    }
  cube::CubeCollisionManager<S> m;
  std::vector<fcl::CollisionObject<S>*> ptrs;
  for (auto& o : objs) ptrs.push_back(o.get());
  m.registerObjects(ptrs);
  const fcl::CollisionResult<S> all = cube::collideAll<S>(m, req);
  std::set<Key> got;
  for (std::size_t c = 0; c < all.numContacts(); ++c) {
    const auto& ct = all.getContact(c);
    const Key k = ct.o1 < ct.o2 ? Key{ct.o1, ct.o2} : Key{ct.o2, ct.o1};
    got.insert(k);
    const auto d = depth.find(k);
    if (d != depth.end()) {
      EXPECT_NEAR(ct.penetration_depth, d->second, 1e-4);
    }
  }
  EXPECT_EQ(got, want);
  int plane_pairs = 0;
  for (const auto& k : want) plane_pairs += depth.count(k) != 0;
  EXPECT_GT(plane_pairs, 5);
  cube::CollisionData<S> data;
  data.request = req;
  m.collide(&data, cube::defaultCollisionCallback<S>);
  std::set<Key> by_callback;
  for (std::size_t c = 0; c < data.result.numContacts(); ++c) {
    const auto& ct = data.result.getContact(c);
    by_callback.insert(ct.o1 < ct.o2 ? Key{ct.o1, ct.o2} : Key{ct.o2, ct.o1});
  }
  EXPECT_EQ(by_callback, want);
}

}  // namespace
