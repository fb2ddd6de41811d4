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

/// The boxes a walk tests for objects posed by poseBoxes: per object k, grown by a rate relative
/// to its scale (grow = rate (1 + max |c| + max h), the cull's tolerance) and by margin[k]:
/// lo = c - h - (grow + margin), hi = c + h + (grow + margin), per coordinate.
template <typename S>
struct WalkBoxes {
  const S* c[3];
  const S* h[3];
  const S* margin;
  S rate;
  S* grow;
  S* lo[3];
  S* hi[3];
};

/// Writes c and h of objects 0 .. n-1, whose poses are poses[16 k .. 16 k + 15].
void poseBoxes(const double* poses, std::size_t n, const PoseBoxes<double>& io);
void poseBoxes(const float* poses, std::size_t n, const PoseBoxes<float>& io);
/// The portable version, for the tests, which compare the two.
void poseBoxesPortable(const double* poses, std::size_t n, const PoseBoxes<double>& io);

/// Writes grow, lo and hi of objects 0 .. n-1 (WalkBoxes). Returns whether every c and h is
/// finite. Every version gives the same results, bit for bit.
bool walkBoxes(std::size_t n, const WalkBoxes<double>& io);
bool walkBoxes(std::size_t n, const WalkBoxes<float>& io);
/// Whether the sum of x[0 .. n-1] is finite: then every x is (false: one is not, or the sum
/// overflowed). Versions may differ on sums near overflow only.
bool sumIsFinite(const double* x, std::size_t n);
bool sumIsFinite(const float* x, std::size_t n);
bool sumIsFinitePortable(const double* x, std::size_t n);

/// The version without AVX2, for the tests.
bool walkBoxesPortable(std::size_t n, const WalkBoxes<double>& io);

/// The box of each object's positions over several sets of poses: for objects k = first ..
/// first + n - 1, lo[d][k] and hi[d][k] the least and largest translation coordinate d of pose k
/// over sets states[0 .. count-1] (count >= 1; pose k of set j is states[j][16 k .. 16 k + 15]).
/// Returns whether every translation read is finite (lo and hi are then exact). Every version
/// gives the same results, bit for bit.
bool positionBoxes(const double* const* states, std::size_t count, std::size_t first, std::size_t n,
                   double* const lo[3], double* const hi[3]);
bool positionBoxes(const float* const* states, std::size_t count, std::size_t first, std::size_t n,
                   float* const lo[3], float* const hi[3]);
bool positionBoxesPortable(const double* const* states, std::size_t count, std::size_t first,
                           std::size_t n, double* const lo[3], double* const hi[3]);

}  // namespace detail
}  // namespace cube
