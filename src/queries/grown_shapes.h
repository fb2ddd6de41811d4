#pragma once

// A mesh against a primitive grown by a reach (a continuous edge's raised margin): one thread's
// primitives, one per kind, made on first use and resized per pair, so that a pair within a
// raised margin allocates nothing. Private to the library.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>

#include <limits>
#include <memory>
#include <utility>

#include "pipeline/fcl_narrow.h"

namespace cube {
namespace detail {

/// One thread's grown primitives (not shared between threads).
template <typename S>
class GrownShapes {
 public:
  using Object = fcl::CollisionObject<S>;

  /// For a mesh and a box, sphere, capsule or cylinder: whether the mesh stays clear of the
  /// primitive grown to hold every point within `reach` of it (its distance is then above reach).
  /// FCL's collision walks the mesh's BVH with cheaper tests than its distance does, and most
  /// pairs within a raised margin are farther apart than it. False for any other pair, and for
  /// an infinite reach. `request`: FCL's collision request for the call.
  bool apart(const Object& a, const Object& b, S reach, const fcl::CollisionRequest<S>& request) {
    const Object* mesh = &a;
    const Object* shape = &b;
    if (mesh->getObjectType() != fcl::OT_BVH) std::swap(mesh, shape);
    if (mesh->getObjectType() != fcl::OT_BVH || shape->getObjectType() != fcl::OT_GEOM ||
        !(reach < std::numeric_limits<S>::infinity()))
      return false;
    const fcl::CollisionGeometry<S>& g = *shape->collisionGeometry();
    fcl::CollisionObject<S>* placed;
    switch (shape->getNodeType()) {
      case fcl::GEOM_BOX:
        placed = grown(0, fcl::Box<S>(static_cast<const fcl::Box<S>&>(g).side +
                                      fcl::Vector3<S>::Constant(S(2) * reach)));
        break;
      case fcl::GEOM_SPHERE:
        placed = grown(1, fcl::Sphere<S>(static_cast<const fcl::Sphere<S>&>(g).radius + reach));
        break;
      case fcl::GEOM_CAPSULE: {
        const auto& x = static_cast<const fcl::Capsule<S>&>(g);
        placed = grown(2, fcl::Capsule<S>(x.radius + reach, x.lz));
        break;
      }
      case fcl::GEOM_CYLINDER: {
        const auto& x = static_cast<const fcl::Cylinder<S>&>(g);
        placed = grown(3, fcl::Cylinder<S>(x.radius + reach, x.lz + S(2) * reach));
        break;
      }
      default:
        return false;
    }
    placed->setTransform(shape->getTransform());
    placed->computeAABB();
    fcl::CollisionResult<S> result;
    return fclCollide(placed, mesh, request, result) == 0;
  }

 private:
  // The one primitive of a kind (slot k), made on first use and given `wanted`'s
  // dimensions: a pair within a raised margin allocates nothing.
  template <typename Shape>
  fcl::CollisionObject<S>* grown(int k, const Shape& wanted) {
    if (!grown_[k]) {
      auto shape = std::make_shared<Shape>(wanted);
      shapes_[k] = shape.get();
      grown_[k] = std::make_unique<fcl::CollisionObject<S>>(shape);
      return grown_[k].get();
    }
    Shape& shape = *static_cast<Shape*>(shapes_[k]);
    shape = wanted;
    shape.computeLocalAABB();
    return grown_[k].get();
  }

  std::unique_ptr<fcl::CollisionObject<S>> grown_[4];  // box, sphere, capsule, cylinder
  fcl::CollisionGeometry<S>* shapes_[4] = {};
};

}  // namespace detail
}  // namespace cube
