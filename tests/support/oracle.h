#pragma once

// Comparison helpers for the tests: what a manager reports, in a form that can be compared with
// what fcl::NaiveCollisionManager reports on the same objects. The narrow phase is FCL's as the
// library applies it (detail::fclCollide: the pairs FCL 0.7 answers wrongly or crashes on are
// answered from the geometry, checked against brute force in test_unbounded.cpp and
// test_culling_plane_pairs.cpp).

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "pipeline/fcl_narrow.h"

namespace cube {
namespace oracle {

/// An unordered pair of objects, smaller pointer first.
template <typename S>
using Pair = std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>;

template <typename S>
Pair<S> unordered(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
  return a < b ? Pair<S>(a, b) : Pair<S>(b, a);
}

/// `pairs` as a sorted list of unordered pairs (duplicates kept).
template <typename S>
std::vector<Pair<S>> unorderedSorted(const std::vector<Pair<S>>& pairs) {
  std::vector<Pair<S>> out;
  for (const auto& p : pairs) out.push_back(unordered(p.first, p.second));
  std::sort(out.begin(), out.end());
  return out;
}

/// Every callback of a collide query, in call order, as given (first, second argument).
template <typename S>
struct Calls {
  std::vector<Pair<S>> calls;
  static bool record(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    static_cast<Calls*>(d)->calls.emplace_back(a, b);
    return false;
  }
  /// The calls as a sorted multiset of unordered pairs (duplicates kept, so they show).
  std::vector<Pair<S>> unorderedSorted() const { return oracle::unorderedSorted(calls); }
};

/// Pairs whose AABBs overlap among `objs` (brute force), as a sorted list of unordered pairs.
template <typename S>
std::vector<Pair<S>> bruteSelfPairs(const std::vector<fcl::CollisionObject<S>*>& objs) {
  std::vector<Pair<S>> out;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      if (objs[i] != objs[j] && objs[i]->getAABB().overlap(objs[j]->getAABB()))
        out.push_back(unordered(objs[i], objs[j]));
  std::sort(out.begin(), out.end());
  return out;
}

/// Pairs (a, b) of `as` x `bs` whose AABBs overlap, a != b (brute force), sorted; ordered: a from
/// `as`, b from `bs` (unorderedSorted() of them for unordered pairs).
template <typename S>
std::vector<Pair<S>> bruteCrossPairs(const std::vector<fcl::CollisionObject<S>*>& as,
                                     const std::vector<fcl::CollisionObject<S>*>& bs) {
  std::vector<Pair<S>> out;
  for (auto* a : as)
    for (auto* b : bs)
      if (a != b && a->getAABB().overlap(b->getAABB())) out.emplace_back(a, b);
  std::sort(out.begin(), out.end());
  return out;
}

/// Self-collide candidate pairs reported by a manager (sorted unordered pairs, duplicates kept).
template <typename S>
std::vector<Pair<S>> selfPairs(const fcl::BroadPhaseCollisionManager<S>& m) {
  Calls<S> c;
  m.collide(&c, &Calls<S>::record);
  return c.unorderedSorted();
}

/// Pairs whose narrow phase says "colliding" for a self-collide with an exhaustive callback.
template <typename S>
std::vector<Pair<S>> collidingPairs(const fcl::BroadPhaseCollisionManager<S>& m) {
  struct Data {
    std::vector<Pair<S>> hits;
  } data;
  auto fn = [](fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    fcl::CollisionRequest<S> req;
    fcl::CollisionResult<S> res;
    if (detail::fclCollide(a, b, req, res) > 0)
      static_cast<Data*>(d)->hits.push_back(unordered(a, b));
    return false;
  };
  m.collide(&data, fn);
  std::sort(data.hits.begin(), data.hits.end());
  return data.hits;
}

/// Collide callback: the narrow phase on the pair in a canonical argument order (so that two
/// managers run the very same call per pair); colliding pairs go to the std::vector<Pair<S>>* d.
template <typename S>
bool narrowCollide(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
  const Pair<S> p = unordered(a, b);
  fcl::CollisionRequest<S> req;
  fcl::CollisionResult<S> res;
  if (detail::fclCollide(p.first, p.second, req, res) > 0)
    static_cast<std::vector<Pair<S>>*>(d)->push_back(p);
  return false;
}

/// Distance callback: narrow-phase distance clamped at 0 (Naive stops visiting at 0, so deeper
/// values are not comparable), the minimum kept in the S* d. FCL 0.7's GJK distance has no
/// support function for planes and halfspaces (it crashes), and octrees are not under test: the
/// AABB distance stands in for them, the same on both sides.
template <typename S>
bool narrowDistance(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d, S& dist) {
  auto boxOnly = [](const fcl::CollisionObject<S>* o) {
    const fcl::NODE_TYPE t = o->getNodeType();
    return t == fcl::GEOM_PLANE || t == fcl::GEOM_HALFSPACE || t == fcl::GEOM_OCTREE;
  };
  const Pair<S> p = unordered(a, b);
  S v;
  if (boxOnly(a) || boxOnly(b)) {
    v = a->getAABB().distance(b->getAABB());
  } else {
    fcl::DistanceRequest<S> req;
    fcl::DistanceResult<S> res;
    v = std::max<S>(0, fcl::distance(p.first, p.second, req, res));
  }
  S& best = *static_cast<S*>(d);
  best = std::min(best, v);
  dist = std::min(dist, v);
  return false;
}

/// Naive manager over the same objects (excluding `skip`, e.g. a registered query object).
template <typename S>
fcl::NaiveCollisionManager<S> naiveOf(const std::vector<fcl::CollisionObject<S>*>& objs) {
  fcl::NaiveCollisionManager<S> naive;
  for (auto* o : objs) naive.registerObject(o);
  return naive;
}

}  // namespace oracle
}  // namespace cube
