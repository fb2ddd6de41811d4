#pragma once

// The Python manager: named objects over a broadphase (the cube manager, or FCL's dynamic AABB
// tree under the same pair rules for backend="fcl", fcl_backend.h). The objects' filter bits,
// margins and excluded pairs live in one rules object, a cube manager (the broadphase itself, or
// the FCL backend's): queries and pickling read them there.

#include <cube_collision/cube_collision_manager.h>
#include <fcl/narrowphase/collision_object.h>

#include <memory>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "common.h"
#include "fcl_backend.h"

namespace cubepy {

/// An FCL object whose AABB can be grown by a margin (FCL's tree reads the grown box).
class Object : public fcl::CollisionObjectd {
 public:
  Object(const std::shared_ptr<fcl::CollisionGeometryd>& g, const fcl::Transform3d& tf)
      : fcl::CollisionObjectd(g, tf) {
    setUserData(nullptr);  // FCL leaves it uninitialised; null marks a query object
  }
  /// computeAABB(), then the box grown by `pad` on every side.
  void refresh(double pad) {
    computeAABB();
    if (pad > 0) {
      aabb.min_ -= fcl::Vector3d::Constant(pad);
      aabb.max_ += fcl::Vector3d::Constant(pad);
    }
  }
};

/// An unknown object name. Python gets cube_collision.UnknownNameError, both a KeyError (this
/// package's word) and a ValueError (trimesh's).
class UnknownName : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The geometry argument of a call that also takes trimesh's keyword `mesh`: whichever of the two
/// is given. TypeError if both or neither are.
inline py::handle geometryArg(py::handle geometry, py::handle mesh, const char* what) {
  if (geometry.is_none() == mesh.is_none())
    throw py::type_error(std::string(what) +
                         (geometry.is_none() ? ": give the geometry (or trimesh's keyword mesh=)"
                                             : ": give the geometry or mesh=, not both"));
  return geometry.is_none() ? mesh : geometry;
}

/// ValueError unless m is finite and >= 0.
void checkMargin(double m);

/// A name argument as a std::string. TypeError if it is not a str.
std::string nameOfArg(py::handle h);

/// One named object.
struct Entry {
  std::string name;
  /// The name as a Python str, made once (with the GIL, in add) for every result that names the
  /// object. Dropped only with the GIL held: remove() keeps a removed entry until it has the GIL.
  py::object pyname;
  std::uint64_t seq = 0;  ///< registration number: order of names, pickling, ties
  GeometryPtr geometry;   ///< what the user gave (its FCL geometry may be cloned into obj)
  std::unique_ptr<Object> obj;
  /// Whether set_margin(name=) gave it a margin of its own (the rules object keeps the value;
  /// it answers an object's margin, not whether it is its own, which pickling keeps).
  bool own_margin = false;
};

/// Reads or writes on a manager from any Python thread: queries take it shared, mutations
/// exclusive, each with the GIL released while it waits and works.
class Manager {
 public:
  Manager(const std::string& backend, int threads);
  ~Manager();

  bool isCube() const { return cube_ != nullptr; }
  const std::string& backend() const { return backend_; }
  int threads() const { return threads_; }

  // Mutations: arguments are checked first (with the GIL); nothing changes on a bad one.
  /// An object to add: its own margin < 0 means none.
  struct NewObject {
    std::string name;
    GeometryPtr geometry;
    fcl::Transform3d tf;
    std::uint64_t category = 1, mask = ~std::uint64_t(0);
    double margin = -1;
  };
  /// Adds every object in one registration (one build of the tree), or none if one is bad.
  void add(std::vector<NewObject> objects, const char* what);
  void remove(const std::string& name);
  void setTransforms(const std::vector<std::string>& names,
                     const std::vector<fcl::Transform3d>& tfs);
  void setFilter(const std::string& name, std::uint64_t category, std::uint64_t mask);
  /// Excludes the pair (never tested or reported), or includes it again (`on` false); `where`
  /// names the Python call in errors.
  void excludePair(const std::string& a, const std::string& b, bool on, const char* where);
  void clearExcluded(const char* where);
  void setMargin(double margin, const std::string* name);

