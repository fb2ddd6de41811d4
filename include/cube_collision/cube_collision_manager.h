#pragma once

#include <fcl/broadphase/broadphase_collision_manager.h>

#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "cube_collision/config.h"
#include "cube_collision/query_stats.h"

namespace cube {

namespace detail {
template <typename S>
class Broadphase;  // the core (src/core/broadphase.h), private to the library
}  // namespace detail

/// An FCL broadphase manager backed by the cube hierarchy: a tree of axis-aligned cuboids built
/// top-down by splitting every cube holding more than `Config::leaf_size` objects at the median
/// object along its longest side. A drop-in replacement for any
/// `fcl::BroadPhaseCollisionManager<S>`: the same callbacks are called for the same pairs.
///
/// Semantics (see the README for the full table):
/// - Candidate pairs are those whose cached AABBs overlap, touching included; a pair of an object
///   with itself is never reported.
/// - A callback returning true stops the whole query at once.
/// - collide(obj)/distance(obj) call callback(managed, obj); manager-vs-manager calls
///   callback(object of this manager, object of the other).
/// - Distance queries start with the largest value of S and prune with the `dist` the callback
///   writes back; pairs whose AABBs overlap are visited even when `dist` <= 0.
/// - Const queries change nothing: any number of threads may query one manager at once, as long
///   as no thread mutates it meanwhile.
///
/// Bad input: a null object or one whose AABB has a NaN throws std::invalid_argument and changes
/// nothing; registering a registered object, unregistering or updating an unknown one has no
/// effect. Objects with an infinite or enormous AABB (planes, halfspaces) are kept in a separate
/// list that every query tests, so they do not spoil the cubes.
///
/// Callbacks: a callback may run any const query, on this manager or another. A mutating call
/// (register, unregister, update, setup, clear) on a manager from inside a callback of one of
/// its own queries, on the query's thread, throws std::logic_error naming the call and changes
/// nothing; let it propagate and the query ends with it. For manager against manager, both
/// managers count as queried.
template <typename S>
class CubeCollisionManager final : public fcl::BroadPhaseCollisionManager<S> {
 public:
  using Object = fcl::CollisionObject<S>;
  using Base = fcl::BroadPhaseCollisionManager<S>;
  using Base::collide;
  using Base::distance;

  /// Creates an empty manager. Throws std::invalid_argument if a Config knob is out of range.
  explicit CubeCollisionManager(const Config& config = Config());
  /// Unregisters nothing and deletes no object: the objects stay the caller's.
  ~CubeCollisionManager() override;
  CubeCollisionManager(const CubeCollisionManager&) = delete;
  CubeCollisionManager& operator=(const CubeCollisionManager&) = delete;

  /// Registers a batch. Throws std::invalid_argument (registering nothing of the batch) if an
  /// entry is null or has a NaN AABB. Entries already registered, or repeated, are registered
  /// once. A batch at least as large as the manager triggers one full build.
  void registerObjects(const std::vector<Object*>& other_objs) override;
  /// Registers one object; its AABB is read from getAABB() now (computeAABB() is the caller's
  /// job). Throws std::invalid_argument for null or NaN; no effect if already registered.
  void registerObject(Object* obj) override;
  /// Removes an object; no effect if it is not registered.
  void unregisterObject(Object* obj) override;
  /// The first call (after construction or clear()) builds the hierarchy from scratch over the
  /// objects registered so far: the same objects always give the same tree. Later calls are
  /// cheap, as objects registered meanwhile are already in place; they rebuild only a degraded
  /// hierarchy (see Config::rebuild_threshold; with a forced update policy, after any insertion
  /// or removal). Idempotent. Queries are correct without it: it makes them faster.
  void setup() override;
  /// Re-reads every object's AABB and refits the cubes (rebuilds if the policy says so). Throws
  /// std::invalid_argument if an AABB is NaN; that object keeps its previous AABB, all others
  /// are updated.
  void update() override;
  /// Re-reads one object's AABB and refits the cubes above it. No effect if not registered.
  /// Throws std::invalid_argument (object unchanged) if its AABB is NaN.
  void update(Object* updated_obj) override;
  /// Same as update(obj) for each object; throws after updating all the valid ones.
  void update(const std::vector<Object*>& updated_objs) override;
  /// Unregisters everything.
  void clear() override;
  /// The registered objects, in registration order.
  void getObjects(std::vector<Object*>& objs) const override;

