// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/planar_pose.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

#include "robust_weight.h"

namespace rvwo {
namespace {

using tracking_detail::weight;

bool placesThePose(const PoseObservation& o, const PlanarPoseOptions& opt) {
  return tracking_detail::placesThePose(o, opt.huber);
}

// One Gauss-Newton term (w J^T J, w J^T r) of the whitened edge; false when it does not project.
template <int N>
bool accumulate(const Se2XyzEdge<N>& edge, const PoseObservation& o, const Eigen::Vector3d& x,
                const Eigen::Matrix<double, N, N>& S, const BarronKernel& kernel, bool huber, Eigen::Matrix3d* H,
                Eigen::Vector3d* g) {
  Eigen::Matrix<double, N, 1> r;
  Eigen::Matrix<double, N, 3> J;
  if (!edge.residual(x, o.P_w, o.z.head<N>(), &r, &J)) return false;
  const Eigen::Matrix<double, N, 1> rw = S * r;
  const Eigen::Matrix<double, N, 3> Jw = S * J;
  const double w = weight(rw.squaredNorm(), kernel, huber, N == 3);
  *H += w * Jw.transpose() * Jw;
  *g += w * Jw.transpose() * rw;
  return true;
}

// The match's whitened squared error at x, from one projection; with S_out, the square-root
// information it used (set only when the match projects, as only such a match can be an inlier).
template <int N>
bool chi2Of(const Se2XyzEdge<N>& edge, const PoseObservation& o, const Eigen::Vector3d& x, const OutOfPlaneNoise& noise,
            double* out, Eigen::Matrix<double, N, N>* S_out = nullptr) {
  Eigen::Matrix<double, N, 1> r;
  Eigen::Matrix<double, N, N> S;
  if (!edge.whitening(x, o.P_w, o.z.head<N>(), o.sigma_px, noise, &r, &S)) return false;
  *out = (S * r).squaredNorm();
  if (S_out) *S_out = S;
  return true;
}

}  // namespace

bool whitenedChi2(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, const PoseObservation& o,
                  const Eigen::Vector3d& x, const OutOfPlaneNoise& out_of_plane, double* chi2) {
  if (o.stereo) {
    if (!stereo) throw std::invalid_argument("optimisePlanarPose: a stereo observation without a stereo edge");
    return chi2Of(*stereo, o, x, out_of_plane, chi2);
  }
  return chi2Of(mono, o, x, out_of_plane, chi2);
}

PlanarPoseResult optimisePlanarPose(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo,
                                    const std::vector<PoseObservation>& obs, const WheelPrior& prior,
                                    const PlanarPoseOptions& opt, Eigen::Vector3d* x) {
  const std::size_t n = obs.size();
  PlanarPoseResult out;
  out.inlier.resize(n);
  for (std::size_t k = 0; k < n; ++k) out.inlier[k] = obs[k].first_round;
  out.error.assign(n, 0.0);
  std::vector<char> usable(n);
  std::vector<BarronKernel> kernel;  // per match, made once (its constants depend on alpha alone)
  kernel.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const PoseObservation& o = obs[k];
    if (o.stereo && !stereo)
      throw std::invalid_argument("optimisePlanarPose: a stereo observation without a stereo edge");
    usable[k] = placesThePose(o, opt);
    kernel.emplace_back(o.alpha, std::sqrt(chi2Gate(o.stereo)) * opt.barron_scale);
  }
  std::vector<Eigen::Matrix3d> S3(n);
  std::vector<Eigen::Matrix2d> S2(n);
  for (int round = 0; round < opt.rounds; ++round) {
    // Square-root information at this round's linearisation point (eq. 10, out-of-plane inflation).
    // After the first round, the last classification computed it at this same point.
    if (round == 0) {
      for (std::size_t k = 0; k < n; ++k) {
        if (!usable[k]) continue;
        if (obs[k].stereo) {
          S3[k] = stereo->sqrtInformation(*x, obs[k].P_w, obs[k].sigma_px, opt.out_of_plane);
        } else {
          S2[k] = mono.sqrtInformation(*x, obs[k].P_w, obs[k].sigma_px, opt.out_of_plane);
        }
      }
    }
    for (int it = 0; it < opt.iterations; ++it) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < n; ++k) {
        if (!usable[k] || !out.inlier[k]) continue;
        const bool ok = obs[k].stereo ? accumulate<3>(*stereo, obs[k], *x, S3[k], kernel[k], opt.huber, &H, &g)
                                      : accumulate<2>(mono, obs[k], *x, S2[k], kernel[k], opt.huber, &H, &g);
        if (!ok) out.inlier[k] = 0;
      }
      out.information = H;
      if (prior.edge) {
        Eigen::Matrix3d Jj;
        const Eigen::Matrix3d& S = prior.edge->sqrtInformation();
        const Eigen::Vector3d r = S * prior.edge->residual(prior.x_prev, *x, nullptr, &Jj);
        const Eigen::Matrix3d Jw = S * Jj;
        H += Jw.transpose() * Jw;
        g += Jw.transpose() * r;
      }
      H.diagonal().array() += 1e-9;  // no match and no prior: a zero step rather than NaN
      const Eigen::Vector3d dx = -H.ldlt().solve(g);
      if (!dx.allFinite()) break;
      *x += dx;
      x->z() = wrapAngle(x->z());
      if (dx.head<2>().norm() < 1e-6 && std::fabs(dx.z()) < 1e-7) break;
    }
    // Classify against the gate (every match, so that a rejected one may come back), keeping the
    // square-root information for the next round.
    out.inliers = 0;
    for (std::size_t k = 0; k < n; ++k) {
      double e2 = 1e9;
      if (obs[k].stereo) {
        chi2Of(*stereo, obs[k], *x, opt.out_of_plane, &e2, &S3[k]);
      } else {
        chi2Of(mono, obs[k], *x, opt.out_of_plane, &e2, &S2[k]);
      }
      out.error[k] = std::sqrt(e2);
      out.inlier[k] = usable[k] && e2 <= chi2Gate(obs[k].stereo);
      out.inliers += out.inlier[k];
    }
  }
  return out;
}

bool solveFromTheWheels(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, std::vector<PoseObservation> obs,
                        const WheelPrior& prior, const PlanarPoseOptions& opt, const Eigen::Vector3d& x_predicted,
                        const std::vector<char>& counted, int min_agree, Eigen::Vector3d* x, PlanarPoseResult* r) {
  if (counted.size() != obs.size()) throw std::invalid_argument("solveFromTheWheels: counted and obs differ in size");
  int agree = 0;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    double e2 = 1e9;
    PoseObservation& o = obs[k];
    o.first_round = placesThePose(o, opt) && whitenedChi2(mono, stereo, o, x_predicted, opt.out_of_plane, &e2) &&
                    e2 <= chi2Gate(o.stereo);
    agree += o.first_round && counted[k];
  }
  if (agree < min_agree) return false;
  *x = x_predicted;
  *r = optimisePlanarPose(mono, stereo, obs, prior, opt, x);
  return true;
}

}  // namespace rvwo
