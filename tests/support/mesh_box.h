#pragma once

// A box as a triangle mesh, for the tests that want meshes among their shapes (batch_world.h,
// test_continuous_edges.cpp).

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>

#include <memory>
#include <vector>

namespace meshbox {

// A box mesh of sides `size` whose centre lies at `offset` from its frame's origin: with an
// offset, a link whose points turn around a far origin.
inline std::shared_ptr<fcl::CollisionGeometryd> meshBox(
    const fcl::Vector3d& size, const fcl::Vector3d& offset = fcl::Vector3d::Zero()) {
  auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  std::vector<fcl::Vector3d> v;
  for (int i = 0; i < 8; ++i)
    v.push_back(offset + fcl::Vector3d((i & 1 ? 0.5 : -0.5) * size[0],
                                       (i & 2 ? 0.5 : -0.5) * size[1],
                                       (i & 4 ? 0.5 : -0.5) * size[2]));
  const int f[12][3] = {{0, 1, 3}, {0, 3, 2}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1},
                        {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
  std::vector<fcl::Triangle> t;
  for (const auto& x : f) t.emplace_back(x[0], x[1], x[2]);
  m->beginModel();
  m->addSubModel(v, t);
  m->endModel();
  return m;
}

// A box mesh of sides sx, sy, sz centred on its frame's origin.
inline std::shared_ptr<fcl::CollisionGeometryd> meshBox(double sx, double sy, double sz) {
  return meshBox(fcl::Vector3d(sx, sy, sz));
}

}  // namespace meshbox
