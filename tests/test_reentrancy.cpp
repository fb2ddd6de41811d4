// (1) A manager mutated from inside a callback of one of its own queries, (2) validate()
// and its running total of cube areas over scenes spanning 1e-6 to 1e9, (3) distances beyond the
// range of float with a raised Config::unbounded_limit.
//
// Oracles: brute force over the objects' AABBs and fcl::NaiveCollisionManager (support/oracle.h),
// and, for "the query goes on", the same query run on the same manager without the mutation
// attempt.

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
#include "support/oracle.h"

namespace {

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

// ------------------------------------------------------------------------------------------------
// Part 1: mutations from inside a callback.
// ------------------------------------------------------------------------------------------------

enum class ReExtra { none, plane, halfspace };

struct ReSceneSpec {
  const char* name;
  int n;            // boxes registered in the queried manager
  bool keep_pairs;  // true: an update() before the queries, so that self-collide reads the list
  ReExtra extra;    // an unbounded object registered last (kept in the separate list)
  bool single;      // float instead of double
};

void PrintTo(const ReSceneSpec& spec, std::ostream* os) {
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

const char* reQueryName(ReQuery q) {
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
bool reWalksOther(ReQuery q) {
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

enum class ReMutation {
  registerObject,
  registerObjects,
  unregisterObject,
  setup,
  updateAll,
  updateObject,
  updateVector,
  clear,
};
constexpr int kReMutations = 8;

const char* reMutationLabel(ReMutation mu) {
  switch (mu) {
    case ReMutation::registerObject:
      return "registerObject";
    case ReMutation::registerObjects:
      return "registerObjects";
    case ReMutation::unregisterObject:
      return "unregisterObject";
    case ReMutation::setup:
      return "setup";
    case ReMutation::updateAll:
      return "update()";
    case ReMutation::updateObject:
      return "update(obj)";
    case ReMutation::updateVector:
      return "update(vector)";
    case ReMutation::clear:
      return "clear";
  }
  return "?";
}

// The name the std::logic_error's message must contain.
const char* reCallName(ReMutation mu) {
  switch (mu) {
    case ReMutation::updateAll:
    case ReMutation::updateObject:
    case ReMutation::updateVector:
      return "update";
    default:
      return reMutationLabel(mu);
  }
}

// Moves an object 1000 along x for the length of a scope, then puts it back exactly where it was
// (same transform, same AABB), also when an exception leaves the scope.
template <typename T>
struct ReMoved {
  ReObj<T>* o;
  fcl::Transform3<T> saved;
  explicit ReMoved(ReObj<T>* obj) : o(obj), saved(obj->getTransform()) {
    o->setTranslation(saved.translation() + fcl::Vector3<T>(1000, 0, 0));
    o->computeAABB();
  }
  ~ReMoved() {
    o->setTransform(saved);
    o->computeAABB();
  }
  ReMoved(const ReMoved&) = delete;
  ReMoved& operator=(const ReMoved&) = delete;
};

// Each mutation, chosen so that it would change the answers if it went through: new objects
// overlap the scene, the removed or updated objects are boxes with overlaps, and an update reads
// an AABB moved far away (put back when the scope ends, so that the objects' AABBs stay those the
// manager had before).
template <typename T>
void reMutate(ReManager<T>& target, const std::vector<ReObj<T>*>& objs,
              const std::vector<ReObj<T>*>& spare, ReMutation mu) {
  switch (mu) {
    case ReMutation::registerObject:
      target.registerObject(spare[0]);
      break;
    case ReMutation::registerObjects:
      target.registerObjects({spare[0], spare[1]});
      break;
    case ReMutation::unregisterObject:
      target.unregisterObject(objs[1]);
      break;
    case ReMutation::setup:
      target.setup();
      break;
    case ReMutation::updateAll: {
      ReMoved<T> moved(objs[1]);
      target.update();
      break;
    }
    case ReMutation::updateObject: {
      ReMoved<T> moved(objs[1]);
      target.update(objs[1]);
      break;
    }
    case ReMutation::updateVector: {
      ReMoved<T> a(objs[1]), b(objs[2]);
      target.update(std::vector<ReObj<T>*>{objs[1], objs[2]});
      break;
    }
    case ReMutation::clear:
      target.clear();
      break;
  }
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

enum class ReMode { propagate, swallow };

struct ReRow {
  ReQuery q;
  bool target_other;  // mutate the other cube manager (walked by the query) instead of this one
  ReMutation mu;
  ReMode mode;
};

std::vector<ReRow> reAllRows() {
  std::vector<ReRow> rows;
  for (int q = 0; q < kReQueries; ++q)
    for (int t = 0; t < (reWalksOther(ReQuery(q)) ? 2 : 1); ++t)
      for (int mu = 0; mu < kReMutations; ++mu)
        for (ReMode mode : {ReMode::propagate, ReMode::swallow})
          rows.push_back({ReQuery(q), t == 1, ReMutation(mu), mode});
  return rows;
}

std::string reRowName(const ReRow& r) {
  return std::string(reQueryName(r.q)) + " x " + reMutationLabel(r.mu) + " of " +
         (r.target_other ? "the other manager" : "this manager") +
         (r.mode == ReMode::propagate ? ", exception propagated" : ", exception caught");
}

// One combination: "" if all is as the contract says, else the first problem. The callback
// attempts the mutation on its first call (propagate: lets the exception out) or on its first and
// third calls (swallow: catches it and returns false). A scene that passed is left in a known
// state (one object of each manager unregistered and registered again, at the end of mine and
// theirs) and serves the next row.
template <typename T>
std::string reCheckRow(ReScene<T>& sc, const ReSceneSpec& spec, const ReRow& row) {
  ReManager<T>& target = row.target_other ? *sc.other : *sc.m;
  const auto& target_objs = row.target_other ? sc.theirs : sc.mine;
  const auto& target_spare = row.target_other ? sc.spare_theirs : sc.spare_mine;
  const bool listed = sc.m->pairsListed();
  if (spec.keep_pairs != listed) return "scene setup: pairsListed() is not keep_pairs";

  ReHook<T> ref;  // the same query without any attempt
  reRun(sc, row.q, ref);
  if (ref.calls.size() < 3) return "scene setup: the query makes fewer than 3 calls";

  ReHook<T> h;
  std::vector<std::string> messages;  // what() of each std::logic_error the attempts threw
  bool went_through = false;
  std::string changed;  // set when a refused call changed the manager all the same
  h.on_call = [&](int call) {
    if (call != 1 && !(row.mode == ReMode::swallow && call == 3)) return;
    try {
      reMutate(target, target_objs, target_spare, row.mu);
    } catch (const std::logic_error& e) {
      messages.push_back(e.what());
      // Checked at once (const calls, allowed here): a query going on over a changed manager
      // could crash the test instead of failing it.
      std::string why;
      if (reObjectsOf(target) != target_objs)
        changed = "getObjects() changed";
      else if (!target.validate(&why))
        changed = "validate() failed: " + why;
      if (!changed.empty()) throw ReAbort{};
      if (row.mode == ReMode::propagate) throw;
      return;
    }
    went_through = true;
    throw ReAbort{};
  };
  bool threw = false, threw_other = false;
  std::string thrown;
  try {
    reRun(sc, row.q, h);
  } catch (const ReAbort&) {
  } catch (const std::logic_error& e) {
    threw = true;
    thrown = e.what();
  } catch (...) {
    threw_other = true;
  }
  const std::string name = reCallName(row.mu);
  if (went_through)
    return std::string("no std::logic_error: ") + reMutationLabel(row.mu) +
           " went through inside the callback";
  if (!changed.empty())
    return std::string("the refused ") + reMutationLabel(row.mu) +
           " changed the manager: " + changed;
  if (threw_other) return "the query threw something other than a std::logic_error";
  for (const std::string& msg : messages)
    if (msg.find(name) == std::string::npos || msg.find("inside a callback") == std::string::npos)
      return "message \"" + msg + "\" lacks \"" + name + "\" or \"inside a callback\"";
  if (row.mode == ReMode::propagate) {
    if (messages.size() != 1) return "expected 1 attempt, saw " + std::to_string(messages.size());
    if (!threw) return "the query did not end with the std::logic_error";
    if (thrown != messages[0]) return "the query ended with another message: " + thrown;
    if (h.calls.size() != 1)
      return "callbacks went on after the exception (" + std::to_string(h.calls.size()) + " calls)";
  } else {
    if (threw) return "the query threw although the callback caught: " + thrown;
    if (messages.size() != 2) return "expected 2 attempts, saw " + std::to_string(messages.size());
    if (reSorted(h.calls) != reSorted(ref.calls))
      return "the query reported other pairs than without the attempt (" +
             std::to_string(h.calls.size()) + " calls vs " + std::to_string(ref.calls.size()) + ")";
  }
  // Nothing changed.
  std::string why = reAnswersLike(*sc.m, sc.mine, "this manager", true, &sc.brute_mine);
  if (!why.empty()) return why;
  why = reAnswersLike(*sc.other, sc.theirs, "the other manager", false, &sc.brute_theirs);
  if (!why.empty()) return why;
  if (sc.m->pairsListed() != listed) return "the pair list was set aside";
  ReHook<T> again;
  reRun(sc, row.q, again);
  if (reSorted(again.calls) != reSorted(ref.calls))
    return "the same query afterwards reports other pairs";
  // The guard was released: both managers take mutations again.
  why = reMutatesNormally(*sc.m, sc.mine, "this manager", &sc.brute_mine);
  if (!why.empty()) return why;
  return reMutatesNormally(*sc.other, sc.theirs, "the other manager", &sc.brute_theirs);
}

const ReSceneSpec kReScenes[] = {
    {"Small10KeepPairs", 10, true, ReExtra::none, false},
    {"Small10NoPairList", 10, false, ReExtra::none, false},
    {"Large300KeepPairs", 300, true, ReExtra::none, false},
    {"Large300NoPairList", 300, false, ReExtra::none, false},
    {"Small10PlaneKeepPairs", 10, true, ReExtra::plane, false},
    {"Large300HalfspaceNoPairList", 300, false, ReExtra::halfspace, false},
    {"FloatSmall10KeepPairs", 10, true, ReExtra::none, true},
    {"FloatLarge300PlaneNoPairList", 300, false, ReExtra::plane, true},
};

class ReentrancyTable : public ::testing::TestWithParam<ReSceneSpec> {};

// Every (query kind x mutating call x manager x propagate or catch) on the scene.
TEST_P(ReentrancyTable, MutationInsideACallbackThrowsAndChangesNothing) {
  const ReSceneSpec spec = GetParam();
  const std::vector<ReRow> rows = reAllRows();
  std::vector<std::string> failures;
  auto runAll = [&](auto scene) {
    for (const ReRow& row : rows) {
      const std::string why = reCheckRow(*scene, spec, row);
      if (why.empty()) continue;
      failures.push_back(reRowName(row) + ": " + why);
      scene = std::make_unique<typename decltype(scene)::element_type>(spec);  // a fresh one
    }
  };
  if (spec.single)
    runAll(std::make_unique<ReScene<float>>(spec));
  else
    runAll(std::make_unique<ReScene<S>>(spec));
  std::ostringstream out;
  for (std::size_t i = 0; i < failures.size() && i < 12; ++i) out << "\n  " << failures[i];
  if (failures.size() > 12) out << "\n  ... and " << failures.size() - 12 << " more";
  EXPECT_TRUE(failures.empty()) << failures.size() << " of " << rows.size()
                                << " combinations failed:" << out.str();
}

INSTANTIATE_TEST_SUITE_P(Scenes, ReentrancyTable, ::testing::ValuesIn(kReScenes),
                         [](const ::testing::TestParamInfo<ReSceneSpec>& info) {
                           return std::string(info.param.name);
                         });

// Reference answers of every query kind over a scene's current objects, by brute force.
template <typename T>
std::vector<RePair<T>> reBruteFor(ReScene<T>& sc, ReQuery q) {
  switch (q) {
    case ReQuery::collideObj:
    case ReQuery::fnCollideObj:
      return reBruteCross<T>(sc.mine, {sc.query});
    case ReQuery::collideSelf:
    case ReQuery::collideThis:
    case ReQuery::fnCollideSelf:
      return cube::oracle::bruteSelfPairs(sc.mine);
    case ReQuery::collideOther:
    case ReQuery::collideNaive:
    case ReQuery::fnCollideOther:
      return reBruteCross<T>(sc.mine, sc.theirs);
    default:
      return {};  // distance queries: compared with a run outside any callback
  }
}

bool reIsCollide(ReQuery q) {
  return q == ReQuery::collideObj || q == ReQuery::collideSelf || q == ReQuery::collideOther ||
         q == ReQuery::collideThis || q == ReQuery::collideNaive || q == ReQuery::fnCollideSelf ||
         q == ReQuery::fnCollideObj || q == ReQuery::fnCollideOther;
}

// Const queries of the same manager from inside a callback: allowed, and they answer as outside.
TEST(Reentrancy, ConstQueriesInsideACallbackGiveTheRightPairs) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[1], kReScenes[5]}) {
    for (int outer = 0; outer < kReQueries; ++outer) {
      SCOPED_TRACE(std::string(spec.name) + ", outer query " + reQueryName(ReQuery(outer)));
      ReScene<S> sc(spec);
      // What each inner query reports outside any callback.
      std::vector<std::vector<RePair<S>>> want(kReQueries);
      for (int inner = 0; inner < kReQueries; ++inner) {
        ReHook<S> h;
        reRun(sc, ReQuery(inner), h);
        want[inner] = reSorted(h.calls);
        if (reIsCollide(ReQuery(inner))) {
          ASSERT_EQ(want[inner], reBruteFor(sc, ReQuery(inner)))
              << "outside any callback: " << reQueryName(ReQuery(inner));
        }
      }
      ReHook<S> outer_hook;
      std::vector<std::string> wrong;
      outer_hook.on_call = [&](int call) {
        if (call > 2) return;
        for (int inner = 0; inner < kReQueries; ++inner) {
          ReHook<S> h;
          reRun(sc, ReQuery(inner), h);
          if (reSorted(h.calls) != want[inner])
            wrong.push_back(std::string(reQueryName(ReQuery(inner))) + " on call " +
                            std::to_string(call));
        }
      };
      reRun(sc, ReQuery(outer), outer_hook);
      EXPECT_TRUE(wrong.empty()) << "nested queries answering otherwise: " << wrong.size()
                                 << ", first: " << (wrong.empty() ? "" : wrong[0]);
      EXPECT_EQ(reSorted(outer_hook.calls), want[outer]);
      EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
      EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
    }
  }
}

// A nested query returning must not release the outer query's guard: a mutation after it, still
// inside the outer callback, throws as well; once the outer query is over, mutations work.
TEST(Reentrancy, GuardHoldsAfterANestedQueryReturns) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[3]}) {
    SCOPED_TRACE(spec.name);
    ReScene<S> sc(spec);
    ReHook<S> ref;
    reRun(sc, ReQuery::collideOther, ref);
    // Outer: m against other. Inner (on call 1): a self-collide of m and one of other, then a
    // mutation of each.
    ReHook<S> outer;
    std::vector<std::string> messages;
    bool went_through = false;
    outer.on_call = [&](int call) {
      if (call != 1) return;
      EXPECT_EQ(cube::oracle::selfPairs(*sc.m), cube::oracle::bruteSelfPairs(sc.mine));
      EXPECT_EQ(cube::oracle::selfPairs(*sc.other), cube::oracle::bruteSelfPairs(sc.theirs));
      for (ReManager<S>* target : {sc.m.get(), sc.other.get()}) {
        try {
          target->clear();
        } catch (const std::logic_error& e) {
          messages.push_back(e.what());
          continue;
        }
        went_through = true;
        throw ReAbort{};
      }
    };
    try {
      reRun(sc, ReQuery::collideOther, outer);
    } catch (const ReAbort&) {
    }
    ASSERT_FALSE(went_through) << "clear() went through inside the outer callback after a nested "
                                  "query had returned";
    ASSERT_EQ(messages.size(), 2u);
    for (const auto& msg : messages) {
      EXPECT_NE(msg.find("clear"), std::string::npos) << msg;
      EXPECT_NE(msg.find("inside a callback"), std::string::npos) << msg;
    }
    EXPECT_EQ(reSorted(outer.calls), reSorted(ref.calls));
    EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
    EXPECT_EQ(reAnswersLike(*sc.other, sc.theirs, "the other manager"), "");
    EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
    EXPECT_EQ(reMutatesNormally(*sc.other, sc.theirs, "the other manager"), "");
  }
}

