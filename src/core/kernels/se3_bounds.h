#pragma once

// The SE(3) motion bounds of continuous edges (batch.h, "Continuous edges"): for a link moving
// from pose a to pose b with the translation linear and the rotation along the geodesic, the
// length of the path of any point within `reach` of its frame's origin is at most |t_b - t_a| +
// angle * reach. Poses are 4x4 column-major matrices of 16 numbers (the storage of
// fcl::Transform3; the last row is not read). No Eigen here: the AVX2 version (double, four
// links per instruction) is built in this file with a per-function target, and runs only where
// the CPU has AVX2.

#include <cmath>
#include <cstddef>
#include <limits>

namespace cube {
namespace detail {

/// Upper bound on the angle whose sine and cosine are proportional to `sine` >= 0 and `cosine`
/// (std::atan2(sine, cosine), in [0, pi]): at least the exact angle and at most 2 kAnglePad
/// above it; NaN if either is NaN. A short polynomial instead of std::atan2's correctly rounded
/// result, which cost several times as much where every link of every state takes one. The
/// octant's angle comes from atan(t), t in [0, 1], reduced to |u| <= tan(pi / 8) by atan(t) =
/// pi / 4 + atan((t - 1) / (t + 1)), where an odd polynomial of degree 21 (a least-squares fit on
/// Chebyshev nodes) is within 4e-15 of it; kAnglePad is added to stay above the exact angle.
inline constexpr double kAnglePad = 1e-14;
inline constexpr double kAnglePi = 3.14159265358979323846;
inline constexpr double kAngleTanPi8 = 0.41421356237309504880;
inline constexpr double kAngleCoefficients[10] = {
    -0.33333333333330023, 0.1999999999995909,  -0.14285714276157827, 0.11111110283465862,
    -0.09090873365654059, 0.07691429922184825, -0.06653564590250108, 0.0576052489486998,
    -0.04562968023044902, 0.023839526937867637};

inline double angleAbove(double sine, double cosine) {
  const double ac = std::fabs(cosine);
  const bool swap = sine > ac;  // past the diagonal: from the other side's angle
  const double num = swap ? ac : sine, den = swap ? sine : ac;
  if (!(den > 0)) return (sine + cosine) * 0 + kAnglePad;  // both 0 (no rotation), or a NaN
  const double t = num / den;
  const bool far = t > kAngleTanPi8;
  const double u = far ? (t - 1) / (t + 1) : t;
  const double z = u * u;
  double p = kAngleCoefficients[9];
  for (int i = 8; i >= 0; --i) p = p * z + kAngleCoefficients[i];
  double a = u + u * z * p;
  if (far) a += kAnglePi / 4;
  if (swap) a = kAnglePi / 2 - a;
  if (cosine < 0) a = kAnglePi - a;
  return a + kAnglePad;
}

/// The bound for one link, poses a and b: the rotation's angle from its sine (half the norm of
/// the skew part of a^T b) and cosine (half its trace less one), accurate near 0 and pi where
/// acos of the trace alone is not, rounded up to S. NaN or infinite for a pose that is. Every
/// sum in a fixed order (left to right), so that the kernels below give the same bits.
template <typename S>
S se3Bound(const S* a, const S* b, S reach) {
  // m(i, j) = column i of a's rotation . column j of b's.
  const auto m = [&](int i, int j) {
    return (a[4 * i] * b[4 * j] + a[4 * i + 1] * b[4 * j + 1]) + a[4 * i + 2] * b[4 * j + 2];
  };
  const S sx = m(2, 1) - m(1, 2), sy = m(0, 2) - m(2, 0), sz = m(1, 0) - m(0, 1);
  const S sine = S(0.5) * std::sqrt((sx * sx + sy * sy) + sz * sz);
  const S cosine = S(0.5) * (((m(0, 0) + m(1, 1)) + m(2, 2)) - S(1));
  const double above = angleAbove(double(sine), double(cosine));
  S angle = S(above);
  if (double(angle) < above) angle = std::nextafter(angle, std::numeric_limits<S>::infinity());
  const S tx = b[12] - a[12], ty = b[13] - a[13], tz = b[14] - a[14];
  return std::sqrt((tx * tx + ty * ty) + tz * tz) + angle * reach;
}

/// out[l] = se3Bound(a + 16 l, b + 16 l, reach[l]) for l in [0, n), bit for bit.
void se3Bounds(const double* a, const double* b, const double* reach, std::size_t n, double* out);
void se3Bounds(const float* a, const float* b, const float* reach, std::size_t n, float* out);
/// The version without AVX2, for the tests.
void se3BoundsPortable(const double* a, const double* b, const double* reach, std::size_t n,
                       double* out);

}  // namespace detail
}  // namespace cube
