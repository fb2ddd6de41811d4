#pragma once

// The way from a CubeCollisionManager to its core, for the library's own code (the adapter's
// helpers, queries over the core, inspection) and for white-box tests. Private to the library:
// the public header declares the struct a friend and nothing more.

#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"

namespace cube {
namespace detail {

struct ManagerAccess {
  /// The manager's core.
  template <typename S>
  static const Broadphase<S>& core(const CubeCollisionManager<S>& manager) {
    return *manager.core_;
  }
};

/// The manager's core (ManagerAccess::core).
template <typename S>
const Broadphase<S>& coreOf(const CubeCollisionManager<S>& manager) {
  return ManagerAccess::core(manager);
}

}  // namespace detail
}  // namespace cube
