// The one-call queries of include/cube_collision/queries.h over any FCL manager: its collide and
// distance walks (a cube manager's own, with ids, through adapter/manager_walks.h) feeding the
// narrow-phase pipeline's streams.

#include <algorithm>
#include <atomic>
#include <stdexcept>

#include "adapter/manager_access.h"
#include "adapter/manager_walks.h"
#include "adapter/query_guard.h"
#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "pipeline/collide_stream.h"
#include "pipeline/distance_search.h"

namespace cube {

namespace {

template <typename S>
bool collectPair(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* out) {
  static_cast<std::vector<ObjectPair<S>>*>(out)->emplace_back(a, b);
  return false;
}

}  // namespace

template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager) {
  std::vector<ObjectPair<S>> out;
  manager.collide(&out, &collectPair<S>);
  return out;
}

template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager,
                                            fcl::CollisionObject<S>* obj) {
  std::vector<ObjectPair<S>> out;
  manager.collide(obj, &out, &collectPair<S>);
  return out;
}

template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager,
                                            fcl::BroadPhaseCollisionManager<S>& other) {
  std::vector<ObjectPair<S>> out;
  manager.collide(&other, &out, &collectPair<S>);
  return out;
}

namespace {

// manager.collide(data, fn); with `split`, our manager walks a large scene on `threads` threads,
// calling fn on this thread with the same pairs in the same order. Any other manager walks as it
// walks.
template <typename S>
void selfWalk(const fcl::BroadPhaseCollisionManager<S>& manager, void* data,
              fcl::CollisionCallBack<S> fn, int threads, bool split) {
  const auto* cube = split ? dynamic_cast<const CubeCollisionManager<S>*>(&manager) : nullptr;
  if (cube != nullptr)
    detail::collideSelfOnThreads(*cube, data, fn, threads > 0 ? threads : hardwareThreads());
  else
    manager.collide(data, fn);
}

// FCL's default callback with culling (callbacks.h), counting the pairs it is handed.
template <typename S>
struct CountedCollide {
  CollisionData<S> data;
  std::size_t candidates = 0;
  std::vector<ObjectPair<S>>* colliding = nullptr;  // NarrowPhaseOptions::colliding
  static bool fn(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* self) {
    auto& c = *static_cast<CountedCollide*>(self);
    ++c.candidates;
    const std::size_t before = c.data.result.numContacts();
    const bool stop = defaultCollisionCallback<S>(a, b, &c.data);
    if (c.colliding != nullptr && c.data.result.numContacts() > before)
      c.colliding->emplace_back(a, b);
    return stop;
  }
};

// The stream's callbacks for walks that give ids.
template <typename S>
detail::CollideFn<S> collideIds() {
  return detail::CollideFn<S>(&detail::CollideStream<S>::callbackWithIds);
}
template <typename S>
detail::DistanceFn<S> distanceIds() {
  return detail::DistanceFn<S>(&detail::DistanceSearch<S>::callbackWithIds);
}

// The stream's walk through a cube manager: with ids, so that the cull reads the object tables'
// volumes (a stale record, kVolumeRebuildMinObjects, leaves its pairs to the cull from the
// objects). False (nothing done) for any other kind of manager, or with
// Config::tight_volumes off.
template <typename S, class Stream, class Fn, class Run>
bool walkWithIds(const fcl::BroadPhaseCollisionManager<S>& manager,
                 const fcl::BroadPhaseCollisionManager<S>* other, Stream& stream, Fn fn,
                 Run&& run) {
  const auto* cube = dynamic_cast<const CubeCollisionManager<S>*>(&manager);
  if (cube == nullptr) return false;
  if (!detail::coreOf(*cube).config().tight_volumes) return false;
  const auto& mine = detail::coreOf(*cube).table();
  // Side b: the same table (self), another cube manager's, or objects of no table (ids kNone).
  const auto* theirs =
      other == &manager ? cube : dynamic_cast<const CubeCollisionManager<S>*>(other);
  const auto* table_b = theirs != nullptr ? &detail::coreOf(*theirs).table() : nullptr;
  mine.wantVolumes();
  if (table_b != nullptr) table_b->wantVolumes();
  stream.volumes().use(
      mine.spheres(), mine.shapes(), table_b != nullptr ? table_b->spheres() : nullptr,
      table_b != nullptr ? table_b->shapes() : nullptr,
      mine.size() + (table_b != nullptr && table_b != &mine ? table_b->size() : 0));
  run(*cube, static_cast<void*>(&stream), fn);
  return true;
}

// Requests whose costs or cached GJK guess travel from pair to pair through the one result run
// the default callback, which accumulates as FCL does. Others run the pipeline, with the same
// answer: through id_walk where it walks (a cube manager), else through walk.
template <typename S, class Walk, class IdWalk>
fcl::CollisionResult<S> collideWith(const fcl::CollisionRequest<S>& request,
                                    const NarrowPhaseOptions<S>& options, const Walk& walk,
                                    const IdWalk& id_walk) {
  if (request.enable_cost || request.enable_cached_gjk_guess) {
    CountedCollide<S> c;
    c.data.request = request;
    c.colliding = options.colliding;
    if (c.colliding != nullptr) c.colliding->clear();
    walk(&c, &CountedCollide<S>::fn);
    if (NarrowPhaseStats* st = options.stats) {
      st->candidate_pairs += c.candidates;
      st->narrow_calls += c.data.narrow_calls;
      if (!request.enable_cost)  // with costs nothing is culled
        st->culled += c.candidates - c.data.narrow_calls;
    }
    return c.data.result;
  }
  if (options.last_hit_first && options.cache != nullptr) {
    const ObjectPair<S> hit = detail::CollideStream<S>::lastHit(*options.cache);
    if (hit.first != nullptr) {
      // Only a candidate of this query may come first: gather them all, move it to the front
      // (in the orientation this walk gives it) and answer it alone before the others.
      std::vector<ObjectPair<S>> pairs;
      walk(&pairs, &collectPair<S>);
      const ObjectPair<S> swapped(hit.second, hit.first);
      const auto it = std::find_if(pairs.begin(), pairs.end(), [&](const ObjectPair<S>& p) {
        return p == hit || p == swapped;
      });
      detail::CollideStream<S> stream(request, options);
      bool done = false;
      if (it != pairs.end()) {
        std::rotate(pairs.begin(), it, it + 1);
        done = stream.pushAlone(pairs.front().first, pairs.front().second);
      }
      for (std::size_t i = it != pairs.end(); i < pairs.size() && !done; ++i)
        done = stream.push(pairs[i].first, pairs[i].second);
      return stream.finish();
    }
  }
  detail::CollideStream<S> stream(request, options);
  if (!id_walk(stream)) walk(&stream, &detail::CollideStream<S>::callback);
  return stream.finish();
}

template <typename S, class Walk, class IdWalk>
fcl::DistanceResult<S> distanceWith(const fcl::DistanceRequest<S>& request,
                                    const NarrowPhaseOptions<S>& options, const Walk& walk,
                                    const IdWalk& id_walk) {
  detail::DistanceSearch<S> search(request, options);
  if (!id_walk(search)) walk(&search, &detail::DistanceSearch<S>::callback);
  return search.finish();
}

}  // namespace

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(
      request, options,
      [&](void* data, fcl::CollisionCallBack<S> f) {
        selfWalk(manager, data, f, options.threads, options.split_walk);
      },
      [&](detail::CollideStream<S>& stream) {
        // A self query: both ids index the manager's table.
        return walkWithIds(
            manager, &manager, stream, collideIds<S>(), [&](const auto& cube, void* data, auto fn) {
              // A large scene's walk split into tasks, each answered on the thread that walked
              // it; else the walk on this thread feeds the stream pair by pair.
              if (stream.takesTasks() && detail::collideSelfInTasks(cube, stream, stream.threads()))
                return;
              if (options.split_walk)
                detail::collideSelfOnThreadsWithIds(
                    cube, data, fn, options.threads > 0 ? options.threads : hardwareThreads());
              else
                detail::collideWithIds(cube, data, fn);
            });
      });
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::CollisionObject<S>* obj,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(
      request, options,
      [&](void* data, fcl::CollisionCallBack<S> f) { manager.collide(obj, data, f); },
      [&](detail::CollideStream<S>& stream) {
        return walkWithIds<S>(manager, nullptr, stream, collideIds<S>(),
                              [&](const auto& cube, void* data, auto fn) {
                                detail::collideWithIds(cube, obj, data, fn);
                              });
      });
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::BroadPhaseCollisionManager<S>& other,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(
      request, options,
      [&](void* data, fcl::CollisionCallBack<S> f) { manager.collide(&other, data, f); },
      [&](detail::CollideStream<S>& stream) {
        return walkWithIds(manager, &other, stream, collideIds<S>(),
                           [&](const auto& cube, void* data, auto fn) {
                             detail::collideWithIds(cube, &other, data, fn);
                           });
      });
}

