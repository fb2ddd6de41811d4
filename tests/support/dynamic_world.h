#pragma once

// What the tests of dynamic updates share (test_dynamic_*.cpp): one typed suite over their files,
// scenes, random motion, the update variants, a registry of the registered objects, and the
// sequence of callbacks a user can observe.

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "correctness.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace cube {
namespace testing {
namespace dynamic_world {

template <typename S>
class Dynamic : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Dynamic, Scalars);

constexpr double kHalf = 2000;  // scenes' default half extent

template <typename S>
scenes::Scene<S> scene(std::size_t n, std::uint32_t seed, double size_scale = 1.0,
                       scenes::Layout layout = scenes::Layout::uniform) {
  scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.size_scale = size_scale;
  o.layout = layout;
  o.overlaps_per_object = 2.0;
  return scenes::makeScene<S>(o);
}

/// Distance between AABB centres: never below the AABB distance, so branch and bound may use
/// it, and its minimum does not depend on the visit order (unlike the default callback's, which
/// stops at the first touching pair).
template <typename S>
S centreDistance(Obj<S>* a, Obj<S>* b) {
  return (a->getAABB().center() - b->getAABB().center()).norm();
}

/// Moves one object by up to `step` per axis, optionally rotating it, and recomputes its AABB.
template <typename S>
void moveObject(Obj<S>* o, std::mt19937& rng, double step, bool rotate) {
  std::uniform_real_distribution<double> unit(-1, 1);
  fcl::Transform3<S> tf = o->getTransform();
  tf.translation() +=
      fcl::Vector3<S>(S(unit(rng) * step), S(unit(rng) * step), S(unit(rng) * step));
  if (rotate) {
    const fcl::Vector3<S> axis =
        fcl::Vector3<S>(S(unit(rng)), S(unit(rng)), S(unit(rng)) + S(2)).normalized();
    tf.linear() = fcl::AngleAxis<S>(S(unit(rng) * 3), axis).toRotationMatrix() * tf.linear();
  }
  o->setTransform(tf);
  o->computeAABB();
}

enum class Variant { all, single, vector };
inline const char* name(Variant v) {
  return v == Variant::all ? "update()" : v == Variant::single ? "update(obj)" : "update(vector)";
}

template <typename S>
void applyUpdate(CubeCollisionManager<S>& m, Variant v, const std::vector<Obj<S>*>& moved) {
  switch (v) {
    case Variant::all:
      m.update();
      break;
    case Variant::single:
      for (auto* o : moved) m.update(o);
      break;
    case Variant::vector:
      m.update(moved);
      break;
  }
}

/// The reference state of the sequence test: which pool objects are registered, in order.
template <typename S>
struct Registry {
  std::vector<Obj<S>*> live;  // registration order
  std::set<Obj<S>*> in;
  void add(Obj<S>* o) {
    if (in.insert(o).second) live.push_back(o);
  }
  void remove(Obj<S>* o) {
    if (in.erase(o)) live.erase(std::find(live.begin(), live.end(), o));
  }
};

/// Every callback of the queries whose order a user can observe: self-collide, object queries,
/// and distance (a recorder that visits everything, and a pruning one).
template <typename S>
struct Sequence {
  std::vector<Pair<S>> self, objects, dist_all, dist_pruned;
  bool operator==(const Sequence& o) const {
    return self == o.self && objects == o.objects && dist_all == o.dist_all &&
           dist_pruned == o.dist_pruned;
  }
};
template <typename S>
Sequence<S> record(const CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& queries) {
  Sequence<S> s;
  Calls<S> c;
  m.collide(&c, &Calls<S>::record);
  s.self = c.calls;
  for (auto* q : queries) {
    Calls<S> cq;
    m.collide(q, &cq, &Calls<S>::record);
    s.objects.insert(s.objects.end(), cq.calls.begin(), cq.calls.end());
  }
  DistCalls<S> d;
  m.distance(&d, &DistCalls<S>::record);
  s.dist_all = d.calls;
  S best = std::numeric_limits<S>::max();
  m.distance([&](Obj<S>* a, Obj<S>* b, S& dist) {
    s.dist_pruned.emplace_back(a, b);
    best = std::min(best, centreDistance(a, b));
    dist = best;
  });
  for (auto* q : queries) {
    best = std::numeric_limits<S>::max();
    m.distance(q, [&](Obj<S>* a, Obj<S>* b, S& dist) {
      s.dist_pruned.emplace_back(a, b);
      best = std::min(best, centreDistance(a, b));
      dist = best;
    });
  }
  return s;
}

}  // namespace dynamic_world
}  // namespace testing
}  // namespace cube
