#pragma once

// What the ray, region and capsule query tests share: a world of every shape kind, the segments
// the queries are asked along, and the box the manager holds for an object.

#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/spatial_queries.h"
#include "scenes.h"

namespace spatial {

template <typename S>
using Obj = fcl::CollisionObject<S>;
template <typename S>
using V3 = fcl::Vector3<S>;

// A world of mixed objects: the scene generator's boxes, spheres and cylinders (half of them as
// meshes), plus cones, ellipsoids, capsules, convexes, and one plane and one halfspace.
template <typename S>
struct World {
  std::vector<std::unique_ptr<Obj<S>>> own;
  std::vector<Obj<S>*> objs;

  World(std::size_t n, std::uint32_t seed, bool flat = true) {
    for (int mesh = 0; mesh < 2; ++mesh) {
      cube::scenes::SceneOptions o;
      o.n = n / 2;
      o.seed = seed + mesh;
      o.meshes = mesh == 1;
      o.half_extent = 50;
      o.overlaps_per_object = 2.0;
      auto sc = cube::scenes::makeScene<S>(o);
      for (auto& p : sc.objects) own.push_back(std::move(p));
    }
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-45, 45), size(0.5, 4);
    std::normal_distribution<double> g(0, 1);
    auto verts = std::make_shared<std::vector<V3<S>>>(
        std::vector<V3<S>>{{-1, -1, -1}, {1, -1, -1}, {0, 1, -1}, {0, 0, 1}});
    auto faces = std::make_shared<std::vector<int>>(
        std::vector<int>{3, 0, 1, 2, 3, 0, 3, 1, 3, 1, 3, 2, 3, 2, 3, 0});
    for (std::size_t i = 0; i < n / 10; ++i) {
      std::shared_ptr<fcl::CollisionGeometry<S>> geo;
      const S a = S(size(rng));
      switch (i % 4) {
        case 0:
          geo = std::make_shared<fcl::Cone<S>>(a, 2 * a);
          break;
        case 1:
          geo = std::make_shared<fcl::Ellipsoid<S>>(a, a / 2, a * S(0.7));
          break;
        case 2:
          geo = std::make_shared<fcl::Capsule<S>>(a / 2, a);
          break;
        default:
          geo = std::make_shared<fcl::Convex<S>>(verts, 4, faces, true);
          break;
      }
      Eigen::Quaternion<double> q(g(rng), g(rng), g(rng), g(rng));
      q.normalize();
      fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
      tf.linear() = q.toRotationMatrix().cast<S>();
      tf.translation() = V3<S>(S(u(rng)), S(u(rng)), S(u(rng)));
      own.push_back(std::make_unique<Obj<S>>(geo, tf));
    }
    if (flat) {
      own.push_back(std::make_unique<Obj<S>>(std::make_shared<fcl::Plane<S>>(V3<S>(1, 0, 0), 30)));
      own.push_back(std::make_unique<Obj<S>>(
          std::make_shared<fcl::Halfspace<S>>(V3<S>(0.3, -1, 0.2).normalized(), 40)));
    }
    // Shuffled, so that registration order is not kind order.
    std::shuffle(own.begin(), own.end(), rng);
    for (auto& p : own) {
      p->computeAABB();
      objs.push_back(p.get());
    }
  }
};

// The segments of the tests: random, axis-parallel, zero-length, from inside an object, lying
// on a box face, ending exactly on a box face.
template <typename S>
std::vector<std::pair<V3<S>, V3<S>>> segments(const std::vector<Obj<S>*>& objs, int n,
                                              std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60);
  std::uniform_int_distribution<std::size_t> pick(0, objs.size() - 1);
  std::vector<std::pair<V3<S>, V3<S>>> out;
  const auto point = [&] { return V3<S>(S(u(rng)), S(u(rng)), S(u(rng))); };
  for (int i = 0; i < n; ++i) {
    const V3<S> a = point();
    V3<S> b = point();
    const fcl::AABB<S>& box = objs[pick(rng)]->getAABB();
    switch (i % 7) {
      case 0:
      case 1:
        out.emplace_back(a, b);
        break;
      case 2: {  // axis-parallel
        b = a;
        b[i % 3] = S(u(rng));
        out.emplace_back(a, b);
        break;
      }
      case 3:  // zero length
        out.emplace_back(a, a);
        break;
      case 4:  // from inside an object's box (usually the object)
        if (std::isfinite(box.center()[0] + box.center()[1] + box.center()[2]))
          out.emplace_back(box.center(), b);
        break;
      case 5: {  // on the box's max-x face, moving in y and z only
        V3<S> f = box.center(), t = b;
        f[0] = t[0] = box.max_[0];
        if (std::isfinite(f.sum() + t.sum())) out.emplace_back(f, t);
        break;
      }
      default: {  // along x, ending exactly on the box's min-x face
        V3<S> f = box.center(), t = box.center();
        f[0] = box.min_[0] - S(10);
        t[0] = box.min_[0];
        if (std::isfinite(f.sum() + t.sum())) out.emplace_back(f, t);
        break;
      }
    }
  }
  return out;
}

// The box the manager holds for o: its AABB grown by its margin (0 unless margins are set).
template <typename S>
fcl::AABB<S> heldBox(const cube::CubeCollisionManager<S>& m, const Obj<S>* o) {
  const S g = m.margin(o);
  fcl::AABB<S> b = o->getAABB();
  for (int k = 0; k < 3; ++k) {
    b.min_[k] = b.min_[k] - g;
    b.max_[k] = b.max_[k] + g;
  }
  return b;
}

// Whether a query's filter (none: every object) lets o through, by the rule written apart from
// the library's: each one's category meets the other's mask.
template <typename S>
bool lets(const cube::CubeCollisionManager<S>& m, const Obj<S>* o,
          const std::optional<cube::QueryFilter>& f) {
  if (!f) return true;
  const auto [category, mask] = m.filter(o);
  return (category & f->mask) != 0 && (f->category & mask) != 0;
}

// Filter bits for the objects of a world, a few layouts: `kinds` distinct values cycling over the
// objects (some pairs of them cannot pair, so the cubes keep them apart when kinds is small), or,
// for kinds 0, random bits of six categories (hundreds of values: more than the filter groups).
template <typename S>
void setBits(cube::CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs, int kinds,
             std::uint32_t seed) {
  static const std::pair<std::uint64_t, std::uint64_t> kLayouts[] = {
      {1, ~std::uint64_t(0)}, {2, 2 | 4}, {4, 1 | 4}, {8, 0}, {16, 16}, {32, ~std::uint64_t(0)}};
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cat(0, 5), mask(0, 63);
  for (std::size_t i = 0; i < objs.size(); ++i) {
    if (kinds > 0) {
      const auto& [c, k] = kLayouts[(i * 7 + seed) % std::size_t(kinds)];
      m.setFilter(objs[i], c, k);
    } else {
      m.setFilter(objs[i], std::uint64_t(1) << cat(rng), std::uint64_t(mask(rng)));
    }
  }
}

// The query filters of the tests: the default bits, one category, several, all, none.
inline std::vector<cube::QueryFilter> queryFilters() {
  return {{1, ~std::uint64_t(0)},
          {2, ~std::uint64_t(0)},
          {4, 8},
          {6, 1 | 2},
          {~std::uint64_t(0), ~std::uint64_t(0)},
          {1, 0},
          {32, 32 | 16}};
}

}  // namespace spatial
