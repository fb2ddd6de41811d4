#pragma once

// Helpers shared by the correctness, semantics and dynamic tests: objects with hand-set AABBs,
// recorders for every query shape, and the same query run against fcl::NaiveCollisionManager so
// that the two can be compared. Nothing here knows the expected answer: it is always computed
// by brute force or by Naive on the same objects.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <type_traits>
#include <vector>

#include "cube_collision/callbacks.h"
#include "oracle.h"

namespace cube {
namespace testing {

template <typename S>
using Obj = fcl::CollisionObject<S>;
template <typename S>
using Pair = oracle::Pair<S>;
template <typename S>
using Manager = fcl::BroadPhaseCollisionManager<S>;

/// A collision object whose AABB a test can set directly (padded, NaN, touching exactly), as
/// tesseract does; FCL keeps the AABB protected.
template <typename S>
class TestObject : public fcl::CollisionObject<S> {
 public:
  /// A box of the given half sizes at `centre`, identity rotation, AABB computed by FCL.
  TestObject(const fcl::Vector3<S>& centre, const fcl::Vector3<S>& half)
      : fcl::CollisionObject<S>(
            std::make_shared<fcl::Box<S>>(2 * half[0], 2 * half[1], 2 * half[2])) {
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.translation() = centre;
    this->setTransform(tf);
    this->computeAABB();
  }
  /// Overwrites the cached AABB (FCL would recompute it in computeAABB()).
  void setAABB(const fcl::Vector3<S>& lo, const fcl::Vector3<S>& hi) {
    this->aabb = fcl::AABB<S>(lo, hi);
  }
  void setNaN() {
    const S nan = std::numeric_limits<S>::quiet_NaN();
    this->aabb.min_[1] = nan;
  }
};

/// Boxes given by min and max corners (exact AABBs, set directly).
template <typename S>
std::vector<std::unique_ptr<TestObject<S>>> boxes(
    const std::vector<std::pair<fcl::Vector3<S>, fcl::Vector3<S>>>& corners) {
  std::vector<std::unique_ptr<TestObject<S>>> out;
  for (const auto& c : corners) {
    auto o = std::make_unique<TestObject<S>>((c.first + c.second) / 2, (c.second - c.first) / 2);
    o->setAABB(c.first, c.second);
    out.push_back(std::move(o));
  }
  return out;
}

template <typename S>
std::vector<Obj<S>*> raw(const std::vector<std::unique_ptr<TestObject<S>>>& v) {
  std::vector<Obj<S>*> out;
  for (const auto& o : v) out.push_back(o.get());
  return out;
}

template <typename S>
std::vector<Pair<S>> sorted(std::vector<Pair<S>> v) {
  std::sort(v.begin(), v.end());
  return v;
}

/// Every collide callback in call order, arguments as given.
template <typename S>
using Calls = oracle::Calls<S>;

/// Every distance callback in call order; never lowers dist, so every candidate is visited.
template <typename S>
struct DistCalls {
  std::vector<Pair<S>> calls;
  static bool record(Obj<S>* a, Obj<S>* b, void* d, S&) {
    static_cast<DistCalls*>(d)->calls.emplace_back(a, b);
    return false;
  }
};

/// Sorted ordered pairs (a, b) of `as` x `bs` with overlapping AABBs and a != b.
using oracle::bruteCrossPairs;

/// Sorted ordered calls (first, second) of a self query.
template <typename S>
std::vector<Pair<S>> cubeObjectCalls(const Manager<S>& m, Obj<S>* q) {
  Calls<S> c;
  m.collide(q, &c, &Calls<S>::record);
  return sorted(c.calls);
}

template <typename S>
std::vector<Pair<S>> managerCalls(const Manager<S>& m, Manager<S>* other) {
  Calls<S> c;
  m.collide(other, &c, &Calls<S>::record);
  return sorted(c.calls);
}

/// Narrow phase with FCL's default request; exhaustive (never stops). Skips (a, a), so that Naive,
/// which pairs a query object with every managed object, can serve as the oracle for registered
/// query objects.
template <typename S>
struct Colliding {
  std::vector<Pair<S>> hits;  // unordered
  static bool record(Obj<S>* a, Obj<S>* b, void* d) {
    if (a == b) return false;
    fcl::CollisionRequest<S> req;
    fcl::CollisionResult<S> res;
    if (fcl::collide(a, b, req, res) > 0)
      static_cast<Colliding*>(d)->hits.push_back(oracle::unordered(a, b));
    return false;
  }
  std::vector<Pair<S>> result() const { return sorted(hits); }
};

/// The three contact budgets the tests use: binary (FCL's default: stop at the first contact),
/// 10 contacts, and exhaustive (a budget no scene reaches, so nothing depends on visit order).
inline const std::vector<std::size_t>& contactBudgets() {
  static const std::vector<std::size_t> budgets{1, 10, 1000000};
  return budgets;
}

/// What a collide query with a default callback ends with.
struct ContactOutcome {
  bool collision = false;
  std::size_t contacts = 0;
  bool operator==(const ContactOutcome& o) const {
    return collision == o.collision && contacts == o.contacts;
  }
};
inline std::ostream& operator<<(std::ostream& os, const ContactOutcome& c) {
  return os << "{collision " << c.collision << ", contacts " << c.contacts << "}";
}

/// fcl::DefaultCollisionFunction, skipping (a, a) (see Colliding).
template <typename S>
bool fclCollisionSkippingSelf(Obj<S>* a, Obj<S>* b, void* d) {
  if (a == b) return false;
  return fcl::DefaultCollisionFunction<S>(a, b, d);
}

/// Runs `query(data, callback)` with FCL's and with our default collision callback at a budget.
template <typename S, class Query>
ContactOutcome fclContacts(std::size_t budget, Query&& query) {
  fcl::DefaultCollisionData<S> d;
  d.request.num_max_contacts = budget;
  query(static_cast<void*>(&d), &fclCollisionSkippingSelf<S>);
  return {d.result.isCollision(), d.result.numContacts()};
}
template <typename S, class Query>
ContactOutcome cubeContacts(std::size_t budget, Query&& query) {
  CollisionData<S> d;
  d.request.num_max_contacts = budget;
  query(static_cast<void*>(&d), &defaultCollisionCallback<S>);
  return {d.result.isCollision(), d.result.numContacts()};
}

/// fcl::DefaultDistanceFunction, skipping (a, a).
template <typename S>
bool fclDistanceSkippingSelf(Obj<S>* a, Obj<S>* b, void* d, S& dist) {
  if (a == b) return false;
  return fcl::DefaultDistanceFunction<S>(a, b, d, dist);
}

template <typename S, class Query>
S fclMinDistance(Query&& query) {
  fcl::DefaultDistanceData<S> d;
  query(static_cast<void*>(&d), &fclDistanceSkippingSelf<S>);
  return d.result.min_distance;
}
template <typename S, class Query>
S cubeMinDistance(Query&& query) {
  DistanceData<S> d;
  query(static_cast<void*>(&d), &defaultDistanceCallback<S>);
  return d.result.min_distance;
}

/// Relative tolerance of the distance comparisons: 1e-6 as the issue asks for double. In float,
/// FCL's own distance depends on the argument order (callback(managed, obj) here, (obj, managed)
/// in Naive): measured up to 7.7e-6 relative over 120,000 scene pairs, so float gets 5e-5.
template <typename S>
constexpr double distanceTolerance() {
  return std::is_same_v<S, double> ? 1e-6 : 5e-5;
}

/// True if a and b agree within the relative tolerance (both infinite/max counts as equal).
template <typename S>
::testing::AssertionResult closeDistance(S a, S b) {
  if (a == b) return ::testing::AssertionSuccess();
  const double da = a, db = b;
  const double scale = std::max({std::abs(da), std::abs(db), 1e-12});
  if (std::abs(da - db) <= distanceTolerance<S>() * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "distances " << da << " and " << db << " differ by "
                                       << std::abs(da - db) / scale << " relative";
}

/// Depth of a cube (root 0), through the parent links.
template <class Tree>
int depthOf(const Tree& t, std::uint32_t cube) {
  int d = 0;
  for (std::uint32_t c = cube; t.parent(c) != 0xffffffffu; c = t.parent(c)) ++d;
  return d;
}

/// The live cubes reachable from the root, with their depths (iterative walk).
template <class Tree>
std::vector<std::pair<std::uint32_t, int>> liveCubes(const Tree& t) {
  std::vector<std::pair<std::uint32_t, int>> out, stack;
  if (t.root() != 0xffffffffu) stack.emplace_back(t.root(), 0);
  while (!stack.empty()) {
    const auto top = stack.back();
    stack.pop_back();
    out.push_back(top);
    const auto& n = t.nodes()[top.first];
    if (!n.isLeaf()) {
      stack.emplace_back(n.first, top.second + 1);
      stack.emplace_back(n.first + 1, top.second + 1);
    }
  }
  return out;
}

/// Fails the current test with validate()'s reason.
template <class M>
::testing::AssertionResult valid(const M& m) {
  std::string why;
  if (m.validate(&why)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "validate(): " << why;
}

}  // namespace testing
}  // namespace cube
