#pragma once

// What the tests of inspection share (test_inspect_*.cpp): one typed suite over their files.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/halfspace.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/inspect.h"
#include "scenes.h"

namespace inspectsuite {

using cube::CubeCollisionManager;
using cube::HierarchyView;

template <typename S>
class InspectTest : public ::testing::Test {};
using Scalars = ::testing::Types<float, double>;
TYPED_TEST_SUITE(InspectTest, Scalars);

}  // namespace inspectsuite
