#pragma once

// Posed boxes of many objects at once (a robot's links in one state): for object k, the centre
// c = R mid + t and half extents h = |R| half of its local AABB (centre mid, half extents half)
// under pose k, a 4x4 column-major matrix of 16 numbers (the storage of fcl::Transform3, whose
// last row is not read). Coordinates come and go as structures of arrays (x[n], y[n], z[n]). No
// Eigen here: the AVX2 version (double, four objects per instruction) is built in this file
// with a per-function target, and runs only where the CPU has AVX2.

#include <cstddef>

namespace cube {
namespace detail {

template <typename S>
struct PoseBoxes {
  const S* mid[3];
  const S* half[3];
  S* c[3];
  S* h[3];
};

/// Writes c and h of objects 0 .. n-1, whose poses are poses[16 k .. 16 k + 15].
void poseBoxes(const double* poses, std::size_t n, const PoseBoxes<double>& io);
void poseBoxes(const float* poses, std::size_t n, const PoseBoxes<float>& io);
/// The portable version, for the tests, which compare the two.
void poseBoxesPortable(const double* poses, std::size_t n, const PoseBoxes<double>& io);

}  // namespace detail
}  // namespace cube