  // Reads (callers hold the shared lock, or the GIL with no query running).
  Entry* find(const std::string& name) const;  ///< UnknownName if unknown
  std::vector<const Entry*> ordered() const;   ///< by registration
  static Entry* entryOf(const fcl::CollisionObjectd* o) {
    return static_cast<Entry*>(o->getUserData());
  }
  /// The name of the object whose (possibly cloned) FCL geometry is g, or null.
  const Entry* byGeometry(const fcl::CollisionGeometryd* g) const;
  /// {category, mask} of an object, as the rules object keeps them.
  std::pair<std::uint64_t, std::uint64_t> filterOf(const Entry& e) const;
  /// An object's margin (its own, else the manager-wide one); null: the manager-wide one.
  double marginOf(const Entry* e) const;
  bool anyMargin() const { return managerMargin() > 0 || own_margins_ > 0; }
  double managerMargin() const { return marginOf(nullptr); }
  std::size_t size() const { return entries_.size(); }
  /// Objects whose geometry is a mesh (FCL's BVH: many contacts per pair).
  std::size_t meshes() const { return meshes_; }
  std::size_t planes() const { return planes_; }
  std::size_t convexes() const { return convexes_; }
  std::vector<std::pair<std::string, std::string>> excludedPairs() const;
  /// Whether the queries over this manager's own pairs hand the pair of objects a and b on once
  /// their boxes (grown by their margins) overlap: the rules object's pairPasses (filter bits,
  /// excluded pairs). False for a == b. UnknownName for an unknown name (a's first).
  bool pairPasses(const std::string& a, const std::string& b) const;

  fcl::BroadPhaseCollisionManagerd& broadphase() const { return *bp_; }
  cube::CubeCollisionManagerd* cube() const { return cube_; }
  /// The rules object: the cube manager that keeps the objects' filter bits, margins and
  /// excluded pairs (the broadphase itself, or the FCL backend's).
  cube::CubeCollisionManagerd& rules() const { return cube_ ? *cube_ : fcl_->rules(); }

  mutable std::shared_mutex mutex;

 private:
  /// Sets obj's own margin (obj non-null) or the manager-wide one, growing the broadphase's
  /// boxes: the rules object's setMargin, through the FCL backend for its tree.
  void applyMargin(fcl::CollisionObjectd* obj, double margin);

  std::string backend_;
  int threads_;
  std::unique_ptr<fcl::BroadPhaseCollisionManagerd> bp_;
  cube::CubeCollisionManagerd* cube_ = nullptr;  // one of the two: bp_
  FclBackend* fcl_ = nullptr;
  std::unordered_map<std::string, std::unique_ptr<Entry>> entries_;
  std::unordered_map<const fcl::CollisionGeometryd*, Entry*> by_geometry_;
  std::size_t own_margins_ = 0;
  std::size_t meshes_ = 0, planes_ = 0, convexes_ = 0;
  std::uint64_t next_seq_ = 0;
};

/// FCL 0.7 crashes (segmentation fault) in fcl::distance with a plane, and in fcl::collide between
/// a plane and a convex: ValueError instead, before any work. `kinds` are those a query brings
/// besides the managers' (a query geometry, a body's links); `distance`: the query computes
/// distances, refused with a plane when an 'fcl'-backend manager (or none) takes part (the
/// library answers a distance to a plane in closed form; FCL's own managers crash).
void refuseFclCrashes(const Manager* a, const Manager* b, const std::vector<std::string>& kinds,
                      bool distance, const char* what);

/// Set while this thread holds a manager's read lock and may run Python code (a callback of a
/// private benchmark hook, or a __del__ set off by an allocation while a query or pickling builds
/// its result): mutations then raise instead of waiting for a lock the thread itself holds.
extern thread_local int in_python_callback;

/// Marks this thread as in_python_callback for its lifetime, and restores the count on every
/// exit, an exception included.
class CallbackScope {
 public:
  CallbackScope() { ++in_python_callback; }
  ~CallbackScope() { --in_python_callback; }
  CallbackScope(const CallbackScope&) = delete;
  CallbackScope& operator=(const CallbackScope&) = delete;
};

}  // namespace cubepy

namespace cubepy {
using ManagerClass = py::class_<Manager, std::shared_ptr<Manager>>;
/// The manager's calls by file: mutations and pickling (manager_binding.cpp), collision queries
/// (collide.cpp), distances (distance.cpp), rays and regions (spatial.cpp), the python-fcl
/// layer's hooks (fcl_hooks.cpp), the batched checks (batch.cpp).
void bindCollideQueries(ManagerClass& cls);
void bindDistanceQueries(ManagerClass& cls);
void bindSpatialQueries(ManagerClass& cls);
void bindFclHooks(ManagerClass& cls);
void bindManagerBatch(ManagerClass& cls);
/// Module-level pair calls (pair_in_collision, the python-fcl layer's collide / distance).
void bindPairCalls(py::module_& m);
}  // namespace cubepy
