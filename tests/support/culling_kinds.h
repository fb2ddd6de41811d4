#pragma once

// What the tests of the culling in front of the narrow phase share (test_culling_*.cpp): one
// typed suite over its files, one geometry of every kind FCL's narrow phase takes, the pairs of
// kinds FCL 0.7 can answer, random rotations and poses, the records the pipeline keeps of a pair
// and the cull it runs on them.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/octree/octree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/margins.h"
#include "cube_collision/narrow_phase.h"
#include "cube_collision/queries.h"
#include "pipeline/cull.h"
#include "pipeline/pair_judge.h"
#include "plane_brute.h"

namespace cullingkinds {

template <typename S>
class Culling : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Culling, Scalars);

template <typename S>
using Geometry = std::shared_ptr<fcl::CollisionGeometry<S>>;

// One geometry of each kind FCL's narrow phase takes, sizes around 1, with the kind's name.
template <typename S>
std::vector<std::pair<std::string, Geometry<S>>> allKinds() {
  std::vector<std::pair<std::string, Geometry<S>>> out;
  out.emplace_back("box", std::make_shared<fcl::Box<S>>(1.0, 0.4, 0.7));
  out.emplace_back("sphere", std::make_shared<fcl::Sphere<S>>(0.45));
  out.emplace_back("ellipsoid", std::make_shared<fcl::Ellipsoid<S>>(0.6, 0.3, 0.4));
  out.emplace_back("capsule", std::make_shared<fcl::Capsule<S>>(0.25, 0.9));
  out.emplace_back("cone", std::make_shared<fcl::Cone<S>>(0.4, 0.9));
  out.emplace_back("cylinder", std::make_shared<fcl::Cylinder<S>>(0.3, 1.1));
  // A tetrahedron as a convex.
  auto verts = std::make_shared<std::vector<fcl::Vector3<S>>>(std::vector<fcl::Vector3<S>>{
      {0.5, 0, -0.2}, {-0.3, 0.4, -0.2}, {-0.3, -0.4, -0.2}, {0, 0, 0.6}});
  auto faces = std::make_shared<std::vector<int>>(
      std::vector<int>{3, 0, 1, 2, 3, 0, 3, 1, 3, 1, 3, 2, 3, 2, 3, 0});
  out.emplace_back("convex", std::make_shared<fcl::Convex<S>>(verts, 4, faces, true));
  auto mesh = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
  fcl::generateBVHModel(*mesh, fcl::Box<S>(0.8, 0.5, 0.3), fcl::Transform3<S>::Identity());
  out.emplace_back("mesh", mesh);
  auto ball = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
  fcl::generateBVHModel(*ball, fcl::Sphere<S>(0.4), fcl::Transform3<S>::Identity(), 8u, 8u);
  out.emplace_back("mesh sphere", ball);
  out.emplace_back("plane", std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0.2, 0.3, 1), 0.1));
  out.emplace_back("halfspace",
                   std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(0, 1, 0.3), -0.2));
  return out;
}

// FCL 0.7's narrow phase itself crashes on a convex against a plane or a halfspace (libccd's GJK
// is handed a support function that does not exist for them): those pairs are left out.
inline bool fclCanCollide(const std::string& a, const std::string& b) {
  const auto flat = [](const std::string& k) { return k == "plane" || k == "halfspace"; };
  return !((a == "convex" && flat(b)) || (b == "convex" && flat(a)));
}

// FCL 0.7's fcl::distance crashes the same way on any shape against a plane or a halfspace.
inline bool fclCanMeasure(const std::string& a, const std::string& b) {
  const auto flat = [](const std::string& k) { return k == "plane" || k == "halfspace"; };
  return !flat(a) && !flat(b);
}

template <typename S>
fcl::Matrix3<S> randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaternion<double> q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q.toRotationMatrix().cast<S>();
}

template <typename S>
bool collides(fcl::CollisionObject<S>& a, fcl::CollisionObject<S>& b) {
  fcl::CollisionRequest<S> req;
  fcl::CollisionResult<S> res;
  return fcl::collide(&a, &b, req, res) > 0;
}

template <typename S>
S defaultTolerance() {
  return S(fcl::CollisionRequest<S>().gjk_tolerance);
}

// The float records the object tables keep of two objects (buildVolume), as the cull and the
// pair judge read them.
struct PairRecords {
  cube::detail::VolumeSphere sa, sb;
  cube::detail::VolumeShape ha, hb;
  cube::detail::Records a() const { return {&sa, &ha}; }
  cube::detail::Records b() const { return {&sb, &hb}; }
};

template <typename S>
PairRecords recordsOf(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b) {
  PairRecords r;
  cube::detail::buildVolume(a, r.sa, r.ha);
  cube::detail::buildVolume(b, r.sb, r.hb);
  return r;
}

// A random pose of a pair, drawn from rng: a turned at random about the origin, b turned at
// random about a centre whose coordinates come from `centre`; both boxes computed. Returns the
// pair's records.
template <typename S>
PairRecords poseAtRandom(fcl::CollisionObject<S>& a, fcl::CollisionObject<S>& b, std::mt19937& rng,
                         std::uniform_real_distribution<double>& centre) {
  a.setTransform(randomRotation<S>(rng), fcl::Vector3<S>::Zero());
  b.setTransform(randomRotation<S>(rng), fcl::Vector3<S>(centre(rng), centre(rng), centre(rng)));
  a.computeAABB();
  b.computeAABB();
  return recordsOf(a, b);
}

// The cull the pipeline runs on the object tables' float records (buildVolume, verdictOf): it
// must keep every promise surelyApart and surelyTouching keep.
template <typename S>
cube::detail::Verdict volumeVerdict(const fcl::CollisionObject<S>& a,
                                    const fcl::CollisionObject<S>& b, bool prove) {
  const PairRecords r = recordsOf(a, b);
  return cube::detail::verdictOf(r.sa, r.ha, r.sb, r.hb,
                                 cube::detail::volumeMarginRate(defaultTolerance<S>()), prove);
}

}  // namespace cullingkinds
