#pragma once

#include <fcl/broadphase/broadphase_collision_manager.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cube_collision/callable.h"
#include "cube_collision/config.h"
#include "cube_collision/query_stats.h"

namespace cube {

namespace detail {
template <typename S>
class Broadphase;      // the core (src/core/broadphase.h), private to the library
struct ManagerAccess;  // the library's and tests' way to the core (src/adapter/manager_access.h)
}  // namespace detail

/// A drop-in fcl::BroadPhaseCollisionManager<S> backed by a cube hierarchy (axis-aligned cuboids
/// split at the median object): the same callbacks for the same pairs. Touching AABBs count, an
/// object never pairs with itself, a callback's true stops the query, const queries are
/// thread-safe, bad input (null, NaN AABB) throws std::invalid_argument and changes nothing (a
/// query against an empty manager reads no object, so a NaN there goes unseen: see collide(obj)).
/// Full contract, callbacks that mutate included: docs/guarantees.md.
template <typename S>
class CubeCollisionManager final : public fcl::BroadPhaseCollisionManager<S> {
 public:
  using Object = fcl::CollisionObject<S>;
  using Base = fcl::BroadPhaseCollisionManager<S>;
  using Base::collide;
  using Base::distance;

  /// An empty manager. Throws std::invalid_argument if a Config knob is out of range.
  explicit CubeCollisionManager(const Config& config = Config());
  /// Unregisters nothing and deletes no object: the objects stay the caller's.
  ~CubeCollisionManager() override;
  CubeCollisionManager(const CubeCollisionManager&) = delete;
  CubeCollisionManager& operator=(const CubeCollisionManager&) = delete;

  /// Registers each entry not yet registered, once. A null entry, or an unregistered one with a
  /// NaN AABB, throws and registers none; the message names the first null entry if there is
  /// one, else the first NaN one.
  void registerObjects(const std::vector<Object*>& other_objs) override;
  /// Registers obj with its getAABB() of now. Throws if null or NaN; no effect if registered.
  void registerObject(Object* obj) override;
  /// Removes obj; no effect if it is not registered.
  void unregisterObject(Object* obj) override;
  /// Optional and idempotent: builds the hierarchy (the first call with objects registered; on a
  /// manager that has never held one it does nothing), later rebuilds a degraded one.
  void setup() override;
  /// Re-reads every AABB and refits; a NaN AABB throws once the others are updated (its own not).
  void update() override;
  /// Re-reads obj's AABB; no effect if not registered. Throws (obj unchanged) if it is NaN.
  void update(Object* updated_obj) override;
  /// update(obj) for each object; throws after updating all the valid ones.
  void update(const std::vector<Object*>& updated_objs) override;
  /// Unregisters everything.
  void clear() override;
  /// The registered objects, in registration order.
  void getObjects(std::vector<Object*>& objs) const override;

