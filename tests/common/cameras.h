// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Camera mounts the tests share.
#pragma once

#include <Eigen/Geometry>

namespace rvwo::test {

// T_b_c of a camera looking ahead (camera z along body x, camera x along -body y, camera y down),
// pitched down by pitch_down rad (negative: up) about the body's y axis, at p_b_c in the body.
inline Eigen::Isometry3d lookingAhead(double pitch_down, const Eigen::Vector3d& p_b_c) {
  Eigen::Matrix3d R_b_c;
  R_b_c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() = Eigen::AngleAxisd(pitch_down, Eigen::Vector3d::UnitY()).toRotationMatrix() * R_b_c;
  T_b_c.translation() = p_b_c;
  return T_b_c;
}

}  // namespace rvwo::test
