#pragma once

// What the query files (collide.cpp, distance.cpp, spatial.cpp, fcl_hooks.cpp) share: names in
// results, the managers' read locks, distances. Each query converts its input with the GIL, then
// releases it and holds the manager's lock shared while C++ runs, and builds Python objects after.

#include <fcl/narrowphase/distance_result.h>

#include <limits>
#include <mutex>
#include <shared_mutex>
#include <string>

#include "manager.h"

namespace cubepy {

constexpr const char* kExternal = "__external";  // trimesh's name for a query geometry

using ObjPtr = fcl::CollisionObjectd*;

inline std::string nameOf(const fcl::CollisionObjectd* o) {
  const Entry* e = Manager::entryOf(o);
  return e ? e->name : kExternal;
}

// Asks for the cache line at p (a read soon): no effect on what the program does.
inline void prefetch(const void* p) {
  __builtin_prefetch(p);
}

// Where an object's user data lies: the last member of FCL 0.7's CollisionObject.
inline const void* userDataLine(const fcl::CollisionObjectd* o) {
  return reinterpret_cast<const char*>(o) + sizeof(fcl::CollisionObjectd) - sizeof(void*);
}

// A name in a result: an entry's (read under the manager's lock, which keeps the entry), or
// kExternal for null (the query geometry). nameStr orders, pyName is what Python gets.
inline const std::string& nameStr(const Entry* e) {
  static const std::string external = kExternal;
  return e ? e->name : external;
}
inline py::object pyName(const Entry* e) {
  return e ? e->pyname : py::str(kExternal);
}

/// Shared locks on one or two managers (in address order), taken with the GIL released.
struct ReadLocks {
  std::shared_lock<std::shared_mutex> a, b;
  ReadLocks(const Manager& x, const Manager* y = nullptr) {
    const Manager* first = &x;
    const Manager* second = y == &x ? nullptr : y;
    if (second && second < first) std::swap(first, second);
    a = std::shared_lock(first->mutex);
    if (second) b = std::shared_lock(second->mutex);
  }
};

/// Which query a result answers: names are sorted (internal), single, or (here, there).
enum class Kind { internal, single, other };

/// The smallest distance found, with its objects' names, nearest points and FCL's primitive
/// indices (b1, b2) in the order of a, b.
struct DistOut {
  double distance = std::numeric_limits<double>::infinity();
  std::string a, b;
  fcl::Vector3d pa = fcl::Vector3d::Zero(), pb = fcl::Vector3d::Zero();
  intptr_t ba = -1, bb = -1;
  bool found = false;
};

/// The smallest distance between m's objects (query and other null), from a query object, or
/// to another manager's objects (either backend): the library's minimumDistance on the
/// managers' broadphases. Called with the GIL released under the managers' read locks.
DistOut distance(const Manager& m, ObjPtr query, const Manager* other, bool points);

}  // namespace cubepy