namespace {

// collideConcurrently's state: the chunk gathered from the walk and the stop flag. `core`: the
// cube manager's core, named by a query guard on whichever thread runs the callback (a worker
// thread has no frame of the walk's), so that a mutation from the callback is refused there too.
template <typename S>
struct ConcurrentCalls {
  void* cdata;
  fcl::CollisionCallBack<S> callback;
  int threads;
  const void* core;
  std::vector<ObjectPair<S>> chunk;
  std::atomic<bool> stop{false};

  void flush() {
    forEachPair<S>(
        chunk,
        [this](std::size_t, fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
          if (stop.load(std::memory_order_relaxed)) return;
          const detail::QueryScope scope(core);
          if (callback(a, b, cdata)) stop.store(true, std::memory_order_relaxed);
        },
        threads);
    chunk.clear();
  }
  static bool gather(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* self) {
    auto& c = *static_cast<ConcurrentCalls*>(self);
    c.chunk.emplace_back(a, b);
    if (c.chunk.size() >= 256) c.flush();
    return c.stop.load(std::memory_order_relaxed);
  }
};

}  // namespace

template <typename S>
void collideConcurrently(const fcl::BroadPhaseCollisionManager<S>& manager, void* cdata,
                         fcl::CollisionCallBack<S> callback, int threads, bool split_walk) {
  if (callback == nullptr) throw std::invalid_argument("cube::collideConcurrently: null callback");
  const auto* cube = dynamic_cast<const CubeCollisionManager<S>*>(&manager);
  ConcurrentCalls<S> calls{
      cdata,
      callback,
      threads,
      cube != nullptr ? static_cast<const void*>(&detail::coreOf(*cube)) : nullptr,
      {}};
  selfWalk(manager, &calls, &ConcurrentCalls<S>::gather, threads, split_walk);
  if (!calls.stop.load()) calls.flush();
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(
      request, options, [&](void* data, fcl::DistanceCallBack<S> f) { manager.distance(data, f); },
      [&](detail::DistanceSearch<S>& search) {
        return walkWithIds(manager, &manager, search, distanceIds<S>(),
                           [&](const auto& cube, void* data, auto fn) {
                             detail::distanceWithIds(cube, data, fn);
                           });
      });
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::CollisionObject<S>* obj,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(
      request, options,
      [&](void* data, fcl::DistanceCallBack<S> f) { manager.distance(obj, data, f); },
      [&](detail::DistanceSearch<S>& search) {
        return walkWithIds<S>(manager, nullptr, search, distanceIds<S>(),
                              [&](const auto& cube, void* data, auto fn) {
                                detail::distanceWithIds(cube, obj, data, fn);
                              });
      });
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::BroadPhaseCollisionManager<S>& other,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(
      request, options,
      [&](void* data, fcl::DistanceCallBack<S> f) { manager.distance(&other, data, f); },
      [&](detail::DistanceSearch<S>& search) {
        return walkWithIds(manager, &other, search, distanceIds<S>(),
                           [&](const auto& cube, void* data, auto fn) {
                             detail::distanceWithIds(cube, &other, data, fn);
                           });
      });
}

