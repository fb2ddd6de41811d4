#pragma once

// What the tests that hold the pipeline's contacts against FCL's share (test_narrow_phase_*.cpp,
// test_collectors.cpp, test_split_walk.cpp): scenes with many touching pairs, the requests to try,
// and contact lists compared bit for bit.

#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "scenes.h"

namespace fclcontacts {

// n objects with many touching pairs: contacts to merge.
template <typename S>
cube::scenes::Scene<S> scene(cube::scenes::Layout layout, bool meshes, std::size_t n,
                             std::uint32_t seed, double size_scale = 1.0) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.layout = layout;
  o.meshes = meshes;
  o.seed = seed;
  o.overlaps_per_object = 3.0;  // many touching pairs: contacts to merge
  o.size_scale = size_scale;
  return cube::scenes::makeScene<S>(o);
}

template <typename S>
bool sameBits(const fcl::Vector3<S>& a, const fcl::Vector3<S>& b) {
  return std::memcmp(a.data(), b.data(), sizeof(S) * 3) == 0;
}

// Equal contact lists, order and every bit included. Without enable_contact FCL leaves a
// contact's position, normal and depth uninitialised: only the objects and primitives count.
template <typename S>
::testing::AssertionResult sameContacts(const fcl::CollisionResult<S>& a,
                                        const fcl::CollisionResult<S>& b,
                                        bool with_geometry = true) {
  if (a.numContacts() != b.numContacts())
    return ::testing::AssertionFailure()
           << a.numContacts() << " contacts against " << b.numContacts();
  for (std::size_t k = 0; k < a.numContacts(); ++k) {
    const fcl::Contact<S>&x = a.getContact(k), &y = b.getContact(k);
    if (x.o1 != y.o1 || x.o2 != y.o2 || x.b1 != y.b1 || x.b2 != y.b2)
      return ::testing::AssertionFailure() << "contact " << k << ": other objects";
    if (with_geometry && (!sameBits(x.pos, y.pos) || !sameBits(x.normal, y.normal) ||
                          std::memcmp(&x.penetration_depth, &y.penetration_depth, sizeof(S)) != 0))
      return ::testing::AssertionFailure() << "contact " << k << " differs";
  }
  return ::testing::AssertionSuccess();
}

template <typename S>
std::vector<fcl::CollisionRequest<S>> requests() {
  std::vector<fcl::CollisionRequest<S>> out;
  for (std::size_t max : {std::size_t(1), std::size_t(7), std::size_t(1) << 30})
    for (bool contact : {false, true}) {
      fcl::CollisionRequest<S> r;
      r.num_max_contacts = max;
      r.enable_contact = contact;
      out.push_back(r);
    }
  return out;
}

}  // namespace fclcontacts
