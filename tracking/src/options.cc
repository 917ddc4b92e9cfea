// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/options.h"

#include <stdexcept>
#include <string>

#include "rvwo/edges/se2_xyz_edge.h"

namespace rvwo {

OutOfPlaneNoise TrackingOptions::outOfPlane() const {
  OutOfPlaneNoise n;
  n.sigma_z = sigma_z;
  n.sigma_rollpitch = Eigen::Matrix2d::Identity() * sigma_rollpitch * sigma_rollpitch;
  return n;
}

void TrackingOptions::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("tracking options: " + what); };
  if (min_inliers < 6) fail("Tracking.MinInliers: >= 6");
  if (!(slip_min_inliers >= 1)) fail("Tracking.SlipMinInliers: >= 1 (times Tracking.MinInliers)");
  if (!(slip_hold >= 0)) fail("Tracking.SlipHold: >= 0 s");
  if (slip_hold_min_frames < 1) fail("Tracking.SlipHoldMinFrames: >= 1");
  if (!(trusted_max_ps > 0 && trusted_max_ps <= 1)) fail("Tracking.TrustedMaxPs: in (0, 1]");
  if (!(barron_scale > 0)) fail("Tracking.BarronScale: > 0");
  if (!(sigma_z >= 0)) fail("Tracking.SigmaZ: >= 0 m");
  if (!(sigma_rollpitch >= 0)) fail("Tracking.SigmaRollPitch: >= 0 rad");
}

}  // namespace rvwo
