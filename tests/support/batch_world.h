#pragma once

// What the tests of the batched checks share (test_batch_*.cpp, test_shared_walk.cpp): worlds of
// random objects (meshes, planes), random bodies and states, and brute force: every link against
// every world object and every checked pair of links, with FCL's narrow phase.

#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/bvh/BVH_model.h>
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
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cube_collision/batch.h"
#include "cube_collision/margins.h"
#include "mesh_box.h"
#include "plane_brute.h"

namespace batchworld {

using S = double;
using Object = fcl::CollisionObjectd;
using Geometry = std::shared_ptr<fcl::CollisionGeometryd>;

using meshbox::meshBox;

inline Geometry randomShape(std::mt19937& rng, double size, bool meshes) {
  std::uniform_real_distribution<double> u(0.3, 1.0);
  switch (std::uniform_int_distribution<int>(0, meshes ? 4 : 3)(rng)) {
    case 0:
      return std::make_shared<fcl::Boxd>(size * u(rng), size * u(rng), size * u(rng));
    case 1:
      return std::make_shared<fcl::Sphered>(0.5 * size * u(rng));
    case 2:
      return std::make_shared<fcl::Cylinderd>(0.3 * size * u(rng), size * u(rng));
    case 3:
      return std::make_shared<fcl::Capsuled>(0.25 * size * u(rng), size * u(rng));
    default:
      return meshBox(size * u(rng), size * u(rng), size * u(rng));
  }
}

inline fcl::Transform3d randomPose(std::mt19937& rng, double half) {
  std::uniform_real_distribution<double> p(-half, half);
  std::normal_distribution<double> g;
  fcl::Transform3d tf = fcl::Transform3d::Identity();
  tf.linear() = fcl::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
  tf.translation() = fcl::Vector3d(p(rng), p(rng), p(rng));
  return tf;
}

struct World {
  std::vector<std::unique_ptr<Object>> objects;
  cube::CubeCollisionManagerd manager;
  std::vector<Object*> pointers() const {
    std::vector<Object*> out;
    for (const auto& o : objects) out.push_back(o.get());
    return out;
  }
};

// n shapes (and meshes) in a cube of half-size 10, plus, with `planes`, a floor halfspace and a
// tilted plane.
inline void fillWorld(World& w, std::size_t n, std::uint32_t seed, bool meshes, bool planes) {
  std::mt19937 rng(seed);
  for (std::size_t i = 0; i < n; ++i) {
    w.objects.push_back(
        std::make_unique<Object>(randomShape(rng, 1.2, meshes), randomPose(rng, 10)));
    w.objects.back()->computeAABB();
  }
  if (planes) {
    w.objects.push_back(
        std::make_unique<Object>(std::make_shared<fcl::Halfspaced>(fcl::Vector3d(0, 0, 1), -9.0),
                                 fcl::Transform3d::Identity()));
    w.objects.push_back(std::make_unique<Object>(
        std::make_shared<fcl::Planed>(fcl::Vector3d(1, 1, 0).normalized(), 8.0),
        fcl::Transform3d::Identity()));
    for (std::size_t i = n; i < w.objects.size(); ++i) w.objects[i]->computeAABB();
  }
  w.manager.registerObjects(w.pointers());
  w.manager.setup();
}

// A chain of `links` links with random shapes (meshes among them with `meshes`).
inline cube::BodySet<S> randomBody(std::size_t links, std::uint32_t seed, bool meshes,
                                   S margin = 0) {
  std::mt19937 rng(seed);
  cube::BodySet<S> body;
  for (std::size_t l = 0; l < links; ++l) body.addLink(randomShape(rng, 1.0, meshes), margin);
  for (std::size_t l = 0; l + 1 < links; ++l) body.allowPair(l, l + 1);
  return body;
}

// States: each link placed near a random centre (a robot folded in a ball of radius 3).
inline std::vector<fcl::Transform3d> randomStates(std::size_t states, std::size_t links,
                                                  std::uint32_t seed, double spread = 9) {
  std::mt19937 rng(seed);
  std::vector<fcl::Transform3d> poses;
  for (std::size_t k = 0; k < states; ++k) {
    const fcl::Transform3d centre = randomPose(rng, spread);
    for (std::size_t l = 0; l < links; ++l) {
      fcl::Transform3d tf = randomPose(rng, 3);
      tf.translation() += centre.translation();
      poses.push_back(tf);
    }
  }
  return poses;
}

inline S bruteDistance(const Object& a, const Object& b);

// Brute force for one pair (link first): touching within margin m.
inline bool bruteTouch(const Object& a, const Object& b, S m) {
  if (cube::brute::touch(a, b)) return true;
  return m > 0 && bruteDistance(a, b) <= m;
}

struct Brute {
  bool colliding = false;
  std::size_t link = cube::kNoIndex, other_link = cube::kNoIndex;
  Object* object = nullptr;
  S clearance = std::numeric_limits<S>::max();
};

// The oracle: every link against every world object (filter bits, predicate), every checked
// link pair, in batch.h's documented order for the first pair.
inline Brute brute(const World& w, const cube::BodySet<S>& body, const fcl::Transform3d* poses,
                   bool self, const std::function<bool(Object*, Object*)>& keep = nullptr,
                   const std::vector<std::pair<std::uint64_t, std::uint64_t>>& bits = {}) {
  std::vector<std::unique_ptr<Object>> links;
  for (std::size_t l = 0; l < body.size(); ++l) {
    links.push_back(std::make_unique<Object>(body.geometry(l), poses[l]));
  }
  const auto meets = [&](std::size_t l, Object* o) {
    if (!bits.empty()) {
      const auto [cat, mask] = w.manager.filter(o);
      if (!((cat & bits[l].second) && (bits[l].first & mask))) return false;
    }
    return !keep || keep(o, links[l].get());
  };
  Brute out;
  for (std::size_t l = 0; l < body.size() && !out.colliding; ++l) {
    for (const auto& o : w.objects) {  // registration order
      if (!meets(l, o.get())) continue;
      if (bruteTouch(*links[l], *o, body.margin(l) + w.manager.margin(o.get()))) {
        out = {true, l, cube::kNoIndex, o.get()};
        break;
      }
    }
    for (std::size_t j = l + 1; self && !out.colliding && j < body.size(); ++j)
      if (body.checked(l, j) && bruteTouch(*links[l], *links[j], body.margin(l) + body.margin(j)))
        out = {true, l, j, nullptr};
  }
  if (out.colliding) return out;
  for (std::size_t l = 0; l < body.size(); ++l) {
    for (const auto& o : w.objects)
      if (meets(l, o.get())) {
        out.clearance = std::min(out.clearance, bruteDistance(*links[l], *o));
      }
    for (std::size_t j = l + 1; self && j < body.size(); ++j)
      if (body.checked(l, j))
        out.clearance = std::min(out.clearance, bruteDistance(*links[l], *links[j]));
  }
  return out;
}

// fcl::distance, or for a plane or halfspace the gap of the brute force (plane_brute.h).
inline S bruteDistance(const Object& a, const Object& b) {
  if (cube::brute::planar(a.getNodeType()) || cube::brute::planar(b.getNodeType()))
    return cube::brute::distance(a, b);
  fcl::DistanceRequestd req;
  fcl::DistanceResultd res;
  return fcl::distance(&a, &b, req, res);
}

inline void expectSame(const std::vector<cube::StateResult<S>>& got, const World& w,
                       const cube::BodySet<S>& body, const std::vector<fcl::Transform3d>& poses,
                       const cube::BatchOptions& o, std::size_t* colliding = nullptr,
                       const std::function<bool(Object*, Object*)>& keep = nullptr,
                       const std::vector<std::pair<std::uint64_t, std::uint64_t>>& bits = {}) {
  ASSERT_EQ(got.size(), poses.size() / body.size());
  std::size_t hits = 0;
  for (std::size_t k = 0; k < got.size(); ++k) {
    const Brute b = brute(w, body, poses.data() + k * body.size(), o.self_collision, keep, bits);
    hits += b.colliding;
    ASSERT_EQ(got[k].colliding, b.colliding) << "state " << k;
    if (o.first_pair && b.colliding) {
      EXPECT_EQ(got[k].link, b.link) << "state " << k;
      EXPECT_EQ(got[k].object, b.object) << "state " << k;
      EXPECT_EQ(got[k].other_link, b.other_link) << "state " << k;
    } else {
      EXPECT_EQ(got[k].link, cube::kNoIndex);
      EXPECT_EQ(got[k].object, nullptr);
    }
    if (o.clearance) {
      // Bit for bit where FCL answers; a closed form's rounding for a plane or halfspace.
      const S want = b.colliding ? S(0) : b.clearance;
      EXPECT_NEAR(got[k].clearance, want, 1e-9 * (1 + std::abs(want))) << "state " << k;
    } else {
      EXPECT_EQ(got[k].clearance, std::numeric_limits<S>::max());
    }
  }
  if (colliding != nullptr) *colliding = hits;
}

// Two calls' answers alike: colliding, and the first pair where it was asked for.
template <typename T>
void expectSameAnswers(const std::vector<cube::StateResult<T>>& got,
                       const std::vector<cube::StateResult<T>>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_EQ(got[k].colliding, want[k].colliding) << "state " << k;
    EXPECT_EQ(got[k].link, want[k].link) << "state " << k;
    EXPECT_EQ(got[k].object, want[k].object) << "state " << k;
    EXPECT_EQ(got[k].other_link, want[k].other_link) << "state " << k;
  }
}

// The states of an edge of n states in the order MotionOrder names (batch.h), written here.
inline std::vector<std::size_t> visitOrder(std::size_t n, cube::MotionOrder order) {
  std::vector<std::size_t> visit;
  if (order == cube::MotionOrder::path || n < 2) {
    for (std::size_t i = 0; i < n; ++i) visit.push_back(i);
  } else {  // OMPL's: the last state, then midpoints breadth first
    visit.push_back(n - 1);
    std::vector<std::pair<std::size_t, std::size_t>> q{{0, n - 2}};
    for (std::size_t h = 0; h < q.size(); ++h) {
      const auto [lo, hi] = q[h];
      const std::size_t mid = (lo + hi) / 2;
      visit.push_back(mid);
      if (mid > lo) q.emplace_back(lo, mid - 1);
      if (mid < hi) q.emplace_back(mid + 1, hi);
    }
  }
  return visit;
}

}  // namespace batchworld
