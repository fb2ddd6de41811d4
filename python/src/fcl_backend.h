#pragma once

// backend="fcl": FCL's DynamicAABBTreeCollisionManager under the library's pair rules. The rules
// live in a cube manager that holds the same objects for their rules only (registered, never set
// up nor queried): filter bits, margins and excluded pairs are set and read there, and each pair
// FCL's tree finds is handed on only if that manager's pairPasses lets it pair, so that the
// library's entry points over any FCL manager (queries.h: collideAll, overlappingPairs,
// collidePairs, minimumDistance) answer its queries as they answer the cube manager's: one code
// path for both backends, FCL's tree deciding the candidate pairs.

#include <cube_collision/cube_collision_manager.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <vector>

namespace cubepy {

class FclBackend final : public fcl::BroadPhaseCollisionManagerd {
 public:
  using Obj = fcl::CollisionObjectd;

  /// The rules object: filter bits, margins and excluded pairs of the objects registered here,
  /// set and read there (margins through setMargin below, which also grows FCL's boxes).
  cube::CubeCollisionManagerd& rules() { return rules_; }
  const cube::CubeCollisionManagerd& rules() const { return rules_; }
  /// The manager-wide margin, then every box grown by it.
  void setMargin(double margin);
  /// obj's own margin (registered objects only), then its box grown by it.
  void setMargin(Obj* obj, double margin);

  // Registration, in FCL's tree and in the rules object: each box in FCL's tree is the object's
  // AABB grown by its margin.
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

  // FCL's tree's queries, each pair handed on only if the rules object lets it pair. Against a
  // manager of another kind, each of its objects is asked of the tree (FCL's tree takes another
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
  struct Gate;
  void grow(Obj* obj) const;

  fcl::DynamicAABBTreeCollisionManagerd tree_;
  cube::CubeCollisionManagerd rules_;
};

}  // namespace cubepy