// A cube manager that takes no part in the running query may be mutated from its callback.
TEST(Reentrancy, MutatingAnUninvolvedManagerIsAllowed) {
  using Obj = ReObj<S>;
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[5]}) {
    for (int q = 0; q < kReQueries; ++q) {
      SCOPED_TRACE(std::string(spec.name) + ", query " + reQueryName(ReQuery(q)));
      ReScene<S> sc(spec);
      // A third manager with its own objects: a row of unit boxes 0.5 apart.
      std::vector<std::unique_ptr<Obj>> own;
      std::vector<Obj*> xs;
      for (int i = 0; i < 8; ++i) {
        own.push_back(std::make_unique<Obj>(std::make_shared<fcl::Box<S>>(1, 1, 1)));
        own.back()->setTranslation(fcl::Vector3<S>(0.5 * i, 0, 0));
        own.back()->computeAABB();
        xs.push_back(own.back().get());
      }
      ReManager<S> x;
      x.registerObjects({xs[0], xs[1], xs[2], xs[3], xs[4]});
      x.setup();
      ReHook<S> ref;
      reRun(sc, ReQuery(q), ref);

      std::vector<std::string> problems;
      ReHook<S> h;
      h.on_call = [&](int call) {
        if (call != 1) return;
        auto check = [&](const std::vector<Obj*>& want, const char* step) {
          const std::string why = reAnswersLike(x, want, "the third manager");
          if (!why.empty()) problems.push_back(std::string(step) + ": " + why);
        };
        try {
          x.registerObject(xs[5]);
          check({xs[0], xs[1], xs[2], xs[3], xs[4], xs[5]}, "registerObject");
          x.registerObjects({xs[6], xs[7]});
          check({xs[0], xs[1], xs[2], xs[3], xs[4], xs[5], xs[6], xs[7]}, "registerObjects");
          x.unregisterObject(xs[2]);
          const std::vector<Obj*> left = {xs[0], xs[1], xs[3], xs[4], xs[5], xs[6], xs[7]};
          check(left, "unregisterObject");
          x.setup();
          check(left, "setup");
          xs[0]->setTranslation(fcl::Vector3<S>(2.2, 0, 0));
          xs[0]->computeAABB();
          x.update(xs[0]);
          check(left, "update(obj)");
          xs[1]->setTranslation(fcl::Vector3<S>(100, 0, 0));
          xs[1]->computeAABB();
          xs[3]->setTranslation(fcl::Vector3<S>(100.5, 0, 0));
          xs[3]->computeAABB();
          x.update(std::vector<Obj*>{xs[1], xs[3]});
          check(left, "update(vector)");
          xs[4]->setTranslation(fcl::Vector3<S>(99.8, 0, 0));
          xs[4]->computeAABB();
          x.update();
          check(left, "update()");
          x.clear();
          check({}, "clear");
        } catch (const std::exception& e) {
          problems.push_back(std::string("the third manager threw: ") + e.what());
        }
        // The other cube manager, when the query does not walk it, is uninvolved too.
        if (!reWalksOther(ReQuery(q))) {
          try {
            sc.other->unregisterObject(sc.theirs[0]);
            sc.other->registerObject(sc.theirs[0]);
            sc.other->update();
          } catch (const std::exception& e) {
            problems.push_back(std::string("the other manager threw: ") + e.what());
          }
        }
      };
      EXPECT_NO_THROW(reRun(sc, ReQuery(q), h));
      EXPECT_TRUE(problems.empty())
          << problems.size() << " problems, first: " << (problems.empty() ? "" : problems[0]);
      EXPECT_EQ(reSorted(h.calls), reSorted(ref.calls));
      EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
      if (!reWalksOther(ReQuery(q))) {
        std::vector<Obj*> theirs(sc.theirs.begin() + 1, sc.theirs.end());
        theirs.push_back(sc.theirs[0]);
        EXPECT_EQ(reAnswersLike(*sc.other, theirs, "the other manager"), "");
      }
    }
  }
  // The other way round: this manager is mutated from a callback of the other one's query that
  // does not involve it.
  ReScene<S> sc(kReScenes[0]);
  std::string problem;
  sc.other->collide(sc.query, [&](ReObj<S>*, ReObj<S>*) {
    try {
      sc.m->unregisterObject(sc.mine[0]);
      sc.m->registerObject(sc.mine[0]);
    } catch (const std::exception& e) {
      problem = e.what();
    }
  });
  EXPECT_EQ(problem, "");
  std::vector<ReObj<S>*> now(sc.mine.begin() + 1, sc.mine.end());
  now.push_back(sc.mine[0]);
  EXPECT_EQ(reAnswersLike(*sc.m, now, "this manager"), "");
}