  /// Calls callback(managed, obj, cdata) for every managed object (other than obj itself) whose
  /// AABB overlaps obj's. Throws std::invalid_argument if obj is null or its AABB is NaN.
  void collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Branch and bound: calls callback(managed, obj, cdata, dist) nearest first while the AABB
  /// distance is below dist. Throws std::invalid_argument if obj is null or its AABB is NaN.
  void distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback) const override;
  /// Calls callback once for every unordered pair of managed objects whose AABBs overlap.
  void collide(void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Branch and bound over every unordered pair of managed objects.
  void distance(void* cdata, fcl::DistanceCallBack<S> callback) const override;
  /// Pairs (object of this, object of other) whose AABBs overlap. Works with any manager type;
  /// another cube manager is traversed tree against tree, others through getObjects().
  void collide(Base* other_manager, void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Distance between the objects of this manager and those of another, as collide(other).
  void distance(Base* other_manager, void* cdata, fcl::DistanceCallBack<S> callback) const override;

  // The six queries above, adding the work they do to `stats` (when not null). Same results and
  // callbacks as without; for tuning and for the benchmark's "box tests per object".

  /// collide(obj, cdata, callback), counting its work into `stats` (ignored if null).
  void collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback,
               QueryStats* stats) const;
  /// distance(obj, cdata, callback), counting its work into `stats` (ignored if null).
  void distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback,
                QueryStats* stats) const;
  /// Self-collide, counting its work into `stats` (ignored if null).
  void collide(void* cdata, fcl::CollisionCallBack<S> callback, QueryStats* stats) const;
  /// Self distance, counting its work into `stats` (ignored if null).
  void distance(void* cdata, fcl::DistanceCallBack<S> callback, QueryStats* stats) const;
  /// collide(other_manager, ...), counting its work into `stats` (ignored if null).
  void collide(Base* other_manager, void* cdata, fcl::CollisionCallBack<S> callback,
               QueryStats* stats) const;
  /// distance(other_manager, ...), counting its work into `stats` (ignored if null).
  void distance(Base* other_manager, void* cdata, fcl::DistanceCallBack<S> callback,
                QueryStats* stats) const;

  /// Self-collide with any callable `bool f(Object* a, Object* b)` (a lambda with captures, say);
  /// returning true stops the query, a callable returning void never stops. No std::function:
  /// the callable is called through one function pointer, like FCL's callbacks.
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(F&& f) const {
    collide(erase(f), &collideThunk<std::remove_reference_t<F>>);
  }
  /// collide(obj, ...) with a callable f(managed, obj).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(Object* obj, F&& f) const {
    collide(obj, erase(f), &collideThunk<std::remove_reference_t<F>>);
  }
  /// collide(other, ...) with a callable f(object of this, object of other).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(Base* other_manager, F&& f) const {
    collide(other_manager, erase(f), &collideThunk<std::remove_reference_t<F>>);
  }
  /// Self distance with a callable `bool f(Object* a, Object* b, S& dist)` that lowers dist to
  /// the pair's distance; returning true stops.
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(F&& f) const {
    distance(erase(f), &distanceThunk<std::remove_reference_t<F>>);
  }
  /// distance(obj, ...) with a callable f(managed, obj, dist).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(Object* obj, F&& f) const {
    distance(obj, erase(f), &distanceThunk<std::remove_reference_t<F>>);
  }
  /// distance(other, ...) with a callable f(object of this, object of other, dist).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(Base* other_manager, F&& f) const {
    distance(other_manager, erase(f), &distanceThunk<std::remove_reference_t<F>>);
  }

  /// True if no object is registered.
  bool empty() const override;
  /// Number of registered objects.
  size_t size() const override;

  /// The configuration the manager was made with.
  const Config& config() const;
  /// Checks every invariant of the object table, the cubes, the unbounded list and, when the
  /// pair list of Config::keep_pairs is in use, that it holds exactly the overlapping pairs; on
  /// failure returns false and, if `why` is given, says which.
  bool validate(std::string* why = nullptr) const;
  /// Heap bytes owned: the object table, the cubes, the pair list and update()'s scratch.
  std::size_t bytes() const;
  /// Whether the next self-collide is served from the pair list (Config::keep_pairs).
  bool pairsListed() const;
  /// The core behind the manager, for the library's inspection code and its tests; its type is
  /// defined in the library's private headers only.
  const detail::Broadphase<S>& core() const { return *core_; }

 private:
  template <class F>
  static void* erase(F& f) {
    return const_cast<void*>(static_cast<const void*>(std::addressof(f)));
  }
  template <class F>
  static bool collideThunk(Object* a, Object* b, void* f) {
    if constexpr (std::is_void_v<std::invoke_result_t<F&, Object*, Object*>>) {
      (*static_cast<F*>(f))(a, b);
      return false;
    } else {
      return static_cast<bool>((*static_cast<F*>(f))(a, b));
    }
  }
  template <class F>
  static bool distanceThunk(Object* a, Object* b, void* f, S& dist) {
    if constexpr (std::is_void_v<std::invoke_result_t<F&, Object*, Object*, S&>>) {
      (*static_cast<F*>(f))(a, b, dist);
      return false;
    } else {
      return static_cast<bool>((*static_cast<F*>(f))(a, b, dist));
    }
  }

  std::unique_ptr<detail::Broadphase<S>> core_;
};

using CubeCollisionManagerd = CubeCollisionManager<double>;
using CubeCollisionManagerf = CubeCollisionManager<float>;

extern template class CubeCollisionManager<double>;
extern template class CubeCollisionManager<float>;

}  // namespace cube