#define CUBE_INSTANTIATE_QUERIES(S)                                                                \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&); \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&,  \
                                                       fcl::CollisionObject<S>*);                  \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&,  \
                                                       fcl::BroadPhaseCollisionManager<S>&);       \
  template fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>&,           \
                                              const fcl::CollisionRequest<S>&,                     \
                                              const NarrowPhaseOptions<S>&);                       \
  template fcl::CollisionResult<S> collideAll(                                                     \
      const fcl::BroadPhaseCollisionManager<S>&, fcl::CollisionObject<S>*,                         \
      const fcl::CollisionRequest<S>&, const NarrowPhaseOptions<S>&);                              \
  template fcl::CollisionResult<S> collideAll(                                                     \
      const fcl::BroadPhaseCollisionManager<S>&, fcl::BroadPhaseCollisionManager<S>&,              \
      const fcl::CollisionRequest<S>&, const NarrowPhaseOptions<S>&);                              \
  template void collideConcurrently(const fcl::BroadPhaseCollisionManager<S>&, void*,              \
                                    fcl::CollisionCallBack<S>, int, bool);                         \
  template fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>&,       \
                                                  const fcl::DistanceRequest<S>&,                  \
                                                  const NarrowPhaseOptions<S>&);                   \
  template fcl::DistanceResult<S> minimumDistance(                                                 \
      const fcl::BroadPhaseCollisionManager<S>&, fcl::CollisionObject<S>*,                         \
      const fcl::DistanceRequest<S>&, const NarrowPhaseOptions<S>&);                               \
  template fcl::DistanceResult<S> minimumDistance(                                                 \
      const fcl::BroadPhaseCollisionManager<S>&, fcl::BroadPhaseCollisionManager<S>&,              \
      const fcl::DistanceRequest<S>&, const NarrowPhaseOptions<S>&);

CUBE_INSTANTIATE_QUERIES(double)
CUBE_INSTANTIATE_QUERIES(float)
#undef CUBE_INSTANTIATE_QUERIES

}  // namespace cube