// An exception of the user's own type leaves every query kind unchanged, also from a nested
// query, and the managers take mutations afterwards (whatever guard there is was released).
TEST(Reentrancy, UserExceptionsPropagateUnchanged) {
  for (const ReSceneSpec& spec : {kReScenes[0], kReScenes[4], kReScenes[5]}) {
    for (int q = 0; q < kReQueries; ++q) {
      for (bool nested : {false, true}) {
        SCOPED_TRACE(std::string(spec.name) + ", query " + reQueryName(ReQuery(q)) +
                     (nested ? ", thrown from a nested self-collide" : ""));
        ReScene<S> sc(spec);
        const bool listed = sc.m->pairsListed();
        ReHook<S> h;
        h.on_call = [&](int call) {
          if (call != 2) return;
          if (!nested) throw ReUserError{q, "from the callback"};
          sc.m->collide([&](ReObj<S>*, ReObj<S>*) { throw ReUserError{q, "from the callback"}; });
        };
        bool caught = false;
        try {
          reRun(sc, ReQuery(q), h);
        } catch (const ReUserError& e) {
          caught = true;
          EXPECT_EQ(e.code, q);
          EXPECT_EQ(e.text, "from the callback");
        } catch (...) {
          ADD_FAILURE() << "another exception than the user's";
        }
        EXPECT_TRUE(caught);
        EXPECT_EQ(h.calls.size(), 2u);
        EXPECT_EQ(sc.m->pairsListed(), listed);
        EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
        EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
        EXPECT_EQ(reMutatesNormally(*sc.other, sc.theirs, "the other manager"), "");
      }
    }
  }
}

