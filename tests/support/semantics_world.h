#pragma once

// What the tests of the manager's semantics share (test_semantics_*.cpp): one typed suite over
// their files and the scenes they ask.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <stdexcept>
#include <thread>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "correctness.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace cube {
namespace testing {
namespace semantics_world {

template <typename S>
class Semantics : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Semantics, Scalars);

template <typename S>
using V3 = fcl::Vector3<S>;

template <typename S>
scenes::Scene<S> scene(std::size_t n, std::uint32_t seed = 5,
                       scenes::Layout layout = scenes::Layout::uniform, double overlaps = 2.0) {
  scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.layout = layout;
  o.overlaps_per_object = overlaps;
  return scenes::makeScene<S>(o);
}

}  // namespace semantics_world
}  // namespace testing
}  // namespace cube
