#pragma once

// What the tests of a manager mutated from inside a callback of one of its own queries share
// (test_reentrancy.cpp, test_reentrancy_table.cpp): the scenes (a queried manager, another cube
// manager and a Naive one, spare objects, a query object), every query kind run with a hook on
// each callback, and checks that a manager still answers as brute force and takes mutations.
// The aliases at the top also serve test_far_scales.cpp.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/config.h"
#include "cube_collision/continuous.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "oracle.h"

namespace reentrancy {

using S = double;

template <typename T>
using ReObj = fcl::CollisionObject<T>;
template <typename T>
using ReManager = cube::CubeCollisionManager<T>;
template <typename T>
using ReBase = fcl::BroadPhaseCollisionManager<T>;
template <typename T>
using RePair = cube::oracle::Pair<T>;

// Thrown by a test callback right after a mutation that should have thrown but went through:
// the query may then be walking freed or reshaped memory, so it must not take another step.
struct ReAbort {};

// A user's own exception type, with a payload to check that it arrives unchanged.
struct ReUserError {
  int code;
  std::string text;
};

template <typename T>
std::vector<RePair<T>> reSorted(std::vector<RePair<T>> v) {
  std::sort(v.begin(), v.end());
  return v;
}

template <typename T>
std::vector<ReObj<T>*> reObjectsOf(const ReBase<T>& m) {
  std::vector<ReObj<T>*> out;
  m.getObjects(out);
  return out;
}

// Brute-force candidates between two sets (a != b), as sorted unordered pairs: the shared
// oracle's ordered pairs, made unordered.
template <typename T>
std::vector<RePair<T>> reBruteCross(const std::vector<ReObj<T>*>& as,
                                    const std::vector<ReObj<T>*>& bs) {
  return cube::oracle::unorderedSorted(cube::oracle::bruteCrossPairs(as, bs));
}

enum class ReExtra { none, plane, halfspace };

struct ReSceneSpec {
  const char* name;
  int n;            // boxes registered in the queried manager
  bool keep_pairs;  // true: an update() before the queries, so that self-collide reads the list
  ReExtra extra;    // an unbounded object registered last (kept in the separate list)
  bool single;      // float instead of double
};

inline void PrintTo(const ReSceneSpec& spec, std::ostream* os) {
  *os << spec.name;
}

// The queried manager `m` (boxes, maybe an unbounded object), another cube manager `other` and a
// Naive manager over other's objects, spare objects for registrations, and a query object.
template <typename T>
struct ReScene {
  using Obj = ReObj<T>;
  std::vector<std::unique_ptr<Obj>> owned;     // first member: outlives the managers below
  std::vector<Obj*> mine, theirs;              // registered in m / in other, in that order
  std::vector<Obj*> spare_mine, spare_theirs;  // registered nowhere, overlapping the scene
  Obj* query = nullptr;                        // registered nowhere, overlapping several of mine
  std::unique_ptr<ReManager<T>> m, other;
  fcl::NaiveCollisionManager<T> naive_other;  // the objects of `other`

  Obj* box(T sx, T sy, T sz, T x, T y, T z) {
    owned.push_back(std::make_unique<Obj>(std::make_shared<fcl::Box<T>>(sx, sy, sz)));
    owned.back()->setTranslation(fcl::Vector3<T>(x, y, z));
    owned.back()->computeAABB();
    return owned.back().get();
  }