  /// callback(managed, obj, cdata) for each other managed object whose AABB overlaps obj's. On
  /// an empty manager it returns without reading obj (a NaN AABB goes undetected there; a null
  /// obj or callback still throws).
  void collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Branch and bound: callback(managed, obj, cdata, dist), nearest first, pruning on dist. On
  /// an empty manager, as collide(obj).
  void distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback) const override;
  /// callback once for each unordered pair of managed objects whose AABBs overlap. Takes up to
  /// about 100 KB of the calling thread's stack (scenes of 256 to about 4,000 objects keep
  /// their float bounds there), besides what the callback takes.
  void collide(void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Branch and bound over every unordered pair of managed objects.
  void distance(void* cdata, fcl::DistanceCallBack<S> callback) const override;
  /// callback(object of this, object of other) for overlapping AABBs; any manager type. If this
  /// manager is empty, the other's objects are not read.
  void collide(Base* other_manager, void* cdata, fcl::CollisionCallBack<S> callback) const override;
  /// Distance between this manager's objects and other's, as collide(other).
  void distance(Base* other_manager, void* cdata, fcl::DistanceCallBack<S> callback) const override;

  /// The six queries above, each also adding its work to `*stats` (if not null); same results.
  ///@{
  void collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback,
               QueryStats* stats) const;
  void distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback,
                QueryStats* stats) const;
  void collide(void* cdata, fcl::CollisionCallBack<S> callback, QueryStats* stats) const;
  void distance(void* cdata, fcl::DistanceCallBack<S> callback, QueryStats* stats) const;
  void collide(Base* other_manager, void* cdata, fcl::CollisionCallBack<S> callback,
               QueryStats* stats) const;
  void distance(Base* other_manager, void* cdata, fcl::DistanceCallBack<S> callback,
                QueryStats* stats) const;
  ///@}

  /// Self-collide with a callable f(Object* a, Object* b) returning bool (true stops) or void.
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(F&& f) const {
    collide(callable::erase(f), &callable::collideThunk<S, F>);
  }
  /// collide(obj, ...) with a callable f(managed, obj).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(Object* obj, F&& f) const {
    collide(obj, callable::erase(f), &callable::collideThunk<S, F>);
  }
  /// collide(other, ...) with a callable f(object of this, object of other).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*>>>
  void collide(Base* other_manager, F&& f) const {
    collide(other_manager, callable::erase(f), &callable::collideThunk<S, F>);
  }
  /// Self distance with a callable f(Object* a, Object* b, S& dist) lowering dist; true stops.
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(F&& f) const {
    distance(callable::erase(f), &callable::distanceThunk<S, F>);
  }
  /// distance(obj, ...) with a callable f(managed, obj, dist).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(Object* obj, F&& f) const {
    distance(obj, callable::erase(f), &callable::distanceThunk<S, F>);
  }
  /// distance(other, ...) with a callable f(object of this, object of other, dist).
  template <class F, class = std::enable_if_t<std::is_invocable_v<F&, Object*, Object*, S&>>>
  void distance(Base* other_manager, F&& f) const {
    distance(other_manager, callable::erase(f), &callable::distanceThunk<S, F>);
  }

  /// Filter bits of a registered object (as Box2D, Bullet and Jolt): a pair reaches a callback
  /// only if (a.category & b.mask) != 0 and (b.category & a.mask) != 0. Default: category 1,
  /// mask all ones. O(1); applies to every query from the next one on, pair list included.
  /// Query objects not registered here have the default bits. Unregistering an object forgets
  /// its bits (and its own margin): registered again, it has the defaults. Throws
  /// std::invalid_argument (nothing changed) if obj is null or not registered.
  void setFilter(Object* obj, std::uint64_t category, std::uint64_t mask);
  /// {category, mask} of obj; the default bits for an object not registered here.
  std::pair<std::uint64_t, std::uint64_t> filter(const Object* obj) const;
  /// A predicate asked for each pair whose bits pass, before the callback is called for it (a
  /// collision matrix, say): false drops the pair. In collide queries, the pairs whose boxes
  /// overlap; in distance queries, every pair the branch and bound would hand to the callback,
  /// whose boxes need not overlap. Called as keep(a, b) with the callback's argument order, from
  /// the querying thread: concurrent const queries call it concurrently. An empty function
  /// removes it.
  void setPairFilter(std::function<bool(Object*, Object*)> keep);
  /// Registered objects a and b never pair (`excluded` true), or pair again (false; no effect
  /// if they were not excluded): from the next query on, no query of this manager reports the
  /// pair or calls the pair filter or a callback for it (self, object, manager against manager,
  /// distance, the pair list, and the queries of queries.h, continuous.h and batch.h built on
  /// them). The exclusion is kept through update(), setup() and rebuilds, and forgotten when
  /// either object is unregistered (registered again, it is excluded from nothing). A query
  /// object registered here brings its exclusions; against another CubeCollisionManager a pair
  /// is dropped if either manager excludes it. O(1) on average; managers that exclude nothing
  /// keep no memory for it. Throws std::invalid_argument (nothing changed) if a or b is null,
  /// either is not registered, or a == b; std::logic_error from inside one of this manager's
  /// query callbacks.
  void excludePair(Object* a, Object* b, bool excluded = true);
  /// Whether excludePair(a, b) is in force: false unless a and b are two registered objects.
  bool isExcluded(const Object* a, const Object* b) const;
  /// Every excluded pair, each as (earlier registered, later registered), sorted by the
  /// registration order of the first, then of the second.
  std::vector<std::pair<Object*, Object*>> excludedPairs() const;
  /// Whether this manager's queries hand the pair (a, b) to their callback when the two AABBs,
  /// each grown by its margin, overlap: the rules above, decided where the queries decide them
  /// (for a narrow phase of one's own over pairs found elsewhere, as Box2D's
  /// b2ShouldShapesCollide). `a` is an object registered here (the callbacks' first object);
  /// `b`, the second, is looked for as the queries look for it:
  /// - `other` null or this manager: b registered here is a pair of the self query (collide());
  ///   b not registered here is a query object of collide(b), with the default bits and in no
  ///   excluded pair;
  /// - `other` another CubeCollisionManager<S>: b registered there, as collide(other) pairs it:
  ///   b's bits are other's, and the pair is dropped if either manager excludes it;
  /// - `other` a manager of another kind: b is a query object here, as collide(other) pairs
  ///   its objects (its bits and exclusions this manager's if registered here, else none).
  /// True if the filter bits pass, the pair is not excluded, and then this manager's pair
  /// filter (if set) keeps it, asked once as the queries ask it: keep(a, b), or, for two objects
  /// registered here under Config::canonical_pairs, keep(earlier registered, later registered).
  /// False, with nothing asked, if a == b, a is not registered here, or b is not registered in
  /// another CubeCollisionManager `other`. O(1) on average, the pair filter's call aside.
  /// Thread-safe as the const queries are; the pair filter runs on the calling thread and may
  /// not change this manager (or `other`): std::logic_error, as from a query's callback.
  /// Throws std::invalid_argument if a or b is null.
  bool pairPasses(Object* a, Object* b, const Base* other = nullptr) const;
  /// Manager-wide margin (>= 0, finite), for every object without one of its own and for query
  /// objects not registered here: queries report the pairs whose AABBs overlap once each is
  /// grown by its margin. Between managers: against another CubeCollisionManager, each side's
  /// objects are grown by their own manager's margins; against any other manager, its objects
  /// are query objects here, grown by this manager's manager-wide margin. Re-reads every AABB
  /// (as update()). Throws std::invalid_argument (nothing changed) for a negative, infinite or
  /// NaN margin.
  void setMargin(S margin);
  /// obj's own margin (>= 0, finite), kept until obj is unregistered; re-reads obj's AABB (as
  /// update(obj)). Throws std::invalid_argument (nothing changed) if obj is null, not
  /// registered, or the margin bad.
  void setMargin(Object* obj, S margin);
  /// The margin obj's AABB is grown by: its own, else the manager-wide one.
  S margin(const Object* obj) const;

  /// True if no object is registered.
  bool empty() const override;
  /// Number of registered objects.
  size_t size() const override;
  /// The configuration the manager was made with.
  const Config& config() const;
  /// Checks the table, cubes, unbounded list and pair list; false (and `why`) if one is broken.
  bool validate(std::string* why = nullptr) const;
  /// Heap bytes owned: the object table, the cubes, the pair list and update()'s scratch.
  std::size_t bytes() const;
  /// Whether the next self-collide is served from the pair list (Config::keep_pairs).
  bool pairsListed() const;
  /// Frees the per-object volumes of Config::tight_volumes, which the first query of the
  /// pipeline (queries.h, batch.h, Config::cull_pairs) builds and every update keeps from then
  /// on; the next such query builds them again. Answers are the same with or without them.
  /// Throws std::logic_error from inside one of this manager's queries.
  void dropVolumes();

 private:
  friend struct detail::ManagerAccess;
  std::unique_ptr<detail::Broadphase<S>> core_;
};

using CubeCollisionManagerd = CubeCollisionManager<double>;
using CubeCollisionManagerf = CubeCollisionManager<float>;

extern template class CubeCollisionManager<double>;
extern template class CubeCollisionManager<float>;

}  // namespace cube
