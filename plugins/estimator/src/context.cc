// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "context.h"

#include <cmath>

#include "rvwo/kernels/barron.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo::estimator {

void Timings::add(const std::string& stage, double ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = std::find_if(stages_.begin(), stages_.end(), [&](const auto& s) { return s.first == stage; });
  if (it == stages_.end()) {
    stages_.emplace_back(stage, std::vector<double>{});
    it = std::prev(stages_.end());
  }
  it->second.push_back(ms);
}

std::vector<std::pair<std::string, TimingStats>> Timings::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<std::string, TimingStats>> out;
  for (const auto& [name, v] : stages_) out.emplace_back(name, TimingStats::of(v));
  return out;
}

Context::Context(const Rig& r, const EstimatorOptions& o) : rig(r), opt(o), mono_edge(*r.camera, r.T_b_c) {
  if (r.sensor != Sensor::kMono) stereo_edge.emplace(*r.camera, r.T_b_c, r.bf());
}

bool Context::rejected(double alpha) const {
  return opt.kernel != KernelChoice::kHuber && alpha == -BarronKernel::kInfinity;
}

bool Context::predict(const Eigen::Vector3d& x, const Eigen::Vector3d& P_w, Eigen::Vector3d* h) const {
  if (stereo_edge) return stereo_edge->predict(x, P_w, h);
  Eigen::Vector2d uv;
  if (!mono_edge.predict(x, P_w, &uv)) return false;
  *h << uv, -1.0;
  return true;
}

double Context::sigmaAt(int level) const { return opt.sigma_px * std::pow(opt.scale_factor, level); }

bool Context::chi2(bool stereo, const Eigen::Vector3d& x, const Eigen::Vector3d& P, const Eigen::Vector3d& z,
                   double sigma, double* out) const {
  PoseObservation o;
  o.P_w = P;
  o.z = z;
  o.stereo = stereo;
  o.sigma_px = sigma;
  return whitenedChi2(mono_edge, this->stereo(), o, x, opt.tracking.outOfPlane(), out);
}

}  // namespace rvwo::estimator