// Several threads querying one manager at once, each callback attempting a mutation: every
// attempt throws, every query reports its pairs, and afterwards the manager takes mutations (the
// guard's bookkeeping survived concurrent queries).
TEST(Reentrancy, ConcurrentQueriesEachSeeTheGuard) {
  ReScene<S> sc(kReScenes[0]);
  // Precondition on one thread; without it the threads below would mutate a manager others walk.
  {
    bool threw = false;
    try {
      sc.m->collide([&](ReObj<S>*, ReObj<S>*) {
        try {
          sc.m->setup();
        } catch (const std::logic_error&) {
          threw = true;
          return;
        }
        throw ReAbort{};
      });
    } catch (const ReAbort&) {
    }
    ASSERT_TRUE(threw) << "setup() inside a callback did not throw std::logic_error (one thread)";
  }
  const auto want_self = cube::oracle::bruteSelfPairs(sc.mine);
  const auto want_obj = reBruteCross<S>(sc.mine, {sc.query});
  std::atomic<int> attempts{0}, throws{0}, wrong{0};
  auto worker = [&](int seed) {
    for (int i = 0; i < 300; ++i) {
      std::vector<RePair<S>> got;
      auto cb = [&](ReObj<S>* a, ReObj<S>* b) {
        got.push_back(cube::oracle::unordered(a, b));
        if (got.size() != 1) return;
        ++attempts;
        try {
          sc.m->setup();
        } catch (const std::logic_error&) {
          ++throws;
        }
      };
      if ((i + seed) % 2 == 0) {
        sc.m->collide(cb);
        if (reSorted(got) != want_self) ++wrong;
      } else {
        sc.m->collide(sc.query, cb);
        if (reSorted(got) != want_obj) ++wrong;
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) threads.emplace_back(worker, t);
  for (auto& t : threads) t.join();
  EXPECT_EQ(attempts.load(), 4 * 300);
  EXPECT_EQ(throws.load(), attempts.load());
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_EQ(reAnswersLike(*sc.m, sc.mine, "this manager"), "");
  EXPECT_EQ(reMutatesNormally(*sc.m, sc.mine, "this manager"), "");
}

// ------------------------------------------------------------------------------------------------
// Part 2: validate() over scenes spanning 1e-6 to 1e9.
// ------------------------------------------------------------------------------------------------

template <typename T>
std::unique_ptr<ReObj<T>> reBoxAt(T size, T x, T y, T z) {
  auto o = std::make_unique<ReObj<T>>(std::make_shared<fcl::Box<T>>(size, size, size));
  o->setTranslation(fcl::Vector3<T>(x, y, z));
  o->computeAABB();
  return o;
}

// The reported case: small boxes registered one by one, one box far away (its centre at
// `far_at`), the far one unregistered: validate() said "tracked area 16.4 differs from 16.4" for
// a far box of size 100 at x = 1e9 (the running total lost the small cubes' area to
// cancellation). Then the same away along each axis, with setup() and update() in between.
template <typename T>
void reFarOneRemoved(const cube::Config& config, const fcl::Vector3<T>& far_at, T far_size) {
  std::vector<std::unique_ptr<ReObj<T>>> owned;
  std::vector<ReObj<T>*> small;
  for (int i = 0; i < 3; ++i) {
    owned.push_back(reBoxAt<T>(1, T(i), T(0.3 * (i % 2)), 0));
    small.push_back(owned.back().get());
  }
  owned.push_back(reBoxAt<T>(far_size, far_at[0], far_at[1], far_at[2]));
  ReObj<T>* far_one = owned.back().get();
  ReManager<T> m(config);
  std::string why;
  for (auto* o : small) {
    m.registerObject(o);
    ASSERT_TRUE(m.validate(&why)) << why;
  }
  m.registerObject(far_one);
  ASSERT_TRUE(m.validate(&why)) << "after registering the far box: " << why;
  m.unregisterObject(far_one);
  ASSERT_TRUE(m.validate(&why)) << "after unregistering the far box: " << why;
  EXPECT_EQ(reObjectsOf<T>(m), small);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(small));
  for (int axis = 0; axis < 3; ++axis) {
    fcl::Vector3<T> p(0, 0, 0);
    p[axis] = T(-1e9);
    far_one->setTranslation(p);
    far_one->computeAABB();
    m.setup();
    m.registerObject(far_one);
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ": " << why;
    m.update();
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ", after update(): " << why;
    m.unregisterObject(far_one);
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ", after unregistering: " << why;
  }
  EXPECT_EQ(reObjectsOf<T>(m), small);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(small));
}

