#pragma once

// Rigid transforms read from row-major 4x4 matrices (numpy's (..., 4, 4) arrays) into the
// column-major storage of fcl::Transform3 (16 numbers, last row included), each checked on the
// way. No Eigen here: the AVX2 version (one matrix per four-wide register row) is built in this
// file with a per-function target, and runs only where the CPU has AVX2.

#include <cstddef>

namespace cube {
namespace detail {

/// The tolerance of rigidRows' checks: half of the Python package's (1e-6), so that a matrix
/// that passes them passes the package's own check whatever the rounding.
inline constexpr double kRigidRowsTolerance = 0.5e-6;

/// Converts matrices rows[16 k .. 16 k + 15] (row-major) into cols[16 k .. 16 k + 15]
/// (column-major, the transpose) for k = 0, 1, ... while matrix k passes every check: the
/// translation finite, the last row exactly (0, 0, 0, 1), the rotation's columns of squared
/// norm within kRigidRowsTolerance of 1 and of pairwise dot products within it of 0, its
/// determinant above 0.5. Returns the number converted: n, or the index of the first matrix that
/// fails, which is not written (nor any after it). A NaN or infinite rotation entry fails.
/// Every version gives the same results, bit for bit.
std::size_t rigidRows(const double* rows, std::size_t n, double* cols);
/// The version without AVX2, for the tests.
std::size_t rigidRowsPortable(const double* rows, std::size_t n, double* cols);

}  // namespace detail
}  // namespace cube