  explicit ReScene(const ReSceneSpec& spec) {
    std::mt19937 rng(2100u + unsigned(spec.n));
    std::uniform_real_distribution<double> size(0.5, 2.0), pos(0.0, 12.0);
    auto randomBox = [&] {
      const double sx = size(rng), sy = size(rng), sz = size(rng);
      const double x = pos(rng), y = pos(rng), z = pos(rng);
      return box(T(sx), T(sy), T(sz), T(x), T(y), T(z));
    };
    const bool small = spec.n <= 64;
    // Small: a row of unit boxes 0.3 apart (each overlaps three neighbours on each side).
    // Large: random boxes in a 12^3 region (a few overlaps per box).
    for (int i = 0; i < spec.n; ++i)
      mine.push_back(small ? box(1, 1, 1, T(0.3 * i), 0, 0) : randomBox());
    const int n_other = std::max(5, spec.n / 2);
    for (int i = 0; i < n_other; ++i)
      theirs.push_back(small ? box(1, 1, 1, T(0.3 * i + 0.15), T(0.2), 0) : randomBox());
    for (int i = 0; i < 2; ++i) {
      spare_mine.push_back(small ? box(1, 1, 1, T(0.5 + i), 0, 0) : box(3, 3, 3, 6, 6, T(6 + i)));
      spare_theirs.push_back(small ? box(1, 1, 1, T(0.5 + i), T(0.2), 0)
                                   : box(3, 3, 3, 6, T(6 + i), 6));
    }
    query = small ? box(1, 1, 1, T(1.35), 0, 0) : box(3, 3, 3, 6, 6, 6);
    if (spec.extra != ReExtra::none) {
      std::shared_ptr<fcl::CollisionGeometry<T>> g;
      if (spec.extra == ReExtra::plane)
        g = std::make_shared<fcl::Plane<T>>(fcl::Vector3<T>(0, 0, 1), T(0.25));
      else
        g = std::make_shared<fcl::Halfspace<T>>(fcl::Vector3<T>(0, 0, 1), T(1));
      owned.push_back(std::make_unique<Obj>(g));
      owned.back()->computeAABB();
      mine.push_back(owned.back().get());
    }
    cube::Config config;
    config.keep_pairs = spec.keep_pairs;
    m = std::make_unique<ReManager<T>>(config);
    m->registerObjects(mine);
    if (spec.keep_pairs)
      m->update();  // lists the pairs: the self-collides below are served from the list
    else
      m->setup();
    other = std::make_unique<ReManager<T>>();
    other->registerObjects(theirs);
    other->setup();
    naive_other.registerObjects(theirs);
    naive_other.setup();
    brute_mine = cube::oracle::bruteSelfPairs(mine);
    brute_theirs = cube::oracle::bruteSelfPairs(theirs);
  }

  // bruteSelfPairs of mine and theirs: sorted, so they hold whatever the registration order.
  std::vector<RePair<T>> brute_mine, brute_theirs;
};

enum class ReQuery {
  collideObj,
  collideSelf,
  collideOther,
  collideThis,
  collideNaive,
  distanceObj,
  distanceSelf,
  distanceOther,
  distanceThis,
  distanceNaive,
  fnCollideSelf,
  fnCollideObj,
  fnCollideOther,
  fnDistanceSelf,
  fnDistanceObj,
  fnDistanceOther,
};
constexpr int kReQueries = 16;

inline const char* reQueryName(ReQuery q) {
  switch (q) {
    case ReQuery::collideObj:
      return "collide(obj, cdata, cb)";
    case ReQuery::collideSelf:
      return "collide(cdata, cb)";
    case ReQuery::collideOther:
      return "collide(&other_cube, cdata, cb)";
    case ReQuery::collideThis:
      return "collide((Base*)this, cdata, cb)";
    case ReQuery::collideNaive:
      return "collide(&naive, cdata, cb)";
    case ReQuery::distanceObj:
      return "distance(obj, cdata, cb)";
    case ReQuery::distanceSelf:
      return "distance(cdata, cb)";
    case ReQuery::distanceOther:
      return "distance(&other_cube, cdata, cb)";
    case ReQuery::distanceThis:
      return "distance((Base*)this, cdata, cb)";
    case ReQuery::distanceNaive:
      return "distance(&naive, cdata, cb)";
    case ReQuery::fnCollideSelf:
      return "collide(lambda)";
    case ReQuery::fnCollideObj:
      return "collide(obj, lambda)";
    case ReQuery::fnCollideOther:
      return "collide(&other_cube, lambda)";
    case ReQuery::fnDistanceSelf:
      return "distance(lambda)";
    case ReQuery::fnDistanceObj:
      return "distance(obj, lambda)";
    case ReQuery::fnDistanceOther:
      return "distance(&other_cube, lambda)";
  }
  return "?";
}

// The queries that walk the other cube manager's tree as well.
inline bool reWalksOther(ReQuery q) {
  return q == ReQuery::collideOther || q == ReQuery::distanceOther ||
         q == ReQuery::fnCollideOther || q == ReQuery::fnDistanceOther;
}

// Records every callback (as unordered pairs, in call order) and runs `on_call` with the call's
// number (1, 2, ...) after recording it. Distance callbacks lower dist to the pair's AABB
// distance, so the searches prune as with a real narrow phase.
template <typename T>
struct ReHook {
  using Obj = ReObj<T>;
  std::vector<RePair<T>> calls;
  std::function<void(int)> on_call;