TEST(ReValidateArea, FarBoxRegisteredThenUnregistered) {
  cube::Config refit;
  refit.update_policy = cube::UpdatePolicy::refit;
  for (const cube::Config& config : {cube::Config(), refit}) {
    SCOPED_TRACE(config.update_policy == cube::UpdatePolicy::refit ? "refit" : "automatic");
    {
      SCOPED_TRACE("double, far box of size 100 at x = 1e9 (the reported case)");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 100);
    }
    {
      SCOPED_TRACE("double, far box of size 1 at x = 1e9");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 1);
    }
    {
      SCOPED_TRACE("double, far box of size 1 at (1e9, 1e9, 1e9)");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 1e9, 1e9), 1);
    }
    {
      SCOPED_TRACE("double, far box of size 1e9 at x = 1e9");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 1e9);
    }
    {
      SCOPED_TRACE("float, far box of size 100 at x = 1e9");
      reFarOneRemoved<float>(config, fcl::Vector3<float>(1e9f, 0, 0), 100);
    }
    {
      SCOPED_TRACE("float, far box of size 1 at (1e9, 1e9, 1e9)");
      reFarOneRemoved<float>(config, fcl::Vector3<float>(1e9f, 1e9f, 1e9f), 1);
    }
  }
}

// A random sequence of mutations over objects from 1e-6 to 1e9 in size and position, moving
// between near the origin and 1e9 away; validate() after every mutation.
template <typename T>
void reRandomFarNear(std::uint32_t seed, const cube::Config& config) {
  using Obj = ReObj<T>;
  std::mt19937 rng(seed);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  auto logUniform = [&](double lo, double hi) {
    return std::exp(uniform(std::log(lo), std::log(hi)));
  };
  const int kPool = 48;
  std::vector<std::unique_ptr<Obj>> pool;
  std::vector<bool> is_far(kPool, false);
  auto place = [&](int i, bool far) {
    fcl::Vector3<T> p;
    for (int k = 0; k < 3; ++k)
      p[k] = T(far ? (rng() % 2 ? 1.0 : -1.0) * 1e9 * uniform(0.5, 1.0)
                   : uniform(-1.0, 1.0) * logUniform(1e-6, 1.0));
    pool[i]->setTranslation(p);
    pool[i]->computeAABB();
    is_far[i] = far;
  };
  for (int i = 0; i < kPool; ++i) {
    const double r = uniform(0, 1);
    const double size = r < 0.7   ? logUniform(1e-6, 1)
                        : r < 0.9 ? logUniform(1, 1e3)
                                  : logUniform(1e6, 1e9);
    pool.push_back(std::make_unique<Obj>(std::make_shared<fcl::Box<T>>(T(size), T(size), T(size))));
    place(i, uniform(0, 1) < 0.2);
  }
  ReManager<T> m(config);
  std::vector<Obj*> reg;  // getObjects() order
  auto registered = [&](Obj* o) { return std::find(reg.begin(), reg.end(), o) != reg.end(); };
  auto indexOf = [&](Obj* o) {
    int i = 0;
    while (pool[i].get() != o) ++i;
    return i;
  };
  auto pickRegistered = [&]() { return reg[rng() % reg.size()]; };
  auto pickFree = [&]() -> Obj* {
    std::vector<Obj*> free;
    for (auto& p : pool)
      if (!registered(p.get())) free.push_back(p.get());
    return free.empty() ? nullptr : free[rng() % free.size()];
  };
  auto flip = [&](Obj* o) {
    const int i = indexOf(o);
    place(i, !is_far[i]);
  };
  const char* names[] = {"registerObject", "registerObjects", "unregisterObject",
                         "update(obj)",    "update()",        "update(vector)",
                         "setup"};
  std::discrete_distribution<int> op_of({20, 5, 20, 25, 10, 10, 10});
  std::string why;
  for (int step = 0; step < 1500; ++step) {
    int op = op_of(rng);
    if (reg.size() < 3) op = 0;
    if (op == 0) {
      if (Obj* o = pickFree()) {
        m.registerObject(o);
        reg.push_back(o);
      }
    } else if (op == 1) {
      std::vector<Obj*> batch;
      for (int k = 0; k < 3; ++k)
        if (Obj* o = pickFree())
          if (std::find(batch.begin(), batch.end(), o) == batch.end()) batch.push_back(o);
      m.registerObjects(batch);
      reg.insert(reg.end(), batch.begin(), batch.end());
    } else if (op == 2) {
      Obj* o = pickRegistered();
      m.unregisterObject(o);
      reg.erase(std::find(reg.begin(), reg.end(), o));
    } else if (op == 3) {
      Obj* o = pickRegistered();
      flip(o);
      m.update(o);
    } else if (op == 4 || op == 5) {
      std::vector<Obj*> moved;
      for (int k = 1 + int(rng() % 3); k > 0; --k) {
        Obj* o = pickRegistered();
        if (std::find(moved.begin(), moved.end(), o) != moved.end()) continue;
        flip(o);
        moved.push_back(o);
      }
      if (op == 4)
        m.update();
      else
        m.update(moved);
    } else {
      m.setup();
    }
    ASSERT_TRUE(m.validate(&why)) << "step " << step << " (" << names[op] << ", " << reg.size()
                                  << " objects): " << why;
    if (step % 100 == 99) {
      ASSERT_EQ(reObjectsOf<T>(m), reg) << "step " << step;
      ASSERT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(reg)) << "step " << step;
    }
  }
  EXPECT_EQ(reObjectsOf<T>(m), reg);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(reg));
  auto naive = cube::oracle::naiveOf(reg);
  EXPECT_EQ(cube::oracle::selfPairs(naive), cube::oracle::bruteSelfPairs(reg));
}

