// The kernel that reads rigid transforms from row-major matrices (detail::rigidRows, which the
// Python package's pose arrays go through): the AVX2 version equals the portable one bit for bit,
// each matrix it takes is copied exactly as its transpose, and it takes exactly the matrices
// whose checks pass by the documented tolerance (brute force in long double, away from the
// tolerance's edge), stopping at the first that does not.

#include <fcl/math/geometry.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/kernels/rigid_rows.h"

namespace {

using cube::detail::kRigidRowsTolerance;
using cube::detail::rigidRows;
using cube::detail::rigidRowsPortable;

// A random rigid transform as a row-major 4x4 matrix.
std::vector<double> randomRigid(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1), t(-100, 100);
  fcl::Vector3d axis(u(rng), u(rng), u(rng));
  if (axis.norm() < 1e-3) axis = fcl::Vector3d::UnitZ();
  const fcl::Matrix3d r = fcl::AngleAxisd(3.2 * u(rng), axis.normalized()).toRotationMatrix();
  std::vector<double> m(16, 0.0);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[4 * i + j] = r(i, j);
    m[4 * i + 3] = t(rng);
  }
  m[15] = 1;
  return m;
}

// What the contract says, in long double: true, false, or -1 for a matrix within 1% of the
// tolerance's edge (rounding may decide either way there).
int contract(const double* m) {
  using L = long double;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(m[4 * i + 3])) return 0;
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1) return 0;
  for (int i = 0; i < 12; ++i)
    if (!std::isfinite(m[i])) return 0;
  L worst = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      L dot = 0;
      for (int r = 0; r < 3; ++r) dot += L(m[4 * r + a]) * L(m[4 * r + b]);
      worst = std::max(worst, std::fabs(dot - (a == b ? 1 : 0)));
    }
  const L det = L(m[0]) * (L(m[5]) * m[10] - L(m[6]) * m[9]) -
                L(m[1]) * (L(m[4]) * m[10] - L(m[6]) * m[8]) +
                L(m[2]) * (L(m[4]) * m[9] - L(m[5]) * m[8]);
  const L tol = kRigidRowsTolerance;
  if (std::fabs(worst - tol) < tol / 100) return -1;
  return worst <= tol && det > 0.5;
}

// Matrices of every kind: rigid, and rigid with one defect (a NaN, an infinity, a scaled,
// sheared or mirrored rotation, a perturbation inside or outside the tolerance, a wrong last
// row, an infinite translation). only_at: only that matrix may have a defect, the others rigid.
std::vector<double> matrices(std::mt19937& rng, std::size_t n, std::size_t only_at = SIZE_MAX) {
  std::uniform_int_distribution<int> kind(0, 11), entry(0, 15), rot(0, 11);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> all;
  for (std::size_t k = 0; k < n; ++k) {
    std::vector<double> m = randomRigid(rng);
    int e = rot(rng);
    if (e % 4 == 3) e -= 1;  // a rotation entry
    const int defect = kind(rng);
    switch (only_at == SIZE_MAX || only_at == k ? defect : 11) {
      case 0:
        m[entry(rng)] = nan;
        break;
      case 1:
        m[entry(rng)] = -inf;
        break;
      case 2:
        for (int i = 0; i < 3; ++i) m[4 * i] *= 1 + 4 * kRigidRowsTolerance;
        break;
      case 3:
        m[e] += 0.1 * kRigidRowsTolerance;
        break;  // inside the tolerance
      case 4:
        m[e] += 10 * kRigidRowsTolerance;
        break;
      case 5:
        for (int i = 0; i < 3; ++i) m[4 * i + 1] = -m[4 * i + 1];
        break;  // mirrored
      case 6:
        m[12 + entry(rng) % 4] += 0.5;
        break;
      case 7:
        m[4 * (entry(rng) % 3) + 3] = inf;
        break;
      case 8:
        m[1] += 0.01;
        break;  // sheared
      default:
        break;  // rigid
    }
    all.insert(all.end(), m.begin(), m.end());
  }
  return all;
}

TEST(RigidRows, Avx2EqualsPortableBitForBit) {
  std::mt19937 rng(11);
  for (int round = 0; round < 300; ++round) {
    const std::size_t n = 1 + round % 40;
    const std::vector<double> rows = matrices(rng, n);
    std::vector<double> a(16 * n, -7.0), b(16 * n, -7.0);
    const std::size_t na = rigidRows(rows.data(), n, a.data());
    const std::size_t nb = rigidRowsPortable(rows.data(), n, b.data());
    ASSERT_EQ(na, nb);
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));
  }
}

// Long runs of rigid matrices with at most one defect, anywhere: the matrices taken several at a
// time, and the one that fails found wherever it lies among them.
TEST(RigidRows, Avx2EqualsPortableOnLongRunsWithOneDefect) {
  std::mt19937 rng(13);
  std::size_t whole = 0, stopped = 0;
  for (int round = 0; round < 600; ++round) {
    const std::size_t n = 1 + round % 67;
    const std::size_t at = std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
    const std::vector<double> rows = matrices(rng, n, at);
    std::vector<double> a(16 * n, -7.0), b(16 * n, -7.0);
    const std::size_t na = rigidRows(rows.data(), n, a.data());
    const std::size_t nb = rigidRowsPortable(rows.data(), n, b.data());
    ASSERT_EQ(na, nb);
    ASSERT_TRUE(na == n || na == at);
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));
    (na == n ? whole : stopped) += 1;
  }
  EXPECT_GT(whole, 100u);
  EXPECT_GT(stopped, 100u);
}

TEST(RigidRows, TakesTheMatricesThatPassAndStopsAtTheFirstThatFails) {
  std::mt19937 rng(12);
  std::size_t taken = 0, refused = 0;
  for (int round = 0; round < 2000; ++round) {
    const std::size_t n = 1 + round % 9;
    const std::vector<double> rows = matrices(rng, n);
    std::vector<double> cols(16 * n, -7.0);
    const std::size_t got = rigidRows(rows.data(), n, cols.data());
    ASSERT_LE(got, n);
    for (std::size_t k = 0; k < got; ++k) {
      const int want = contract(rows.data() + 16 * k);
      if (want >= 0) {
        EXPECT_EQ(want, 1) << "matrix " << k << " taken against the contract";
      }
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
          EXPECT_EQ(cols[16 * k + 4 * c + r], rows[16 * k + 4 * r + c]);  // bits: copied
      ++taken;
    }
    if (got < n) {
      const int want = contract(rows.data() + 16 * got);
      if (want >= 0) {
        EXPECT_EQ(want, 0) << "matrix " << got << " refused against the contract";
      }
      for (std::size_t i = 16 * got; i < cols.size(); ++i) EXPECT_EQ(cols[i], -7.0);
      ++refused;
    }
  }
  // Both outcomes happened often.
  EXPECT_GT(taken, 500u);
  EXPECT_GT(refused, 500u);
}

TEST(RigidRows, ZeroMatricesWriteNothing) {
  double out = -7.0;
  EXPECT_EQ(rigidRows(nullptr, 0, &out), 0u);
  EXPECT_EQ(rigidRowsPortable(nullptr, 0, &out), 0u);
  EXPECT_EQ(out, -7.0);
}

}  // namespace
