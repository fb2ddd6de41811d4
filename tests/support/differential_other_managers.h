#pragma once

// The operation of a differential sequence that queries the manager against another manager:
// another cube manager (both directions), a Naive one, FCL's dynamic AABB tree, or the manager
// itself, each against brute force, and the Naive case against Naive vs Naive.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <algorithm>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "differential_expect.h"
#include "differential_pool.h"

namespace cube {
namespace diff {

class OtherManagerOp {
 public:
  OtherManagerOp(Source& src, Pool& pool, const Model& model, CubeCollisionManager<S>& mgr,
                 std::ostream& trace)
      : src_(src), pool_(pool), model_(model), mgr_(mgr), trace_(trace) {}

  /// Draws the other side, queries against it; "" or what differs.
  std::string run() {
    const std::uint32_t kind = src_.pick(4);
    const auto members = pool_.some(std::uint32_t(pool_.size()));
    std::unique_ptr<Manager> other = makeOther(kind, members);
    trace_ << "vs manager kind " << kind << " with " << members.size() << " objects\n";
    Manager* om = other ? other.get() : &mgr_;
    std::vector<Object*> theirs;
    om->getObjects(theirs);
    // The other side's boxes: a fresh manager read them now; the manager itself uses its cache.
    Boxes their_boxes;
    for (auto* o : theirs) their_boxes[o] = other ? o->getAABB() : model_.box(o);

    auto expectPairs = [&](bool reversed) {
      if (!other) return selfPairs(model_);
      return crossPairs(model_, theirs, their_boxes, reversed);
    };

    Rec r;
    mgr_.collide(om, &r, &Rec::collide);
    std::vector<Pair> got = r.calls;
    if (!other)
      for (auto& p : got) p = unordered(p.first, p.second);
    if (sorted(got) != expectPairs(false))
      return "collide(manager kind " + std::to_string(kind) + ") pairs differ from brute force";

    MinRec m{&model_.boxes(), &their_boxes};
    mgr_.distance(om, &m, &MinRec::distance);
    const S expected =
        other ? crossMinDistance(model_, theirs, their_boxes) : selfMinDistance(model_);
    if (m.bad || m.min != expected)
      return "distance(manager kind " + std::to_string(kind) + ") minimum " +
             std::to_string(m.min) + ", expected " + std::to_string(expected);

    if (kind == 0) {
      // The other direction: callback(object of other, object of this).
      auto* cube_other = dynamic_cast<CubeCollisionManager<S>*>(om);
      Rec back;
      cube_other->collide(&mgr_, &back, &Rec::collide);
      if (sorted(back.calls) != expectPairs(true))
        return "reverse collide(manager) pairs differ from brute force";
      MinRec mb{&their_boxes, &model_.boxes()};
      cube_other->distance(&mgr_, &mb, &MinRec::distance);
      if (mb.bad || mb.min != expected) return "reverse distance(manager) minimum differs";
    }
    if (kind == 1 && model_.inSync()) {
      // Against FCL itself: a Naive manager over our objects colliding with the other Naive.
      fcl::NaiveCollisionManager<S> mine;
      mine.registerObjects(model_.order());
      Rec n;
      mine.collide(om, &n, &Rec::collide);
      std::vector<Pair> want;
      for (const auto& p : n.calls)
        if (p.first != p.second) want.push_back(p);
      if (sorted(r.calls) != sorted(want))
        return "collide(Naive manager) differs from Naive vs Naive";
    }
    return "";
  }

 private:
  // Kind 0: another cube manager of a drawn configuration; 1: Naive; 2: FCL's dynamic AABB tree;
  // 3: none (the manager itself).
  std::unique_ptr<Manager> makeOther(std::uint32_t kind, const std::vector<Object*>& members) {
    static const std::vector<Config> all_configs = configs();
    if (kind == 0) {
      auto c = std::make_unique<CubeCollisionManager<S>>(
          all_configs[src_.pick(std::uint32_t(all_configs.size()))]);
      // Half the time one by one, so the other tree is incremental rather than freshly built.
      if (src_.pick(2)) {
        for (auto* o : members) c->registerObject(o);
      } else {
        c->registerObjects(members);
      }
      return c;
    }
    if (kind == 3) return nullptr;
    std::vector<Object*> distinct;
    for (auto* o : members)
      if (std::find(distinct.begin(), distinct.end(), o) == distinct.end()) distinct.push_back(o);
    if (kind == 1) {
      auto naive = std::make_unique<fcl::NaiveCollisionManager<S>>();
      naive->registerObjects(distinct);
      return naive;
    }
    auto tree = std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
    // One by one and no setup(): FCL's own bulk build (topdown_0) crashes on the degenerate
    // scenes (coincident boxes); we only need its getObjects().
    for (auto* o : distinct) tree->registerObject(o);
    return tree;
  }

  Source& src_;
  Pool& pool_;
  const Model& model_;
  CubeCollisionManager<S>& mgr_;
  std::ostream& trace_;
};

}  // namespace diff
}  // namespace cube
