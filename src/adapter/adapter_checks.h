#pragma once

// The adapter's input checks, shared by its mutations (cube_collision_manager.cpp) and its queries
// (manager_queries.cpp): an FCL object's AABB as the core's box, and the errors they throw.

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/broadphase.h"
#include "core/kernels/box_ops.h"

namespace cube {
namespace detail {
namespace adapter {

using detail::Box;

template <typename S>
Box<S> boxOf(const fcl::CollisionObject<S>& obj) {
  const fcl::AABB<S>& a = obj.getAABB();
  Box<S> b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = a.min_[k];
    b.hi[k] = a.max_[k];
  }
  return b;
}

// No NaN coordinate: only then does a box equal itself (box_ops's compare, a few SIMD
// instructions on every query's box).
template <typename S>
bool isValid(const Box<S>& b) {
  return detail::sameBox(b, b);
}

[[noreturn]] inline void fail(const char* where, const std::string& what) {
  throw std::invalid_argument(std::string("cube::CubeCollisionManager::") + where + ": " + what);
}

template <typename S>
std::string indexName(const detail::Broadphase<S>& core, const fcl::CollisionObject<S>* obj) {
  std::vector<fcl::CollisionObject<S>*> all;
  core.objects(all);
  const auto it = std::find(all.begin(), all.end(), obj);
  return "object #" + std::to_string(it - all.begin()) + " (in getObjects() order)";
}

template <typename S>
Box<S> checkedQueryBox(const fcl::CollisionObject<S>* obj, const char* where) {
  if (obj == nullptr) fail(where, "null query object");
  const Box<S> b = boxOf(*obj);
  if (!isValid(b)) fail(where, "the query object's AABB has a NaN coordinate");
  return b;
}

}  // namespace adapter
}  // namespace detail
}  // namespace cube
