#include "cube_collision/queries.h"

#include "cube_collision/callbacks.h"

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

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   const fcl::CollisionRequest<S>& request) {
  CollisionData<S> data;
  data.request = request;
  manager.collide(&data, &defaultCollisionCallback<S>);
  return data.result;
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::CollisionObject<S>* obj,
                                   const fcl::CollisionRequest<S>& request) {
  CollisionData<S> data;
  data.request = request;
  manager.collide(obj, &data, &defaultCollisionCallback<S>);
  return data.result;
}

template <typename S>
fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>& manager,
                                   fcl::BroadPhaseCollisionManager<S>& other,
                                   const fcl::CollisionRequest<S>& request) {
  CollisionData<S> data;
  data.request = request;
  manager.collide(&other, &data, &defaultCollisionCallback<S>);
  return data.result;
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       const fcl::DistanceRequest<S>& request) {
  DistanceData<S> data;
  data.request = request;
  manager.distance(&data, &defaultDistanceCallback<S>);
  return data.result;
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::CollisionObject<S>* obj,
                                       const fcl::DistanceRequest<S>& request) {
  DistanceData<S> data;
  data.request = request;
  manager.distance(obj, &data, &defaultDistanceCallback<S>);
  return data.result;
}

template <typename S>
fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>& manager,
                                       fcl::BroadPhaseCollisionManager<S>& other,
                                       const fcl::DistanceRequest<S>& request) {
  DistanceData<S> data;
  data.request = request;
  manager.distance(&other, &data, &defaultDistanceCallback<S>);
  return data.result;
}

#define CUBE_INSTANTIATE_QUERIES(S)                                                                \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&); \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&,  \
                                                       fcl::CollisionObject<S>*);                  \
  template std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>&,  \
                                                       fcl::BroadPhaseCollisionManager<S>&);       \
  template fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>&,           \
                                              const fcl::CollisionRequest<S>&);                    \
  template fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>&,           \
                                              fcl::CollisionObject<S>*,                            \
                                              const fcl::CollisionRequest<S>&);                    \
  template fcl::CollisionResult<S> collideAll(const fcl::BroadPhaseCollisionManager<S>&,           \
                                              fcl::BroadPhaseCollisionManager<S>&,                 \
                                              const fcl::CollisionRequest<S>&);                    \
  template fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>&,       \
                                                  const fcl::DistanceRequest<S>&);                 \
  template fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>&,       \
                                                  fcl::CollisionObject<S>*,                        \
                                                  const fcl::DistanceRequest<S>&);                 \
  template fcl::DistanceResult<S> minimumDistance(const fcl::BroadPhaseCollisionManager<S>&,       \
                                                  fcl::BroadPhaseCollisionManager<S>&,             \
                                                  const fcl::DistanceRequest<S>&);

CUBE_INSTANTIATE_QUERIES(double)
CUBE_INSTANTIATE_QUERIES(float)
#undef CUBE_INSTANTIATE_QUERIES

}  // namespace cube
