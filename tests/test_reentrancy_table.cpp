// Every (query kind x mutating call x manager x exception propagated or caught), on scenes of
// both precisions with and without the pair list and unbounded objects: a mutation from inside a
// callback of a query throws std::logic_error and changes nothing.
//
// Oracles: brute force over the objects' AABBs and fcl::NaiveCollisionManager (support/oracle.h),
// and, for "the query goes on", the same query run on the same manager without the mutation
// attempt.

#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/reentrancy_world.h"

namespace {

using namespace reentrancy;

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

}  // namespace
