#pragma once

// backend="fcl": FCL's DynamicAABBTreeCollisionManager under the pair rules of the cube manager's
// interface (filter bits, margins that grow the boxes, a pair predicate, no object paired with
// itself), so that the library's entry points over any FCL manager (queries.h: collideAll,
// overlappingPairs, collidePairs, minimumDistance) answer its queries as they answer the cube
// manager's: one code path for both backends, FCL's tree deciding the candidate pairs.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

namespace cubepy {

class FclBackend final : public fcl::BroadPhaseCollisionManagerd {
 public:
  using Obj = fcl::CollisionObjectd;

  // Rules, as CubeCollisionManager's (setFilter, filter, setMargin, margin, setPairFilter).
  void setFilter(Obj* obj, std::uint64_t category, std::uint64_t mask);
  /// {category, mask}; the default bits for an object not registered here.
  std::pair<std::uint64_t, std::uint64_t> filter(const Obj* obj) const;
  /// The manager-wide margin: every box of an object without its own grown by it.
  void setMargin(double margin);
  /// obj's own margin (registered objects only).
  void setMargin(Obj* obj, double margin);
  /// obj's own margin, else the manager-wide one (also for objects not registered here).
  double margin(const Obj* obj) const;
  /// Asked for each pair whose bits pass, within this manager's queries; empty: none.
  void setPairFilter(std::function<bool(Obj*, Obj*)> keep) { keep_ = std::move(keep); }

  // Registration: each box is the object's AABB grown by its margin.
  void registerObjects(const std::vector<Obj*>& objs) override;
  void registerObject(Obj* obj) override;
  void unregisterObject(Obj* obj) override;
  void setup() override { tree_.setup(); }
  void update() override;
  void update(Obj* obj) override;
  void update(const std::vector<Obj*>& objs) override;
  void clear() override;
  void getObjects(std::vector<Obj*>& objs) const override { tree_.getObjects(objs); }
  bool empty() const override { return tree_.empty(); }
  size_t size() const override { return tree_.size(); }

  // FCL's tree's queries, each pair handed on only if the rules let it pair. Against a manager
  // of another kind, each of its objects is asked of the tree (FCL's tree takes another
  // manager only of its own type); pairs come as (object here, object there).
  void collide(Obj* obj, void* cdata, fcl::CollisionCallBack<double> cb) const override;
  void distance(Obj* obj, void* cdata, fcl::DistanceCallBack<double> cb) const override;
  void collide(void* cdata, fcl::CollisionCallBack<double> cb) const override;
  void distance(void* cdata, fcl::DistanceCallBack<double> cb) const override;
  void collide(fcl::BroadPhaseCollisionManagerd* other, void* cdata,
               fcl::CollisionCallBack<double> cb) const override;
  void distance(fcl::BroadPhaseCollisionManagerd* other, void* cdata,
                fcl::DistanceCallBack<double> cb) const override;

 private:
  struct Rule {
    std::uint64_t category = 1, mask = ~std::uint64_t(0);
    double margin = -1;  // < 0: the manager-wide one
  };
  struct Gate;
  void grow(Obj* obj) const;

  fcl::DynamicAABBTreeCollisionManagerd tree_;
  std::unordered_map<const Obj*, Rule> rules_;
  std::function<bool(Obj*, Obj*)> keep_;
  double margin_ = 0;
};

}  // namespace cubepy
