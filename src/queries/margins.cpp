// Contacts within a margin: the manager's candidate pairs (boxes grown by the margins), those
// the pair judge finds farther apart than their margins left out, then fcl::collide and
// fcl::distance.

#include "cube_collision/margins.h"

#include <atomic>
#include <functional>

#include "cube_collision/queries.h"
#include "pipeline/collectors.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"

namespace cube {

namespace {

template <typename S>
std::vector<MarginContact<S>> withinMargins(const CubeCollisionManager<S>& manager,
                                            const std::vector<ObjectPair<S>>& pairs,
                                            const fcl::DistanceRequest<S>& request, int threads,
                                            NarrowPhaseStats* stats) {
  detail::WithinMargin<MarginContact<S>> near(pairs.size());
  std::atomic<std::size_t> culled{0}, calls{0};
  const detail::PairJudge<S> judge(request);
  forEachPair<S>(
      pairs,
      [&](std::size_t i, fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
        const S within = manager.margin(a) + manager.margin(b);
        if (!judge.mayBeWithin(*a, *b, within)) {
          culled.fetch_add(1, std::memory_order_relaxed);
          return;
        }
        MarginContact<S>& c = near.at(i);
        c.a = a;
        c.b = b;
        fcl::CollisionRequest<S> creq;
        creq.gjk_solver_type = request.gjk_solver_type;
        fcl::CollisionResult<S> cres;
        calls.fetch_add(1, std::memory_order_relaxed);
        if (detail::fclCollide(a, b, creq, cres) > 0) {
          c.colliding = true;
          near.keep(i);
          return;
        }
        fcl::DistanceResult<S> dres;
        calls.fetch_add(1, std::memory_order_relaxed);
        c.distance = detail::fclDistance(a, b, request, dres);
        c.nearest_points[0] = dres.nearest_points[0];
        c.nearest_points[1] = dres.nearest_points[1];
        if (c.distance <= within) near.keep(i);
      },
      threads);
  std::vector<MarginContact<S>> out = near.take();
  if (stats != nullptr) {
    stats->candidate_pairs += pairs.size();
    stats->culled += culled.load();
    stats->narrow_calls += calls.load();
  }
  return out;
}

}  // namespace

template <typename S>
std::vector<MarginContact<S>> contactsWithinMargin(const CubeCollisionManager<S>& manager,
                                                   const fcl::DistanceRequest<S>& distance_request,
                                                   int threads, NarrowPhaseStats* stats) {
  return withinMargins(manager, overlappingPairs<S>(manager), distance_request, threads, stats);
}

template <typename S>
std::vector<MarginContact<S>> contactsWithinMargin(const CubeCollisionManager<S>& manager,
                                                   fcl::CollisionObject<S>* obj,
                                                   const fcl::DistanceRequest<S>& distance_request,
                                                   int threads, NarrowPhaseStats* stats) {
  return withinMargins(manager, overlappingPairs<S>(manager, obj), distance_request, threads,
                       stats);
}

#define CUBE_MARGINS_INSTANTIATE(S)                                                             \
  template std::vector<MarginContact<S>> contactsWithinMargin<S>(                               \
      const CubeCollisionManager<S>&, const fcl::DistanceRequest<S>&, int, NarrowPhaseStats*);  \
  template std::vector<MarginContact<S>> contactsWithinMargin<S>(                               \
      const CubeCollisionManager<S>&, fcl::CollisionObject<S>*, const fcl::DistanceRequest<S>&, \
      int, NarrowPhaseStats*);
CUBE_MARGINS_INSTANTIATE(double)
CUBE_MARGINS_INSTANTIATE(float)
#undef CUBE_MARGINS_INSTANTIATE

}  // namespace cube
