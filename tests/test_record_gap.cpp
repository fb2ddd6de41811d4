// The records' box gap (src/core/kernels/record_gap*.h): the SSE2 kernel equals the portable one
// bit for bit on random and degenerate records and stops, and both find a gap that only an edge
// axis shows. That every gap is a gap of the true boxes is checked against FCL with the rest of
// the cull (test_culling_soundness.cpp).

#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision_object.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <random>

#include "core/kernels/record_gap.h"
#include "core/kernels/record_gap_portable.h"
#include "core/volume.h"
#if defined(__SSE2__)
#include "core/kernels/record_gap_sse2.h"
#endif

namespace {

using cube::detail::VolumeShape;
using cube::detail::VolumeSphere;

struct Record {
  VolumeSphere sphere;
  VolumeShape shape;
};

// A record as buildVolume makes it for a box of half extents (hx, hy, hz) at `pose`.
Record boxRecord(double hx, double hy, double hz, const fcl::Transform3d& pose) {
  fcl::CollisionObjectd o(std::make_shared<fcl::Boxd>(2 * hx, 2 * hy, 2 * hz), pose);
  o.computeAABB();
  Record r{};
  cube::detail::buildVolume(o, r.sphere, r.shape);
  return r;
}

fcl::Transform3d rotatedAbout(const fcl::Vector3d& axis, double angle, const fcl::Vector3d& at) {
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  t.translation() = at;
  return t;
}

std::uint32_t bitsOf(float x) {
  std::uint32_t u = 0;
  std::memcpy(&u, &x, sizeof x);
  return u;
}

#if defined(__SSE2__)
TEST(RecordBoxGap, Sse2EqualsPortableBitForBit) {
  namespace pt = cube::detail::portable;
  namespace s2 = cube::detail::sse2;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_real_distribution<double> size(0, 2);
  const float inf = std::numeric_limits<float>::infinity();
  const float stops[] = {-inf, 0.f, 0.25f, inf};
  // Random rotations, with a share that keep an axis (parallel edges: cross products too short
  // to count), and the axis-aligned pose; extents from zero up, scales from tiny to huge.
  auto pose = [&](double scale) {
    fcl::Vector3d axis(unit(rng), unit(rng), unit(rng));
    if (axis.norm() < 1e-3) axis = fcl::Vector3d::UnitZ();
    const int kind = int(rng() % 4);
    if (kind == 0) axis = fcl::Vector3d::Unit(int(rng() % 3));
    const double angle = kind == 1 ? 0.0 : unit(rng) * M_PI;
    return rotatedAbout(axis, angle, fcl::Vector3d(unit(rng), unit(rng), unit(rng)) * scale);
  };
  std::size_t compared = 0, separated = 0;
  for (int rep = 0; rep < 20000; ++rep) {
    const double scale = std::ldexp(1.0, int(rng() % 40) - 20);
    auto extent = [&] { return rng() % 8 == 0 ? 0.0 : size(rng) * scale; };
    const Record a = boxRecord(extent(), extent(), extent(), pose(2 * scale));
    const Record b = boxRecord(extent(), extent(), extent(), pose(2 * scale));
    ASSERT_GE(a.sphere.r, 0.f);
    ASSERT_GE(b.sphere.r, 0.f);
    for (float stop : stops) {
      const float want = pt::recordBoxGap(a.sphere, a.shape, b.sphere, b.shape, stop * scale);
      const float got = s2::recordBoxGap(a.sphere, a.shape, b.sphere, b.shape, stop * scale);
      ASSERT_EQ(bitsOf(got), bitsOf(want))
          << "rep " << rep << " stop " << stop << ": " << got << " vs " << want;
      ++compared;
      separated += want > 0.f;
    }
  }
  // Both outcomes were met: boxes apart and boxes whose gap bound is not positive.
  EXPECT_GT(separated, compared / 10);
  EXPECT_LT(separated, compared - compared / 10);
}
#endif

// Two unit cubes (half extents 1), a turned 45 degrees about z (an edge along z at x = sqrt 2),
// b turned 45 degrees about y and placed at x = d (an edge along y at x = d - sqrt 2): they are
// d - 2 sqrt 2 apart along x, which is neither box's face normal, while along every face normal
// they overlap.
TEST(RecordBoxGap, FindsAGapOnlyAnEdgeAxisShows) {
  const double d = 3.0, want = d - 2 * std::sqrt(2.0);
  const Record a = boxRecord(1, 1, 1, rotatedAbout(fcl::Vector3d::UnitZ(), M_PI / 4, {0, 0, 0}));
  const Record b = boxRecord(1, 1, 1, rotatedAbout(fcl::Vector3d::UnitY(), M_PI / 4, {d, 0, 0}));
  // stop 0: the face axes show no gap above it, so the edge axes are tested.
  const float gap = cube::detail::recordBoxGap(a.sphere, a.shape, b.sphere, b.shape, 0.f);
  EXPECT_LE(gap, want);
  EXPECT_GT(gap, want - 1e-4);
  // Turned the other way round, the same gap.
  const float back = cube::detail::recordBoxGap(b.sphere, b.shape, a.sphere, a.shape, 0.f);
  EXPECT_LE(back, want);
  EXPECT_GT(back, want - 1e-4);
  // Moved closer until the edges cross: no positive gap.
  const Record c = boxRecord(1, 1, 1, rotatedAbout(fcl::Vector3d::UnitY(), M_PI / 4, {2.7, 0, 0}));
  EXPECT_LE(cube::detail::recordBoxGap(a.sphere, a.shape, c.sphere, c.shape, 0.f), 0.f);
}

// A gap the face axes show above `stop` is returned without the edge axes; below it, the edge
// axes can only raise it.
TEST(RecordBoxGap, FaceGapAboveStopIsReturnedAsIs) {
  const Record a = boxRecord(1, 1, 1, fcl::Transform3d::Identity());
  const Record b = boxRecord(1, 1, 1, rotatedAbout(fcl::Vector3d(1, 2, 3), 0.3, {5, 0, 0}));
  const float faces = cube::detail::recordBoxGap(a.sphere, a.shape, b.sphere, b.shape, 0.f);
  EXPECT_GT(faces, 2.f);
  EXPECT_LT(faces, 3.f);
  const float all = cube::detail::recordBoxGap(a.sphere, a.shape, b.sphere, b.shape,
                                               std::numeric_limits<float>::infinity());
  EXPECT_GE(all, faces);
  EXPECT_LT(all, 3.f);
}

}  // namespace
