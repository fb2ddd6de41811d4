// The per-object volumes the narrow-phase pipeline culls with follow every change update() sees,
// are built by the first pipeline query and dropped on request; the answers stay FCL's.

#include <gtest/gtest.h>

#include "support/narrow_phase_world.h"

namespace {

using namespace narrowphase;

// The per-object volumes the pipeline culls with (Config::tight_volumes) follow every change
// update() sees, and some FCL's boxes do not show: a rod turned about its centre keeps the box of
// its bounding sphere but meets another object; a geometry changed in place with the same
// bounding sphere (then named to update(), as the Config says); a recycled id whose new object
// has the last one's transform and local AABB. Each time collideAll answers as fcl::collide
// does, through update(), update(obj) and update(objects), with the volumes and without, in a
// manager large enough to rebuild a moved object's records at once and in a small one, which
// marks them stale and builds them again when update() finds the object standing.
TYPED_TEST(NarrowPhase, VolumesFollowWhatUpdateSees) {
  using S = TypeParam;
  const auto rz = [](double deg) {
    return fcl::AngleAxis<S>(S(deg * M_PI / 180), fcl::Vector3<S>::UnitZ()).toRotationMatrix();
  };
  const auto fclSays = [](fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
    fcl::CollisionRequest<S> req;
    fcl::CollisionResult<S> res;
    return fcl::collide(a, b, req, res) > 0;
  };
  for (const int filler_count : {300, 0})
    for (const bool volumes : {true, false})
      for (int how = 0; how < 3; ++how) {
        cube::Config config;
        config.tight_volumes = volumes;
        cube::CubeCollisionManager<S> m(config);
        const auto update = [&](fcl::CollisionObject<S>* o) {
          if (how == 0) m.update();
          if (how == 1) m.update(o);
          if (how == 2) m.update(std::vector<fcl::CollisionObject<S>*>{o});
        };
        // Every query starts from a valid manager: each mutation before it left one.
        const auto collides = [&] {
          std::string why;
          EXPECT_TRUE(m.validate(&why)) << why;
          fcl::CollisionRequest<S> req;
          return cube::collideAll<S>(m, req, cube::NarrowPhaseOptions<S>{1}).isCollision();
        };
        const std::string what = std::string(volumes ? "volumes" : "no volumes") + ", update #" +
                                 std::to_string(how) + ", " + std::to_string(filler_count) +
                                 " more objects";
        auto rod_shape = std::make_shared<fcl::Box<S>>(S(4), S(0.2), S(0.2));
        fcl::CollisionObject<S> rod(rod_shape, rz(30), fcl::Vector3<S>::Zero());
        fcl::CollisionObject<S> probe(std::make_shared<fcl::Box<S>>(S(0.2), S(0.2), S(0.2)),
                                      fcl::Matrix3<S>::Identity(),
                                      rz(60) * fcl::Vector3<S>(1.9, 0, 0));
        rod.computeAABB();
        probe.computeAABB();
        m.registerObjects({&rod, &probe});
        // Far away; 300 make the manager large enough to rebuild a moved object's records
        // (kVolumeRebuildMinObjects). The ids of the test's objects then index its records.
        std::vector<std::unique_ptr<fcl::CollisionObject<S>>> fillers;
        for (int i = 0; i < filler_count; ++i) {
          fillers.push_back(std::make_unique<fcl::CollisionObject<S>>(
              std::make_shared<fcl::Sphere<S>>(S(0.1)), fcl::Matrix3<S>::Identity(),
              fcl::Vector3<S>(S(100 + i), S(100), S(100))));
          fillers.back()->computeAABB();
          m.registerObject(fillers.back().get());
        }
        m.setup();
        ASSERT_FALSE(fclSays(&rod, &probe));
        EXPECT_FALSE(collides()) << what;
        // Turned about its centre: FCL's box of the rod stays the same.
        const fcl::AABB<S> box = rod.getAABB();
        rod.setTransform(rz(60), fcl::Vector3<S>::Zero());
        rod.computeAABB();
        ASSERT_TRUE(box.equal(rod.getAABB()));
        ASSERT_TRUE(fclSays(&rod, &probe));
        update(&rod);
        EXPECT_TRUE(collides()) << what << ": the rod turned";
        // Back, then the geometry changed in place: the rod now lies along its y axis, which
        // points at the probe; its bounding sphere, so FCL's box, is the same.
        rod.setTransform(rz(-30), fcl::Vector3<S>::Zero());
        rod.computeAABB();
        update(&rod);
        EXPECT_FALSE(collides()) << what;
        rod_shape->side = fcl::Vector3<S>(S(0.2), S(4), S(0.2));
        rod_shape->computeLocalAABB();
        rod.computeAABB();
        ASSERT_TRUE(box.equal(rod.getAABB()));
        ASSERT_TRUE(fclSays(&rod, &probe));
        // Named, as Config::tight_volumes asks of a geometry changed in place.
        if (how == 2)
          m.update(std::vector<fcl::CollisionObject<S>*>{&rod});
        else
          m.update(&rod);
        EXPECT_TRUE(collides()) << what << ": the geometry changed";
        // Nothing moved: the small manager builds the rod's stale records again, from the geometry
        // as it is now.
        m.update();
        EXPECT_TRUE(collides()) << what << ": the geometry changed, then a still update()";
        // A recycled id: a ball apart from the probe leaves, and a box with its transform and its
        // local AABB takes its id; the box's corner reaches the probe.
        m.unregisterObject(&rod);
        const fcl::Vector3<S> centre =
            probe.getTranslation() - fcl::Vector3<S>(0.8, 0.8, 0) / S(std::sqrt(2.0));
        fcl::CollisionObject<S> ball(std::make_shared<fcl::Sphere<S>>(S(0.6)),
                                     fcl::Matrix3<S>::Identity(), centre);
        fcl::CollisionObject<S> cube_(std::make_shared<fcl::Box<S>>(S(1.2), S(1.2), S(1.2)),
                                      fcl::Matrix3<S>::Identity(), centre);
        ball.computeAABB();
        cube_.computeAABB();
        ASSERT_FALSE(fclSays(&ball, &probe));
        ASSERT_TRUE(fclSays(&cube_, &probe));
        m.registerObject(&ball);
        EXPECT_FALSE(collides()) << what;
        m.unregisterObject(&ball);
        m.registerObject(&cube_);
        EXPECT_TRUE(collides()) << what << ": a recycled id";
      }
}

// A manager used through FCL's interface only keeps no per-object volumes: its memory and its
// answers are those of a manager without them. The first pipeline query builds them, updates keep
// them, dropVolumes() frees them, and the answers stay FCL's throughout.
TEST(NarrowPhaseVolumes, BuiltByThePipelinesFirstQueryAndDroppedOnRequest) {
  using S = double;
  auto world = scene<S>(Layout::uniform, false, 1000, 5);
  cube::Config plain_config;
  plain_config.tight_volumes = false;
  cube::CubeCollisionManager<S> plain(plain_config), m;
  plain.registerObjects(world.pointers());
  m.registerObjects(world.pointers());
  plain.setup();
  m.setup();
  std::string why;
  const auto valid = [&] { EXPECT_TRUE(m.validate(&why)) << why; };
  const std::size_t fcl_only = m.bytes();
  EXPECT_EQ(fcl_only, plain.bytes());
  // FCL's interface with the user's callbacks: self and object collides, distance, updates.
  std::size_t pairs = 0;
  m.collide(&pairs, [](fcl::CollisionObject<S>*, fcl::CollisionObject<S>*, void* d) {
    ++*static_cast<std::size_t*>(d);
    return false;
  });
  EXPECT_GT(pairs, 0u);
  for (auto* o : world.pointers()) {
    o->setTranslation(o->getTranslation() + fcl::Vector3<S>(0.01, 0, 0));
    o->computeAABB();
  }
  m.update();
  plain.update();
  valid();
  EXPECT_EQ(m.bytes(), plain.bytes());
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 20;
  const auto want = cube::collideAll<S>(plain, all);
  const auto got = cube::collideAll<S>(m, all);
  EXPECT_EQ(got.numContacts(), want.numContacts());
  EXPECT_GT(m.bytes(), plain.bytes());  // built by the pipeline's first query
  valid();
  // Kept fresh by the updates: objects moved onto one another still get FCL's answer.
  for (std::size_t i = 0; i + 1 < world.objects.size(); i += 7) {
    world.objects[i]->setTransform(world.objects[i + 1]->getTransform());
    world.objects[i]->computeAABB();
  }
  m.update();
  plain.update();
  valid();
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(),
            cube::collideAll<S>(plain, all).numContacts());
  const std::size_t kept = m.bytes();
  m.dropVolumes();
  valid();
  EXPECT_LT(m.bytes(), kept);
  EXPECT_EQ(m.bytes(), plain.bytes());
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(),
            cube::collideAll<S>(plain, all).numContacts());
  EXPECT_EQ(m.bytes(), kept);  // built again
  valid();
}

}  // namespace
