// The check of the caller's motion bounds (detail::allFiniteNonNegative, which checkMotions and
// the Python package run over every bound before any work): against a brute force, for every
// length up to past the vector loop's stride and a bad value at every position, in double and
// float. And the angle of the SE(3) bounds (detail::angleAbove): never below the exact angle
// (std::atan2 in long double), never more than twice its pad above it. And the bounds of many
// links at once (detail::se3Bounds): the AVX2 kernel equal to the portable one bit for bit, each
// equal to the bound of its link alone, and never below the exact bound (long double).

#include <fcl/math/geometry.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/kernels/se3_bounds.h"
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

// Random poses (column-major, 16 numbers): rotations of every angle, small ones and ones near pi
// among them; with defects, now and then a NaN entry or an infinite translation.
std::vector<double> randomPoses(std::mt19937& rng, std::size_t n, bool defects) {
  std::uniform_real_distribution<double> u(-1, 1), angle(0, 3.14159265358979323846);
  std::uniform_int_distribution<int> kind(0, 19), entry(0, 14);
  std::vector<double> out(16 * n);
  for (std::size_t k = 0; k < n; ++k) {
    fcl::Vector3d axis(u(rng), u(rng), u(rng));
    if (axis.norm() < 1e-3) axis = fcl::Vector3d::UnitX();
    double a = angle(rng);
    const int what = kind(rng);
    if (what == 1) a = std::ldexp(a, -20 - entry(rng));
    if (what == 2) a = 3.14159265358979323846 - std::ldexp(a, -20 - entry(rng));
    if (what == 3) a = 0;
    fcl::Transform3d t = fcl::Transform3d::Identity();
    t.linear() = fcl::AngleAxisd(a, axis.normalized()).toRotationMatrix();
    t.translation() = 50 * fcl::Vector3d(u(rng), u(rng), u(rng));
    std::memcpy(&out[16 * k], t.data(), sizeof t);
    constexpr int kRead[12] = {0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14};  // the last row is not
    if (defects && what == 4) out[16 * k + kRead[entry(rng) % 12]] = NAN;
    if (defects && what == 5) out[16 * k + 12 + entry(rng) % 3] = INFINITY;
  }
  return out;
}

TEST(Se3Bounds, Avx2EqualsPortableAndEachLinkAloneBitForBit) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> reach(0, 3);
  for (int round = 0; round < 400; ++round) {
    const std::size_t n = round % 23;
    std::vector<double> a = randomPoses(rng, n, true), b = randomPoses(rng, n, true);
    for (std::size_t k = 0; k < n; k += 5)  // some links that do not move
      std::memcpy(&b[16 * k], &a[16 * k], 16 * sizeof(double));
    for (std::size_t k = 3; k < n; k += 7)  // a^T b = diag(1, 0, 0): sine and cosine both 0
      for (int i : {0, 1, 2, 4, 5, 6, 8, 9, 10}) {
        a[16 * k + i] = i % 5 == 0 ? 1 : 0;
        b[16 * k + i] = i == 0 ? 1 : 0;
      }
    std::vector<double> r(n);
    for (double& x : r) x = reach(rng);
    std::vector<double> got(n + 1, -7.0), want(n + 1, -7.0);
    cube::detail::se3Bounds(a.data(), b.data(), r.data(), n, got.data());
    cube::detail::se3BoundsPortable(a.data(), b.data(), r.data(), n, want.data());
    EXPECT_EQ(0, std::memcmp(got.data(), want.data(), got.size() * sizeof(double))) << n;
    for (std::size_t k = 0; k < n; ++k) {
      const double alone = cube::detail::se3Bound(&a[16 * k], &b[16 * k], r[k]);
      EXPECT_TRUE(std::memcmp(&alone, &want[k], sizeof alone) == 0) << k << " of " << n;
    }
    EXPECT_EQ(got[n], -7.0);  // nothing written past the links
  }
}

TEST(Se3Bounds, NeverBelowTheExactBoundAndNaNForABadPose) {
  std::mt19937 rng(22);
  std::uniform_real_distribution<double> reach(0, 3);
  for (int round = 0; round < 200; ++round) {
    const std::size_t n = 1 + round % 17;
    const std::vector<double> a = randomPoses(rng, n, true), b = randomPoses(rng, n, true);
    std::vector<double> r(n), got(n);
    for (double& x : r) x = reach(rng);
    cube::detail::se3Bounds(a.data(), b.data(), r.data(), n, got.data());
    for (std::size_t k = 0; k < n; ++k) {
      const double* p = &a[16 * k];
      const double* q = &b[16 * k];
      bool finite = true;
      for (int i = 0; i < 15; ++i)
        finite = finite && (i % 4 == 3 || (std::isfinite(p[i]) && std::isfinite(q[i])));
      if (!finite) {
        EXPECT_FALSE(std::isfinite(got[k])) << k;
        continue;
      }
      // The exact bound in long double: the rotation angle of a^T b from atan2, the shift.
      using L = long double;
      L m[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          m[i][j] = L(p[4 * i]) * q[4 * j] + L(p[4 * i + 1]) * q[4 * j + 1] +
                    L(p[4 * i + 2]) * q[4 * j + 2];
      const L sx = m[2][1] - m[1][2], sy = m[0][2] - m[2][0], sz = m[1][0] - m[0][1];
      const L angle = std::atan2(std::sqrt(sx * sx + sy * sy + sz * sz) / 2,
                                 (m[0][0] + m[1][1] + m[2][2] - 1) / 2);
      const L tx = L(q[12]) - p[12], ty = L(q[13]) - p[13], tz = L(q[14]) - p[14];
      const L exact = std::sqrt(tx * tx + ty * ty + tz * tz) + angle * r[k];
      EXPECT_GE(L(got[k]), exact * (1 - 1e-15L)) << k;  // within the rounding of its inputs
      EXPECT_LE(L(got[k]), exact + 1e-12L * (1 + exact)) << k;
    }
  }
}

}  // namespace
