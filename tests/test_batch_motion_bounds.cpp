// The check of the caller's motion bounds (detail::allFiniteNonNegative, which checkMotions and
// the Python package run over every bound before any work): against a brute force, for every
// length up to past the vector loop's stride and a bad value at every position, in double and
// float.

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "queries/motion_bounds.h"

namespace {

template <typename S>
bool boundsValidByBruteForce(const std::vector<S>& v) {
  for (const S x : v)
    if (!std::isfinite(x) || x < S(0)) return false;
  return true;
}

template <typename S>
void expectBoundsCheckMatchesBruteForce() {
  const S inf = std::numeric_limits<S>::infinity();
  const S bad_values[] = {S(-1e-30),
                          -std::numeric_limits<S>::denorm_min(),
                          S(-1),
                          -inf,
                          inf,
                          std::numeric_limits<S>::quiet_NaN(),
                          -std::numeric_limits<S>::max()};
  const S good_values[] = {S(0), S(-0.0), std::numeric_limits<S>::denorm_min(), S(0.5),
                           std::numeric_limits<S>::max()};
  for (std::size_t n = 0; n <= 13; ++n) {
    for (const S fill : good_values) {
      std::vector<S> v(n, fill);
      EXPECT_TRUE(cube::detail::allFiniteNonNegative(v.data(), n)) << n << " x " << fill;
      for (std::size_t at = 0; at < n; ++at) {
        for (const S bad : bad_values) {
          v[at] = bad;
          EXPECT_EQ(cube::detail::allFiniteNonNegative(v.data(), n), boundsValidByBruteForce(v))
              << "length " << n << ", " << bad << " at " << at;
          EXPECT_FALSE(cube::detail::allFiniteNonNegative(v.data(), n));
        }
        v[at] = fill;
      }
    }
  }
}

TEST(MotionBoundsCheck, AcceptsExactlyTheFiniteNonNegativeValuesInDouble) {
  expectBoundsCheckMatchesBruteForce<double>();
}

TEST(MotionBoundsCheck, AcceptsExactlyTheFiniteNonNegativeValuesInFloat) {
  expectBoundsCheckMatchesBruteForce<float>();
}

}  // namespace
