#pragma once

// What a differential sequence compares the manager with: callbacks that record what a query
// reports, the brute-force answers over the model's cached AABBs, and the failure texts.

#include <algorithm>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "differential_pool.h"

namespace cube {
namespace diff {

// ---- recorders ------------------------------------------------------------------------------

/// A collide callback recording every pair as called, never stopping.
struct Rec {
  std::vector<Pair> calls;
  static bool collide(Object* a, Object* b, void* d) {
    static_cast<Rec*>(d)->calls.emplace_back(a, b);
    return false;
  }
};

/// A distance callback lowering dist to the pair's AABB distance (the first object's box from
/// `first`, the second's from `second`, or its live AABB if `second` is null) and recording the
/// minimum; `bad` when an object is in neither.
struct MinRec {
  const Boxes* first;
  const Boxes* second;
  S min = std::numeric_limits<S>::max();
  std::size_t calls = 0;
  bool bad = false;
  static bool distance(Object* a, Object* b, void* p, S& dist) {
    auto* r = static_cast<MinRec*>(p);
    ++r->calls;
    const auto ia = r->first->find(a);
    if (ia == r->first->end()) return r->bad = true;
    AABB bb = b->getAABB();
    if (r->second) {
      const auto ib = r->second->find(b);
      if (ib == r->second->end()) return r->bad = true;
      bb = ib->second;
    }
    const S d = ia->second.distance(bb);
    r->min = std::min(r->min, d);
    dist = std::min(dist, d);
    return false;
  }
};

inline std::vector<Pair> sorted(std::vector<Pair> v) {
  std::sort(v.begin(), v.end());
  return v;
}

// ---- brute-force expectations ---------------------------------------------------------------

/// Self-collide: every unordered pair of registered objects whose cached boxes overlap, sorted.
inline std::vector<Pair> selfPairs(const Model& m) {
  const auto& order = m.order();
  std::vector<Pair> out;
  for (std::size_t i = 0; i < order.size(); ++i)
    for (std::size_t j = i + 1; j < order.size(); ++j)
      if (overlap(m.box(order[i]), m.box(order[j]))) out.push_back(unordered(order[i], order[j]));
  std::sort(out.begin(), out.end());
  return out;
}

/// Self distance: the minimum cached-box distance over all pairs (max() for fewer than two).
inline S selfMinDistance(const Model& m) {
  const auto& order = m.order();
  S expected = std::numeric_limits<S>::max();
  for (std::size_t i = 0; i < order.size(); ++i)
    for (std::size_t j = i + 1; j < order.size(); ++j)
      expected = std::min(expected, m.box(order[i]).distance(m.box(order[j])));
  return expected;
}

/// Self distance without pruning: every pair Naive would visit (box distance below max()).
inline std::vector<Pair> selfDistancePairs(const Model& m) {
  const auto& order = m.order();
  std::vector<Pair> want;
  for (std::size_t i = 0; i < order.size(); ++i)
    for (std::size_t j = i + 1; j < order.size(); ++j)
      if (m.box(order[i]).distance(m.box(order[j])) < std::numeric_limits<S>::max())
        want.push_back(unordered(order[i], order[j]));
  return want;
}

/// collide(obj): (registered object, obj) for every other object overlapping obj's live AABB.
inline std::vector<Pair> objectPairs(const Model& m, Object* o) {
  std::vector<Pair> want;
  for (auto* x : m.order())
    if (x != o && overlap(m.box(x), o->getAABB())) want.emplace_back(x, o);
  return want;
}

/// distance(obj): the minimum distance of obj's live AABB to every other object's cached box.
inline S objectMinDistance(const Model& m, const Object* o) {
  S expected = std::numeric_limits<S>::max();
  for (auto* x : m.order())
    if (x != o) expected = std::min(expected, m.box(x).distance(o->getAABB()));
  return expected;
}

/// collide(other manager): (ours, theirs) pairs of distinct objects whose boxes overlap, or
/// (theirs, ours) when `reversed`; sorted.
inline std::vector<Pair> crossPairs(const Model& m, const std::vector<Object*>& theirs,
                                    const Boxes& their_boxes, bool reversed) {
  std::vector<Pair> out;
  for (auto* a : m.order())
    for (auto* b : theirs)
      if (a != b && overlap(m.box(a), their_boxes.at(b)))
        out.push_back(reversed ? Pair(b, a) : Pair(a, b));
  std::sort(out.begin(), out.end());
  return out;
}

/// distance(other manager): the minimum box distance over pairs of distinct objects.
inline S crossMinDistance(const Model& m, const std::vector<Object*>& theirs,
                          const Boxes& their_boxes) {
  S expected = std::numeric_limits<S>::max();
  for (auto* a : m.order())
    for (auto* b : theirs)
      if (a != b) expected = std::min(expected, m.box(a).distance(their_boxes.at(b)));
  return expected;
}

// ---- failure texts --------------------------------------------------------------------------

inline std::string boxText(const Pool& pool, const Model& m, const Object* o) {
  std::ostringstream s;
  s.precision(17);
  const auto it = m.boxes().find(o);
  const AABB& b = it != m.boxes().end() ? it->second : o->getAABB();
  s << pool.name(o) << (it != m.boxes().end() ? "" : "(live)") << "[" << b.min_.transpose() << " | "
    << b.max_.transpose() << "]";
  return s.str();
}

/// What one sorted pair list has that the other lacks.
inline std::string diffPairs(const Pool& pool, const Model& m, const std::vector<Pair>& got,
                             const std::vector<Pair>& want) {
  std::vector<Pair> extra, missing;
  std::set_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(extra));
  std::set_difference(want.begin(), want.end(), got.begin(), got.end(),
                      std::back_inserter(missing));
  std::string out;
  for (const auto& p : extra)
    out += "\n  extra " + boxText(pool, m, p.first) + " " + boxText(pool, m, p.second);
  for (const auto& p : missing)
    out += "\n  missing " + boxText(pool, m, p.first) + " " + boxText(pool, m, p.second);
  return out;
}

/// The manager's cubes and lists.
inline std::string dump(const Pool& pool, const CubeCollisionManager<S>& mgr) {
  std::ostringstream s;
  s.precision(9);
  const auto& h = ::cube::detail::coreOf(mgr).tree();
  s << "\n--- hierarchy: root " << h.root() << " ---";
  for (std::size_t i = 0; i < h.nodes().size(); ++i) {
    const auto& n = h.nodes()[i];
    s << "\n  cube " << i << " [" << n.lo[0] << " " << n.lo[1] << " " << n.lo[2] << " | " << n.hi[0]
      << " " << n.hi[1] << " " << n.hi[2] << "] first " << n.first << " count " << n.count;
  }
  for (std::size_t i = 0; i < h.items().size(); ++i)
    s << "\n  item " << i << " " << (h.items()[i].obj ? pool.name(h.items()[i].obj) : "dead")
      << " leaf " << h.items()[i].leaf;
  for (const auto& it : ::cube::detail::coreOf(mgr).unboundedItems())
    s << "\n  unbounded " << pool.name(it.obj);
  return s.str();
}

}  // namespace diff
}  // namespace cube
