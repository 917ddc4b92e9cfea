// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What the frame's pose solves (planar and spatial) share: which matches place the pose, and the
// IRLS weight of a match's squared whitened error. Private to rvwo::tracking.
#pragma once

#include <cmath>

#include "rvwo/kernels/barron.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo::tracking_detail {

// Whether a match may place the pose: usable, and not rejected by its kernel (Huber ignores alpha).
inline bool placesThePose(const PoseObservation& o, bool huber) {
  return o.usable && (huber || o.alpha != -BarronKernel::kInfinity);
}

// IRLS weight rho'(s) of a squared whitened error s: Huber at the gate's root, or Barron.
inline double weight(double s, const BarronKernel& kernel, bool huber, bool stereo) {
  if (huber) {
    const double c = std::sqrt(chi2Gate(stereo)), r = std::sqrt(s);
    return r <= c ? 1.0 : c / r;
  }
  double rho[3];
  kernel.evaluate(s, rho);
  return rho[1];
}

}  // namespace rvwo::tracking_detail
