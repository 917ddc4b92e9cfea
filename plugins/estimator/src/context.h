// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What every role of the estimator reads (front_end.h, map.h, wheels.h, tracker.h, mapper.h): the
// rig, the options, the camera's edges, and the stage timings they all add to. Fixed once the
// estimator is made, but for the timings (under their own lock). Private to the library.
#pragma once

#include <algorithm>
#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/estimator/estimator.h"
#include "rvwo/estimator/features.h"

namespace rvwo::estimator {

using Clock = std::chrono::steady_clock;
inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Milliseconds per named stage, in the order the stages first came.
class Timings {
 public:
  void add(const std::string& stage, double ms);
  std::vector<std::pair<std::string, TimingStats>> stats() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, std::vector<double>>> stages_;
};

struct Context {
  Context(const Rig& r, const EstimatorOptions& o);

  const Rig rig;
  const EstimatorOptions opt;
  const Se2XyzEdge<2> mono_edge;
  std::optional<Se2XyzEdge<3>> stereo_edge;  // stereo and RGB-D (rectified pinhole) only
  Timings timings;

  const Se2XyzEdge<3>* stereo() const { return stereo_edge ? &*stereo_edge : nullptr; }

  // A landmark the adaptive (or a fixed alpha = -inf) kernel rejects: its edges leave the problem.
  bool rejected(double alpha) const;

  // The camera's pose in the world at the robot pose x = (x, y, theta).
  Eigen::Isometry3d T_w_c(const Eigen::Vector3d& x) const { return SE2::fromVector(x).isometry3() * rig.T_b_c; }

  // Predicted (u, v, u_R) of P_w from x (mono: u_R = -1); false when it does not project.
  bool predict(const Eigen::Vector3d& x, const Eigen::Vector3d& P_w, Eigen::Vector3d* h) const;

  // Observation (u, v, u_R) of a frame's feature (u_R = -1 without stereo or depth).
  static Eigen::Vector3d observation(const Features& f, int i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    return Eigen::Vector3d(kp.pt.x, kp.pt.y, f.u_right[i]);
  }
  bool hasStereo(const Features& f, int i) const { return rig.sensor != Sensor::kMono && f.u_right[i] >= 0; }

  // A feature's pixel noise (px): Estimator.SigmaPx scaled to its pyramid level.
  double sigmaAt(int level) const;

  // Whitened chi2 of observation z = (u, v, u_R) at x (u_R unused unless stereo), with the
  // information at x (rvwo::whitenedChi2); false when the point does not project.
  bool chi2(bool stereo, const Eigen::Vector3d& x, const Eigen::Vector3d& P, const Eigen::Vector3d& z, double sigma,
            double* out) const;
};

}  // namespace rvwo::estimator
