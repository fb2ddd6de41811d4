#include "cube_collision/queries.h"

#include "cube_collision/callbacks.h"

#include <atomic>

#include "narrow_phase_stream.h"

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

// Costs and a cached GJK guess travel from pair to pair through the one result: FCL's way, on
// this thread. Everything else goes through the pipeline.
template <typename S, class Walk>
fcl::CollisionResult<S> collideWith(const fcl::CollisionRequest<S>& request,
                                    const NarrowPhaseOptions<S>& options, const Walk& walk) {
  if (request.enable_cost || request.enable_cached_gjk_guess) {
    CollisionData<S> data;
    data.request = request;
    walk(&data, &defaultCollisionCallback<S>);
    if (options.stats != nullptr) options.stats->narrow_calls += data.narrow_calls;
    return data.result;
  }
  detail::CollideStream<S> stream(request, options);
  walk(&stream, &detail::CollideStream<S>::callback);
  return stream.finish();
}

template <typename S, class Walk>
fcl::DistanceResult<S> distanceWith(const fcl::DistanceRequest<S>& request,
                                    const NarrowPhaseOptions<S>& options, const Walk& walk) {
  detail::DistanceSearch<S> search(request, options);
  walk(&search, &detail::DistanceSearch<S>::callback);
  return search.finish();
}

}  // namespace

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(request, options,
                     [&](void* data, fcl::CollisionCallBack<S> f) { manager.collide(data, f); });
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::CollisionObject<S>* obj,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(request, options, [&](void* data, fcl::CollisionCallBack<S> f) {
    manager.collide(obj, data, f);
  });
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::BroadPhaseCollisionManager<S>& other,
                                   const fcl::CollisionRequest<S>& request,
                                   const NarrowPhaseOptions<S>& options) {
  return collideWith(request, options, [&](void* data, fcl::CollisionCallBack<S> f) {
    manager.collide(&other, data, f);
  });
}

namespace {

// collideConcurrently's state: the chunk gathered from the walk and the stop flag.
template <typename S>
struct ConcurrentCalls {
  void* cdata;
  fcl::CollisionCallBack<S> callback;
  int threads;
  std::vector<ObjectPair<S>> chunk;
  std::atomic<bool> stop{false};

  void flush() {
    forEachPair<S>(
        chunk,
        [this](std::size_t, fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
          if (!stop.load(std::memory_order_relaxed) && callback(a, b, cdata))
            stop.store(true, std::memory_order_relaxed);
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
                         fcl::CollisionCallBack<S> callback, int threads) {
  ConcurrentCalls<S> calls{cdata, callback, threads, {}};
  manager.collide(&calls, &ConcurrentCalls<S>::gather);
  if (!calls.stop.load()) calls.flush();
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(request, options,
                      [&](void* data, fcl::DistanceCallBack<S> f) { manager.distance(data, f); });
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::CollisionObject<S>* obj,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(request, options, [&](void* data, fcl::DistanceCallBack<S> f) {
    manager.distance(obj, data, f);
  });
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::BroadPhaseCollisionManager<S>& other,
                                       const fcl::DistanceRequest<S>& request,
                                       const NarrowPhaseOptions<S>& options) {
  return distanceWith(request, options, [&](void* data, fcl::DistanceCallBack<S> f) {
    manager.distance(&other, data, f);
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
                                    fcl::CollisionCallBack<S>, int);                               \
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
