#pragma once

// The planning examples' arm: a chain of links from the origin, a yaw joint at the base, then
// pitch and roll joints in turn, links alternately boxes and capsules. Shared by the OMPL
// example and the instruction counts of its checks (benchmarks/instructions.cpp), so that both
// check the very same robot.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>

#include <cmath>
#include <memory>
#include <vector>

namespace cube {
namespace scenes {

inline constexpr int kArmJoints = 7;
inline constexpr double kArmLink = 1.0;  // each link's length

/// The links' geometry, link 0 at the base.
inline std::vector<std::shared_ptr<fcl::CollisionGeometryd>> armGeometry() {
  std::vector<std::shared_ptr<fcl::CollisionGeometryd>> g;
  for (int i = 0; i < kArmJoints; ++i) {
    if (i % 2 == 0)
      g.push_back(std::make_shared<fcl::Boxd>(0.16, 0.16, kArmLink));
    else
      g.push_back(std::make_shared<fcl::Capsuled>(0.08, kArmLink - 0.16));
  }
  return g;
}

/// Forward kinematics: the links' poses (each the middle of its segment) for joints q[0 ..
/// kArmJoints). One sine and cosine per joint and a rotation about a frame axis applied to the
/// columns, as a planner's own kinematics does: a check costs a few microseconds, so a general
/// 4x4 product per joint would be a large share of it.
inline void armPoses(const double* q, fcl::Transform3d* out) {
  fcl::Matrix3d R = fcl::Matrix3d::Identity();
  fcl::Vector3d p = fcl::Vector3d::Zero();
  for (int i = 0; i < kArmJoints; ++i) {
    const double c = std::cos(q[i]), s = std::sin(q[i]);
    // R * rotation about local axis k (z for the base, then y and x in turn): two columns mix.
    const int k = i == 0 ? 2 : (i % 2 ? 1 : 0);
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const fcl::Vector3d ca = R.col(a), cb = R.col(b);
    R.col(a) = c * ca + s * cb;
    R.col(b) = c * cb - s * ca;
    out[i].linear() = R;
    out[i].translation() = p + (kArmLink / 2) * R.col(2);
    out[i].makeAffine();
    p += kArmLink * R.col(2);
  }
}

}  // namespace scenes
}  // namespace cube
