// The check of the caller's motion bounds (detail::allFiniteNonNegative, which checkMotions and
// the Python package run over every bound before any work): against a brute force, for every
// length up to past the vector loop's stride and a bad value at every position, in double and
// float. And the angle of the SE(3) bounds (detail::angleAbove): never below the exact angle
// (std::atan2 in long double), never more than twice its pad above it.

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
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

// The exact angle of (sine, cosine) in long double, and angleAbove's, checked against it.
void expectAngleAboveWithinPad(double sine, double cosine) {
  const long double exact =
      std::atan2(static_cast<long double>(sine), static_cast<long double>(cosine));
  const long double got = cube::detail::angleAbove(sine, cosine);
  EXPECT_GE(got, exact) << "sine " << sine << ", cosine " << cosine;
  EXPECT_LE(got - exact, 2 * static_cast<long double>(cube::detail::kAnglePad))
      << "sine " << sine << ", cosine " << cosine;
}

TEST(MotionBoundsAngle, IsAtLeastTheExactAngleAndWithinTwicePadAboveIt) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(0, 3.14159265358979323846), scale(-30, 30);
  for (int i = 0; i < 200000; ++i) {
    // Angles over [0, pi] and near the reduction's seams, lengths over many scales.
    double a = angle(rng);
    if (i % 4 == 1) a = std::ldexp(a, -int(scale(rng) + 30));  // tiny angles
    if (i % 4 == 2) a = 3.14159265358979323846 / 8 * (1 + 1e-9 * scale(rng));
    if (i % 4 == 3) a = 3.14159265358979323846 / 4 * (1 + 1e-9 * scale(rng));
    const double r = std::ldexp(1.0, int(scale(rng)));
    expectAngleAboveWithinPad(r * std::sin(a), r * std::cos(a));
    expectAngleAboveWithinPad(r * std::sin(3.14159265358979323846 - a),
                              r * std::cos(3.14159265358979323846 - a));
  }
  for (const double c : {1.0, -1.0, 1e-300, -1e-300})
    for (const double s : {0.0, 1e-300, 1e-17, 1.0}) expectAngleAboveWithinPad(s, c);
  expectAngleAboveWithinPad(1.0, 0.0);
  expectAngleAboveWithinPad(1.0, -0.0);
  // No rotation (both 0): the pad alone; a NaN stays NaN, so that a NaN pose is found.
  EXPECT_EQ(cube::detail::angleAbove(0.0, 0.0), cube::detail::kAnglePad);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double other : {0.0, 1.0, -1.0}) {
    EXPECT_TRUE(std::isnan(cube::detail::angleAbove(nan, other))) << other;
    EXPECT_TRUE(std::isnan(cube::detail::angleAbove(std::fabs(other), nan))) << other;
  }
}

}  // namespace
