#pragma once

// What is checked after every step of a differential sequence: validate(), size() and
// getObjects() against the model, self-collide and self distance against brute force over the
// cached AABBs, collide(obj) and distance(obj) for two pool objects, and (drawn one step in four,
// when the cache equals the live AABBs at ordinary scales) the narrow phase against
// fcl::NaiveCollisionManager.

#include <fcl/broadphase/broadphase_bruteforce.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "differential_expect.h"
#include "differential_pool.h"
#include "oracle.h"

namespace cube {
namespace diff {

class StepChecks {
 public:
  StepChecks(Source& src, Pool& pool, const Model& model, CubeCollisionManager<S>& mgr, Scene scene)
      : src_(src), pool_(pool), model_(model), mgr_(mgr), scene_(scene) {}

  /// validate() failures whose message contains `text` are not reported (for the fuzzer only).
  void tolerateKnownBug(const std::string& text) { known_ = text; }

  std::size_t checksRun() const { return checks_; }
  std::size_t narrowChecksRun() const { return narrow_checks_; }

  /// "" or what differs.
  std::string afterStep() {
    ++checks_;
    std::string why;
    if (!mgr_.validate(&why) && (known_.empty() || why.find(known_) == std::string::npos))
      return "validate() failed: " + why;
    const auto& order = model_.order();
    if (mgr_.size() != order.size() || mgr_.empty() != order.empty())
      return "size() " + std::to_string(mgr_.size()) + ", expected " + std::to_string(order.size());
    std::vector<Object*> objs;
    mgr_.getObjects(objs);
    if (objs != order) return "getObjects() differs from the registered objects in order";
    std::string err = checkSelf();
    if (err.empty()) err = checkObjectQueries();
    if (err.empty() && src_.pick(4) == 0 && model_.inSync() && scene_ != Scene::huge &&
        scene_ != Scene::tiny)
      err = checkNarrow();
    return err;
  }

 private:
  std::string checkSelf() {
    Rec r;
    mgr_.collide(&r, &Rec::collide);
    std::vector<Pair> got;
    for (const auto& c : r.calls) got.push_back(unordered(c.first, c.second));
    if (sorted(got) != selfPairs(model_))
      return "self-collide pairs differ from brute force: " +
             diffPairs(pool_, model_, sorted(got), selfPairs(model_)) + dump(pool_, mgr_);

    // Self distance, pruning: the minimum AABB distance over all pairs.
    MinRec m{&model_.boxes(), &model_.boxes()};
    mgr_.distance(&m, &MinRec::distance);
    const S expected = selfMinDistance(model_);
    if (m.bad || m.min != expected)
      return "self distance minimum " + std::to_string(m.min) + ", expected " +
             std::to_string(expected);

    // Self distance with a callback that never lowers dist: every pair Naive would visit, each
    // once.
    Rec all;
    mgr_.distance(&all, [](Object* a, Object* b, void* d, S&) { return Rec::collide(a, b, d); });
    std::vector<Pair> visited;
    for (const auto& c : all.calls) visited.push_back(unordered(c.first, c.second));
    const std::vector<Pair> want = selfDistancePairs(model_);
    if (sorted(visited) != sorted(want))
      return "self distance without pruning visited " + std::to_string(visited.size()) +
             " pairs, expected " + std::to_string(want.size());
    return "";
  }

  std::string checkObjectQueries() {
    for (int q = 0; q < 2; ++q) {
      Object* o = pool_.any();  // registered or not
      Rec r;
      mgr_.collide(o, &r, &Rec::collide);
      std::vector<Pair> got;
      for (const auto& c : r.calls) {
        if (c.second != o) return "collide(obj): second argument is not the query object";
        got.emplace_back(c.first, o);
      }
      const std::vector<Pair> want = objectPairs(model_, o);
      if (sorted(got) != sorted(want))
        return "collide(" + pool_.name(o) + ") reported " + std::to_string(got.size()) +
               " objects, expected " + std::to_string(want.size());

      MinRec d{&model_.boxes(), nullptr};
      struct Check {
        MinRec* rec;
        Object* query;
        bool wrong = false;
      } chk{&d, o};
      mgr_.distance(o, &chk, [](Object* a, Object* b, void* p, S& dist) {
        auto* c = static_cast<Check*>(p);
        if (b != c->query) c->wrong = true;
        return MinRec::distance(a, b, c->rec, dist);
      });
      const S expected = objectMinDistance(model_, o);
      if (chk.wrong || d.bad) return "distance(obj): wrong callback arguments";
      if (d.min != expected)
        return "distance(" + pool_.name(o) + ") minimum " + std::to_string(d.min) + ", expected " +
               std::to_string(expected);
    }
    return "";
  }

  // The narrow-phase callbacks are oracle::narrowCollide / oracle::narrowDistance: the same call
  // per pair on both sides, argument order made canonical.
  std::string checkNarrow() {
    ++narrow_checks_;
    fcl::NaiveCollisionManager<S> naive;
    naive.registerObjects(model_.order());
    std::vector<Pair> ours, theirs;
    mgr_.collide(&ours, &oracle::narrowCollide<S>);
    naive.collide(&theirs, &oracle::narrowCollide<S>);
    if (sorted(ours) != sorted(theirs))
      return "narrow-phase colliding pairs differ from Naive (" + std::to_string(ours.size()) +
             " vs " + std::to_string(theirs.size()) + ")";
    S a = std::numeric_limits<S>::max(), b = a;
    mgr_.distance(&a, &oracle::narrowDistance<S>);
    naive.distance(&b, &oracle::narrowDistance<S>);
    if (std::abs(a - b) > 1e-9)
      return "narrow-phase self distance " + std::to_string(a) + " vs Naive " + std::to_string(b);
    // One query object through collide(obj) with FCL's own per-object loop.
    Object* q = pool_.any();
    std::vector<Pair> oq, nq;
    mgr_.collide(q, &oq, &oracle::narrowCollide<S>);
    struct Filter {
      Object* q;
      std::vector<Pair>* out;
    } f{q, &nq};
    naive.collide(q, &f, [](Object* x, Object* y, void* p) {
      // Naive calls back for every object without an AABB test; skip the query itself and
      // AABB-disjoint pairs, which the narrow phase may still call touching.
      auto* f = static_cast<Filter*>(p);
      if (y == x || !x->getAABB().overlap(y->getAABB())) return false;
      return oracle::narrowCollide<S>(x, y, f->out);
    });
    if (sorted(oq) != sorted(nq)) return "narrow-phase collide(obj) differs from Naive";
    return "";
  }

  Source& src_;
  Pool& pool_;
  const Model& model_;
  CubeCollisionManager<S>& mgr_;
  Scene scene_;
  std::string known_;
  std::size_t checks_ = 0, narrow_checks_ = 0;
};

}  // namespace diff
}  // namespace cube