  void seen(Obj* a, Obj* b) {
    calls.push_back(cube::oracle::unordered(a, b));
    if (on_call) on_call(int(calls.size()));
  }
  bool distanceStep(Obj* a, Obj* b, T& dist) {
    seen(a, b);
    const T v = a->getAABB().distance(b->getAABB());
    if (v < dist) dist = v;
    return false;
  }
  static bool collideFn(Obj* a, Obj* b, void* d) {
    static_cast<ReHook*>(d)->seen(a, b);
    return false;
  }
  static bool distanceFn(Obj* a, Obj* b, void* d, T& dist) {
    return static_cast<ReHook*>(d)->distanceStep(a, b, dist);
  }
};

// Runs query `q` of manager `m` (of scene `sc`) with hook `h`.
template <typename T>
void reRunOn(const ReManager<T>& m, ReScene<T>& sc, ReQuery q, ReHook<T>& h) {
  using Obj = ReObj<T>;
  using Base = ReBase<T>;
  Base* other = sc.other.get();
  Base* self_as_base = const_cast<ReManager<T>*>(&m);
  auto c = [&h](Obj* a, Obj* b) { h.seen(a, b); };  // returns void: never stops
  auto d = [&h](Obj* a, Obj* b, T& dist) { return h.distanceStep(a, b, dist); };
  switch (q) {
    case ReQuery::collideObj:
      m.collide(sc.query, &h, &ReHook<T>::collideFn);
      break;
    case ReQuery::collideSelf:
      m.collide(&h, &ReHook<T>::collideFn);
      break;
    case ReQuery::collideOther:
      m.collide(other, &h, &ReHook<T>::collideFn);
      break;
    case ReQuery::collideThis:
      m.collide(self_as_base, &h, &ReHook<T>::collideFn);
      break;
    case ReQuery::collideNaive:
      m.collide(&sc.naive_other, &h, &ReHook<T>::collideFn);
      break;
    case ReQuery::distanceObj:
      m.distance(sc.query, &h, &ReHook<T>::distanceFn);
      break;
    case ReQuery::distanceSelf:
      m.distance(&h, &ReHook<T>::distanceFn);
      break;
    case ReQuery::distanceOther:
      m.distance(other, &h, &ReHook<T>::distanceFn);
      break;
    case ReQuery::distanceThis:
      m.distance(self_as_base, &h, &ReHook<T>::distanceFn);
      break;
    case ReQuery::distanceNaive:
      m.distance(&sc.naive_other, &h, &ReHook<T>::distanceFn);
      break;
    case ReQuery::fnCollideSelf:
      m.collide(c);
      break;
    case ReQuery::fnCollideObj:
      m.collide(sc.query, c);
      break;
    case ReQuery::fnCollideOther:
      m.collide(other, c);
      break;
    case ReQuery::fnDistanceSelf:
      m.distance(d);
      break;
    case ReQuery::fnDistanceObj:
      m.distance(sc.query, d);
      break;
    case ReQuery::fnDistanceOther:
      m.distance(other, d);
      break;
  }
}

template <typename T>
void reRun(ReScene<T>& sc, ReQuery q, ReHook<T>& h) {
  reRunOn(*sc.m, sc, q, h);
}

// "" if `m` holds exactly `objs` (same order), validates, and its self-collide reports the
// pairs of brute force (`brute`: bruteSelfPairs(objs) when the caller has it already) and, with
// `narrow`, the colliding pairs of fcl::NaiveCollisionManager; else what differs.
template <typename T>
std::string reAnswersLike(const ReManager<T>& m, const std::vector<ReObj<T>*>& objs,
                          const char* who, bool narrow = true,
                          const std::vector<RePair<T>>* brute = nullptr) {
  const std::string w = std::string(who) + ": ";
  if (reObjectsOf(m) != objs)
    return w + "getObjects() changed (" + std::to_string(m.size()) + " objects, expected " +
           std::to_string(objs.size()) + ")";
  std::string why;
  if (!m.validate(&why)) return w + "validate() failed: " + why;
  const auto got = cube::oracle::selfPairs(m);
  const auto want = brute ? *brute : cube::oracle::bruteSelfPairs(objs);
  if (got != want)
    return w + "self-collide pairs differ from brute force (" + std::to_string(got.size()) +
           " vs " + std::to_string(want.size()) + ")";
  if (!narrow) return "";
  auto naive = cube::oracle::naiveOf(objs);
  if (cube::oracle::collidingPairs(m) != cube::oracle::collidingPairs(naive))
    return w + "colliding pairs differ from fcl::NaiveCollisionManager's";
  return "";
}

// "" if mutations outside any query work on `m` (which holds `objs`): unregistering and
// registering again one object (objs[0], which `objs` then holds last, as getObjects() does), then
// update(). (Pairs against brute force; the narrow phase is checked once, after the query.)
template <typename T>
std::string reMutatesNormally(ReManager<T>& m, std::vector<ReObj<T>*>& objs, const char* who,
                              const std::vector<RePair<T>>* brute = nullptr) {
  const std::string w = std::string(who) + ": ";
  ReObj<T>* x = objs[0];
  const std::vector<RePair<T>> all = brute ? *brute : cube::oracle::bruteSelfPairs(objs);
  std::vector<RePair<T>> without_x;
  for (const auto& p : all)
    if (p.first != x && p.second != x) without_x.push_back(p);
  try {
    m.unregisterObject(x);
    objs.erase(objs.begin());
    std::string why = reAnswersLike(m, objs, who, false, &without_x);
    if (!why.empty()) return "after unregisterObject outside any query, " + why;
    m.registerObject(x);
    objs.push_back(x);
    why = reAnswersLike(m, objs, who, false, &all);
    if (!why.empty()) return "after registerObject outside any query, " + why;
    m.update();
    why = reAnswersLike(m, objs, who, false, &all);
    if (!why.empty()) return "after update() outside any query, " + why;
  } catch (const std::exception& e) {
    return w + "a mutation outside any query threw: " + e.what();
  }
  return "";
}

inline const ReSceneSpec kReScenes[] = {
    {"Small10KeepPairs", 10, true, ReExtra::none, false},
    {"Small10NoPairList", 10, false, ReExtra::none, false},
    {"Large300KeepPairs", 300, true, ReExtra::none, false},
    {"Large300NoPairList", 300, false, ReExtra::none, false},
    {"Small10PlaneKeepPairs", 10, true, ReExtra::plane, false},
    {"Large300HalfspaceNoPairList", 300, false, ReExtra::halfspace, false},
    {"FloatSmall10KeepPairs", 10, true, ReExtra::none, true},
    {"FloatLarge300PlaneNoPairList", 300, false, ReExtra::plane, true},
};

}  // namespace reentrancy
