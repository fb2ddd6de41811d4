#pragma once

// A differential sequence's objects and what the manager under test should hold: the pool the
// operations draw objects from, and the model (the AABBs cached at register/update time, in
// registration order).

#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "differential_sources.h"

namespace cube {
namespace diff {

using S = double;
using Object = fcl::CollisionObject<S>;
using AABB = fcl::AABB<S>;
using Manager = fcl::BroadPhaseCollisionManager<S>;
using Pair = std::pair<Object*, Object*>;
using Boxes = std::map<const Object*, AABB>;

inline bool overlap(const AABB& a, const AABB& b) {
  return a.overlap(b);
}

inline bool sameBox(const AABB& a, const AABB& b) {
  for (int k = 0; k < 3; ++k)
    if (!(a.min_[k] == b.min_[k] && a.max_[k] == b.max_[k])) return false;
  return true;
}

inline Pair unordered(Object* a, Object* b) {
  return a < b ? Pair(a, b) : Pair(b, a);
}

/// The objects of one sequence, of one scene family; poses and shapes drawn from the source.
class Pool {
 public:
  /// `size` objects (1..64); `planes` mixes planes and halfspaces in.
  Pool(Source& src, Scene scene, int size, bool planes) : src_(src), scene_(scene) {
    scale_ = scene == Scene::huge ? 1e6 : scene == Scene::tiny ? 1e-6 : 1.0;
    for (int i = 0; i < size; ++i) objects_.push_back(makeObject(planes && src_.pick(6) == 0));
  }

  std::size_t size() const { return objects_.size(); }
  /// Any object of the pool, registered or not.
  Object* any() { return objects_[src_.pick(std::uint32_t(objects_.size()))].get(); }
  /// Up to `max_count` objects of the pool, repeats allowed.
  std::vector<Object*> some(std::uint32_t max_count) {
    std::vector<Object*> out(src_.pick(max_count + 1));
    for (auto& o : out) o = any();
    return out;
  }
  /// "p<index>", for traces and messages.
  std::string name(const Object* o) const {
    for (std::size_t i = 0; i < objects_.size(); ++i)
      if (objects_[i].get() == o) return "p" + std::to_string(i);
    return "?";
  }

  /// A new pose for `o` (its AABB recomputed).
  void setPose(Object* o) {
    fcl::Vector3<S> t(coord(), coord(), coord());
    if (scene_ == Scene::line) t[1] = t[2] = 0;
    fcl::Matrix3<S> r = fcl::Matrix3<S>::Identity();
    if (scene_ == Scene::identical) {
      // Two poses only, so that most objects are exactly alike.
      if (src_.pick(2)) r = Eigen::AngleAxis<S>(0.5, fcl::Vector3<S>::UnitZ()).toRotationMatrix();
    } else if (src_.pick(2)) {
      fcl::Vector3<S> axis(src_.unit() - 0.5, src_.unit() - 0.5, src_.unit() + 0.1);
      r = Eigen::AngleAxis<S>(src_.unit() * 6.28, axis.normalized()).toRotationMatrix();
    }
    o->setTransform(r, t);
    o->computeAABB();
  }

 private:
  double coord() {
    switch (scene_) {
      case Scene::one_point:
      case Scene::identical:
        return 0;
      case Scene::zero_size:
        return double(int(src_.pick(5)) - 2);  // a small grid: many coincident points
      default:
        return scale_ * (src_.unit() * 20 - 10);
    }
  }

  std::shared_ptr<fcl::CollisionGeometry<S>> geometry(bool plane) {
    if (plane) {
      fcl::Vector3<S> n = fcl::Vector3<S>::Unit(int(src_.pick(3)));
      if (src_.pick(2)) n = fcl::Vector3<S>(src_.unit() - 0.5, src_.unit() - 0.5, 1).normalized();
      const S d = scale_ * (src_.unit() * 10 - 5);
      if (src_.pick(2)) return std::make_shared<fcl::Plane<S>>(n, d);
      return std::make_shared<fcl::Halfspace<S>>(n, d);
    }
    if (scene_ == Scene::identical) {
      if (!shared_) shared_ = std::make_shared<fcl::Box<S>>(1, 2, 3);
      return shared_;
    }
    if (scene_ == Scene::zero_size) return std::make_shared<fcl::Box<S>>(0, 0, 0);
    const S a = scale_ * (0.5 + 3 * src_.unit());
    switch (src_.pick(3)) {
      case 0:
        return std::make_shared<fcl::Box<S>>(a, a * 0.7, a * 1.3);
      case 1:
        return std::make_shared<fcl::Sphere<S>>(a * 0.5);
      default:
        return std::make_shared<fcl::Cylinder<S>>(a * 0.4, a);
    }
  }

  std::unique_ptr<Object> makeObject(bool plane) {
    auto o = std::make_unique<Object>(geometry(plane));
    setPose(o.get());
    return o;
  }

  Source& src_;
  Scene scene_;
  double scale_ = 1;
  std::shared_ptr<fcl::CollisionGeometry<S>> shared_;
  std::vector<std::unique_ptr<Object>> objects_;
};

/// What the manager under test should hold: each registered object's AABB as it was when the
/// manager last read it, and the registration order.
class Model {
 public:
  const Boxes& boxes() const { return cached_; }
  const std::vector<Object*>& order() const { return order_; }
  const AABB& box(const Object* o) const { return cached_.at(o); }
  bool registered(const Object* o) const { return cached_.count(o) != 0; }
  /// Position in registration order (order().size() if not registered).
  int indexOf(const Object* o) const {
    return int(std::find(order_.begin(), order_.end(), o) - order_.begin());
  }

  /// registerObject: no effect on an object already registered.
  void add(Object* o) {
    if (registered(o)) return;
    cached_[o] = o->getAABB();
    order_.push_back(o);
  }
  void remove(Object* o) {
    if (!registered(o)) return;
    cached_.erase(o);
    order_.erase(std::find(order_.begin(), order_.end(), o));
  }
  /// update(o): the manager reads o's AABB if o is registered.
  void read(Object* o) {
    if (registered(o)) cached_[o] = o->getAABB();
  }
  /// update(): every registered object but `except` read again.
  void readAll(const Object* except = nullptr) {
    for (auto& c : cached_)
      if (c.first != except) c.second = c.first->getAABB();
  }
  void clear() {
    cached_.clear();
    order_.clear();
  }
  /// True when every cached AABB equals the object's live one (the narrow phase may be compared).
  bool inSync() const {
    for (const auto& c : cached_)
      if (!sameBox(c.second, c.first->getAABB())) return false;
    return true;
  }

 private:
  Boxes cached_;
  std::vector<Object*> order_;
};

}  // namespace diff
}  // namespace cube