TEST(ReValidateArea, RandomMutationsAcrossFifteenDecades) {
  cube::Config refit, pairs;
  refit.update_policy = cube::UpdatePolicy::refit;
  pairs.keep_pairs = true;
  const std::pair<const char*, cube::Config> configs[] = {
      {"default", cube::Config()}, {"refit", refit}, {"keep_pairs=true", pairs}};
  for (const auto& [name, config] : configs) {
    for (std::uint32_t seed : {21u, 2021u}) {
      SCOPED_TRACE(std::string(name) + ", seed " + std::to_string(seed));
      {
        SCOPED_TRACE("double");
        reRandomFarNear<S>(seed, config);
      }
      {
        SCOPED_TRACE("float");
        reRandomFarNear<float>(seed, config);
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Part 3: distances beyond float range (Config::unbounded_limit raised to 1e30).
// ------------------------------------------------------------------------------------------------

using ReDistObj = ReObj<S>;

// cube::defaultDistanceCallback, counting its calls.
struct ReCounted {
  cube::DistanceData<S> data;
  int calls = 0;
  static bool fn(ReDistObj* a, ReDistObj* b, void* d, S& dist) {
    auto* c = static_cast<ReCounted*>(d);
    ++c->calls;
    return cube::defaultDistanceCallback<S>(a, b, &c->data, dist);
  }
};

// leaf_size 1 puts every object in a leaf of its own, so that even two objects are reached
// through a cube against cube distance.
cube::Config reFarConfig(double limit = 1e30, int leaf_size = 8) {
  cube::Config c;
  c.unbounded_limit = limit;
  c.leaf_size = leaf_size;
  return c;
}

std::unique_ptr<ReDistObj> reSphereAt(S r, S x, S y, S z) {
  auto o = std::make_unique<ReDistObj>(std::make_shared<fcl::Sphere<S>>(r));
  o->setTranslation(fcl::Vector3<S>(x, y, z));
  o->computeAABB();
  return o;
}

// Minimum distance of a self distance query: (cube manager with defaultDistanceCallback and its
// call count, Naive with fcl::DefaultDistanceFunction), both also with the oracle's canonical
// narrowDistance.
struct ReMinDistances {
  S cube = 0, naive = 0, cube_canonical = 0, naive_canonical = 0;
  int cube_calls = 0;
};

ReMinDistances reSelfDistances(const ReManager<S>& m, const std::vector<ReDistObj*>& objs) {
  ReMinDistances r;
  ReCounted counted;
  m.distance(&counted, &ReCounted::fn);
  r.cube = counted.data.result.min_distance;
  r.cube_calls = counted.calls;
  auto naive = cube::oracle::naiveOf(objs);
  fcl::DefaultDistanceData<S> nd;
  naive.distance(&nd, fcl::DefaultDistanceFunction<S>);
  r.naive = nd.result.min_distance;
  r.cube_canonical = r.naive_canonical = std::numeric_limits<S>::max();
  m.distance(&r.cube_canonical, cube::oracle::narrowDistance<S>);
  naive.distance(&r.naive_canonical, cube::oracle::narrowDistance<S>);
  return r;
}

ReMinDistances reObjectDistances(const ReManager<S>& m, const std::vector<ReDistObj*>& objs,
                                 ReDistObj* q) {
  ReMinDistances r;
  ReCounted counted;
  m.distance(q, &counted, &ReCounted::fn);
  r.cube = counted.data.result.min_distance;
  r.cube_calls = counted.calls;
  auto naive = cube::oracle::naiveOf(objs);
  fcl::DefaultDistanceData<S> nd;
  naive.distance(q, &nd, fcl::DefaultDistanceFunction<S>);
  r.naive = nd.result.min_distance;
  r.cube_canonical = r.naive_canonical = std::numeric_limits<S>::max();
  m.distance(q, &r.cube_canonical, cube::oracle::narrowDistance<S>);
  naive.distance(q, &r.naive_canonical, cube::oracle::narrowDistance<S>);
  return r;
}

void reExpectSame(const ReMinDistances& r, S exact = -1) {
  const S tol = 1e-9 * std::abs(r.naive);
  EXPECT_GE(r.cube_calls, 1) << "the callback was never called";
  EXPECT_NEAR(r.cube, r.naive, tol)
      << "cube::defaultDistanceCallback vs fcl::DefaultDistanceFunction";
  EXPECT_NEAR(r.cube_canonical, r.naive_canonical, tol) << "oracle::narrowDistance";
  if (exact >= 0) {
    EXPECT_NEAR(r.naive, exact, 1e-9 * exact) << "Naive against the exact value";
  }
}

std::string reNum(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

TEST(ReFarDistance, TwoSpheresFarApart) {
  for (int leaf_size : {8, 1})
    for (S far : {1e20, 1e25}) {
      for (bool diagonal : {false, true}) {
        SCOPED_TRACE("apart by " + reNum(far) + (diagonal ? " on each axis" : " along x") +
                     ", leaf_size " + std::to_string(leaf_size));
        auto a = reSphereAt(0.5, 0, 0, 0);
        auto b = diagonal ? reSphereAt(0.5, far, far, far) : reSphereAt(0.5, far, 0, 0);
        ReManager<S> m(reFarConfig(1e30, leaf_size));
        m.registerObjects({a.get(), b.get()});
        std::string why;
        ASSERT_TRUE(m.validate(&why)) << why;
        {
          SCOPED_TRACE("self distance of the two");
          reExpectSame(reSelfDistances(m, {a.get(), b.get()}),
                       (diagonal ? std::sqrt(3.0) : 1) * far - 1);
        }
        // A query object as far again from the nearest one.
        auto q = reSphereAt(0.5, -far, 0, 0);
        ReManager<S> one(reFarConfig(1e30, leaf_size));
        one.registerObject(a.get());
        {
          SCOPED_TRACE("distance(query) with one object registered");
          reExpectSame(reObjectDistances(one, {a.get()}, q.get()), far - 1);
        }
        {
          SCOPED_TRACE("distance(query) with both registered");
          reExpectSame(reObjectDistances(m, {a.get(), b.get()}, q.get()), far - 1);
        }
      }
    }
}

// A scattered scene: a grid 1e20 apart, objects anywhere within 1e25, query objects among them;
// self distance, distance(obj) and distance(&other cube manager) against Naive. With the default
// unbounded_limit (1e15) as well, where every such object is in the unbounded list.
TEST(ReFarDistance, ScatteredSceneMatchesNaive) {
  for (double limit : {1e30, 1e15})
    for (int leaf_size : {8, 1}) {
      SCOPED_TRACE("unbounded_limit " + reNum(limit) + ", leaf_size " + std::to_string(leaf_size));
      std::mt19937 rng(21);
      std::uniform_real_distribution<double> coord(-1e25, 1e25), radius(1, 1e3);
      std::vector<std::unique_ptr<ReDistObj>> owned;
      std::vector<ReDistObj*> objs, others, queries;
      auto add = [&](std::vector<ReDistObj*>& to, std::unique_ptr<ReDistObj> o) {
        owned.push_back(std::move(o));
        to.push_back(owned.back().get());
      };
      for (int i = 0; i < 40; ++i)  // a 4 x 10 grid 1e20 apart, at 3e24 along x
        add(objs, reSphereAt(radius(rng), 3e24 + 1e20 * (i % 10), 1e20 * (i / 10), 0));
      for (int i = 0; i < 60; ++i) {
        const S r = radius(rng);
        const S x = coord(rng), y = coord(rng), z = coord(rng);
        if (i % 2)
          add(objs, reSphereAt(r, x, y, z));
        else
          add(objs, [&] {
            auto o = std::make_unique<ReDistObj>(std::make_shared<fcl::Box<S>>(r, 2 * r, r));
            o->setTranslation(fcl::Vector3<S>(x, y, z));
            o->computeAABB();
            return o;
          }());
      }
      for (int i = 0; i < 20; ++i) add(others, reSphereAt(radius(rng), coord(rng), coord(rng), 0));
      for (int i = 0; i < 6; ++i)
        add(queries, reSphereAt(radius(rng), coord(rng), coord(rng), coord(rng)));
      add(queries, reSphereAt(1, 3e24 + 4.5e20, 5e19, 0));  // amid the grid: nearest ~5e19 away

      ReManager<S> m(reFarConfig(limit, leaf_size)), other(reFarConfig(limit, leaf_size));
      m.registerObjects(objs);
      other.registerObjects(others);
      std::string why;
      ASSERT_TRUE(m.validate(&why)) << why;
      {
        SCOPED_TRACE("self distance");
        reExpectSame(reSelfDistances(m, objs));
      }
      for (std::size_t i = 0; i < queries.size(); ++i) {
        SCOPED_TRACE("distance(query #" + std::to_string(i) + ")");
        reExpectSame(reObjectDistances(m, objs, queries[i]));
      }
      {
        SCOPED_TRACE("distance(&other)");
        ReCounted counted;
        m.distance(&other, &counted, &ReCounted::fn);
        auto naive = cube::oracle::naiveOf(objs);
        auto naive_other = cube::oracle::naiveOf(others);
        fcl::DefaultDistanceData<S> nd;
        naive.distance(&naive_other, &nd, fcl::DefaultDistanceFunction<S>);
        EXPECT_GE(counted.calls, 1);
        EXPECT_NEAR(counted.data.result.min_distance, nd.result.min_distance,
                    1e-9 * nd.result.min_distance);
      }
    }
}

// ---------------------------------------------------------------------------------------------
// User code off the manager's own query path: the pair predicate
// during sweptPairs and continuousCollideAll, and a collideConcurrently callback on whichever
// thread runs it. Every kind of mutation is refused with std::logic_error there too, and the
// manager keeps its objects and passes validate().

struct GuardWorld {
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
  std::unique_ptr<fcl::CollisionObjectd> spare;
  cube::CubeCollisionManagerd m;
  explicit GuardWorld(int n) {
    auto box = std::make_shared<fcl::Boxd>(1, 1, 1);
    for (int i = 0; i < n; ++i) {
      // A row of touching boxes: every neighbour pair overlaps.
      objects.push_back(std::make_unique<fcl::CollisionObjectd>(
          box, fcl::Transform3d(Eigen::Translation3d(0.9 * (i % 40), 0.9 * (i / 40), 0))));
      objects.back()->computeAABB();
      m.registerObject(objects.back().get());
    }
    spare = std::make_unique<fcl::CollisionObjectd>(box);
    spare->computeAABB();
  }
};

constexpr int kGuardMutations = 12;

// Mutation k of m; throws what the manager throws.
void guardMutate(GuardWorld& w, int k) {
  fcl::CollisionObjectd* first = w.objects.front().get();
  std::vector<fcl::CollisionObjectd*> some{first};
  switch (k) {
    case 0:
      w.m.registerObject(w.spare.get());
      return;
    case 1:
      w.m.registerObjects({w.spare.get()});
      return;
    case 2:
      w.m.unregisterObject(first);
      return;
    case 3:
      w.m.setup();
      return;
    case 4:
      w.m.update();
      return;
    case 5:
      w.m.update(first);
      return;
    case 6:
      w.m.update(some);
      return;
    case 7:
      w.m.clear();
      return;
    case 8:
      w.m.setFilter(first, 2, 2);
      return;
    case 9:
      w.m.setPairFilter({});
      return;
    case 10:
      w.m.setMargin(0.5);
      return;
    case 11:
      w.m.setMargin(first, 0.5);
      return;
    default:
      return;
  }
}

// Counts the attempts and the refusals; an attempt that got through is a failure.
struct GuardCount {
  std::atomic<int> tried{0}, refused{0};
  void attempt(GuardWorld& w, int k) {
    ++tried;
    try {
      guardMutate(w, k);
    } catch (const std::logic_error&) {
      ++refused;
    }
  }
};

::testing::AssertionResult unchanged(GuardWorld& w, std::size_t n) {
  std::string why;
  if (w.m.size() != n) return ::testing::AssertionFailure() << w.m.size() << " objects, not " << n;
  if (!w.m.validate(&why)) return ::testing::AssertionFailure() << "validate: " << why;
  if (w.m.filter(w.objects.front().get()).first != 1)
    return ::testing::AssertionFailure() << "bits";
  if (w.m.margin(w.objects.front().get()) != 0) return ::testing::AssertionFailure() << "margin";
  return ::testing::AssertionSuccess();
}

TEST(ReentrancyOffThePath, PredicateOfContinuousQueriesCannotMutate) {
  for (int k = 0; k < kGuardMutations; ++k)
    for (const bool full : {false, true}) {  // sweptPairs, continuousCollideAll
      GuardWorld w(40);
      GuardCount count;
      w.m.setPairFilter([&](fcl::CollisionObjectd*, fcl::CollisionObjectd*) {
        if (count.tried.load() == 0) count.attempt(w, k);
        return true;
      });
      std::vector<cube::Motion<double>> motions(1);
      motions[0].object = w.objects[5].get();
      motions[0].end = fcl::Transform3d(Eigen::Translation3d(4.5, 0.3, 0));
      if (full)
        cube::continuousCollideAll(w.m, motions);
      else
        cube::sweptPairs(w.m, motions);
      EXPECT_EQ(count.tried.load(), 1) << "mutation " << k << " full " << full;
      EXPECT_EQ(count.refused.load(), 1) << "mutation " << k << " full " << full;
      EXPECT_TRUE(unchanged(w, 40)) << "mutation " << k << " full " << full;
    }
}

// collideAll runs no user callback, but the manager's pair predicate: with the walk split over
// threads (split_walk, 5,000 objects) it is still asked on the calling thread, inside the
// query's guard, and every mutation from it is refused.
TEST(ReentrancyOffThePath, PredicateDuringASplitCollideAllCannotMutate) {
  for (int k = 0; k < kGuardMutations; ++k) {
    GuardWorld w(5000);
    GuardCount count;
    w.m.setPairFilter([&](fcl::CollisionObjectd*, fcl::CollisionObjectd*) {
      if (count.tried.load() < 50) count.attempt(w, k);
      return true;
    });
    fcl::CollisionRequestd all;
    all.num_max_contacts = 1 << 30;
    cube::NarrowPhaseOptions<double> o;
    o.threads = 2;
    o.split_walk = true;
    const auto r = cube::collideAll<double>(w.m, all, o);
    EXPECT_GT(r.numContacts(), 1000u);
    EXPECT_EQ(count.tried.load(), 50) << "mutation " << k;
    EXPECT_EQ(count.refused.load(), 50) << "mutation " << k;
    EXPECT_TRUE(unchanged(w, 5000)) << "mutation " << k;
  }
}

TEST(ReentrancyOffThePath, CollideConcurrentlyCallbacksCannotMutateOnAnyThread) {
  struct Data {
    GuardWorld* w;
    GuardCount* count;
    int k;
    std::atomic<int> on_other_threads{0};
    std::thread::id caller;
  };
  int on_workers = 0;  // over all runs: one run's worker may get no pair on a loaded machine
  for (int k = 0; k < kGuardMutations; ++k)
    for (const int threads : {1, 2, 3}) {
      GuardWorld w(1500);
      GuardCount count;
      Data d{&w, &count, k, {}, std::this_thread::get_id()};
      cube::collideConcurrently<double>(
          w.m, &d,
          [](fcl::CollisionObjectd*, fcl::CollisionObjectd*, void* p) {
            auto& x = *static_cast<Data*>(p);
            if (std::this_thread::get_id() != x.caller) ++x.on_other_threads;
            x.count->attempt(*x.w, x.k);
            return false;
          },
          threads);
      EXPECT_GT(count.tried.load(), 1000) << "mutation " << k;
      EXPECT_EQ(count.refused.load(), count.tried.load())
          << "mutation " << k << " threads " << threads;
      on_workers += d.on_other_threads.load();
      EXPECT_TRUE(unchanged(w, 1500)) << "mutation " << k << " threads " << threads;
    }
  if (cube::hardwareThreads() > 1) {
    EXPECT_GT(on_workers, 0) << "no callback ran on a worker";
  }
}

}  // namespace
