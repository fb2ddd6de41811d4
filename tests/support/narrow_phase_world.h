#pragma once

// What the tests of the narrow-phase pipeline share (test_narrow_phase_*.cpp): one typed suite
// over its files, and FCL's own accumulation, the reference its answers are held against.

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "fcl_contacts.h"
#include "scenes.h"

namespace narrowphase {

using namespace fclcontacts;

template <typename S>
class NarrowPhase : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(NarrowPhase, Scalars);

using cube::scenes::Layout;

// FCL's own way, the reference: fcl::collide on every pair the manager hands over, in its
// order, into one result, stopping once the result is full (FCL's DefaultCollisionFunction).
// `colliding`: the pairs that added a contact, in turn (NarrowPhaseOptions::colliding's oracle).
template <typename S>
struct Accumulate {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  std::vector<cube::ObjectPair<S>> colliding;
  static bool fn(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    auto& x = *static_cast<Accumulate*>(d);
    const std::size_t before = x.result.numContacts();
    fcl::collide(a, b, x.request, x.result);
    if (x.result.numContacts() > before) x.colliding.emplace_back(a, b);
    // With costs FCL's default callback never stops.
    return !x.request.enable_cost && x.result.isCollision() &&
           x.result.numContacts() >= x.request.num_max_contacts;
  }
};

}  // namespace narrowphase
