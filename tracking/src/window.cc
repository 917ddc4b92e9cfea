// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/tracking/window.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>

#include "rvwo/ceres/barron_loss.h"
#include "rvwo/ceres/se2_manifold.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/kernels/barron.h"
#include "rvwo/tracking/wheel_checks.h"

namespace rvwo {
namespace {

// Ends the solve when the host asks (ORB-SLAM3's local mapping, when a new keyframe came): the
// state reached is kept, as g2o's force-stop flag keeps it.
class StopFlag final : public ceres::IterationCallback {
 public:
  explicit StopFlag(const bool* stop) : stop_(stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stopped() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
  bool stopped() const { return stop_ && *stop_; }

 private:
  const bool* stop_;
};

// Whether a wheel edge beyond its gate is one vision contradicts the way a slip does: the wheels
// claimed clearly more travel than the keyframes made, along their own direction, or clearly more
// turn, their own way. Among walkers, where a window may be pulled any way, the edges stay.
bool slipsAgainstTheWindow(const WheelEdge& edge, const Eigen::Vector3d& r) {
  const Eigen::Vector2d& dp = edge.delta().dp;
  const Eigen::Vector2d miss = -r.head<2>();  // the residual is what the keyframes made less the claim
  const double dphi = edge.delta().dphi, turn_miss = -r.z();
  const double along = dp.norm() < 0.02 ? 0.0 : miss.dot(dp.normalized());
  const bool travel_slip = along > 0.3 * dp.norm() && along * along > 0.6 * miss.squaredNorm();
  const bool turn_slip =
      std::fabs(dphi) >= 0.05 && turn_miss * dphi > 0 && std::fabs(turn_miss) > 0.3 * std::fabs(dphi);
  return travel_slip || turn_slip;
}

class WindowSolver {
 public:
  WindowSolver(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, const WindowProblem& pb,
               const WindowOptions& opt)
      : mono_(mono), stereo_(stereo), pb_(pb), opt_(opt), problem_(problemOptions()), stop_(opt.stop) {
    for (const WindowKeyFrame& k : pb.keyframes) x_.push_back(k.x_w_b);
    for (const WindowPoint& p : pb.points) P_.push_back(p.P_w);
    c_ = pb.calibration.c;
    for (const WindowKeyFrame& k : pb.keyframes) newest_t_ = std::max(newest_t_, k.t);
  }

  WindowSolution solve() {
    addObservations();
    addWheelEdges();
    addCalibration();
    const bool held = setManifolds();
    WindowSolution out;
    if ((held || !opt_.needs_a_fixed_keyframe) && problem_.NumResidualBlocks() > 0 && !stop_.stopped()) {
      out.ran = true;
      ceres::Solver::Summary summary;
      const bool two_rounds = opt_.outliers_leave || opt_.drop_slipping_wheel_edges || !calibrating_.empty() ||
                              std::any_of(wheels_.begin(), wheels_.end(), [](const Wheel& w) { return w.spin; });
      if (two_rounds) {
        run(opt_.first_round_iterations, &summary);
        betweenRounds(summary.IsSolutionUsable());
        if (!stop_.stopped()) run(opt_.second_round_iterations, &summary);
      } else {
        run(opt_.second_round_iterations, &summary);
      }
      out.usable = summary.IsSolutionUsable();
    }
    out.calibrated = out.ran && c_free_ && out.usable && c_.allFinite();  // learnt only from a solve
    return finish(std::move(out));
  }

 private:
  struct Wheel {
    WheelEdge edge;
    int a, b;
    bool slipped, spin;
    ceres::ResidualBlockId block;  // nullptr: not in the problem
  };

  static ceres::Problem::Options problemOptions() {
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    po.enable_fast_removal = true;  // outliers leave between the rounds
    return po;
  }

  // An SE(2)-XYZ edge per observation of a point that is not rejected and projects, for points
  // with min_views such observations.
  void addObservations() {
    const std::size_t n = pb_.observations.size();
    blocks_.assign(n, nullptr);
    std::vector<int> projecting(P_.size(), 0);
    std::vector<char> projects(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
      const WindowObservation& o = pb_.observations[k];
      if (pb_.points[o.point].alpha == -BarronKernel::kInfinity) continue;
      Eigen::Vector2d h;
      projects[k] = mono_.predict(x_[o.keyframe], P_[o.point], &h);
      projecting[o.point] += projects[k];
    }
    for (std::size_t k = 0; k < n; ++k) {
      const WindowObservation& o = pb_.observations[k];
      if (!projects[k] || projecting[o.point] < opt_.min_views) continue;
      const Eigen::Vector3d &x = x_[o.keyframe], &P = P_[o.point];
      ceres::CostFunction* cost;
      if (o.stereo) {
        if (!stereo_) throw std::invalid_argument("solveWindow: a stereo observation without a stereo edge");
        cost = new ceres_adapters::Se2XyzCost<3>(*stereo_, o.z,
                                                 stereo_->sqrtInformation(x, P, o.sigma_px, opt_.out_of_plane));
      } else {
        cost = new ceres_adapters::Se2XyzCost<2>(mono_, o.z.head<2>(),
                                                 mono_.sqrtInformation(x, P, o.sigma_px, opt_.out_of_plane));
      }
      ceres::LossFunction* loss = ceres_adapters::reprojectionLoss(opt_.huber, pb_.points[o.point].alpha,
                                                                   opt_.barron_scale, chi2Gate(o.stereo));
      blocks_[k] = problem_.AddResidualBlock(cost, loss, x_[o.keyframe].data(), P_[o.point].data());
    }
  }

  ceres::LossFunction* slippedLoss() const { return new ceres::HuberLoss(std::sqrt(opt_.slipped_wheel_chi2)); }

  // The wheel edges: a spin's waits for the second round; a slip's is under Huber and leaves the
  // calibration alone (it would take the slip for a scale error); the others are quadratic (among
  // walkers they hold the window to the static world) and calibrated.
  void addWheelEdges() {
    for (const WindowWheelEdge& w : pb_.wheels) {
      std::optional<WheelEdge> edge;
      try {
        edge.emplace(w.delta);
      } catch (const std::invalid_argument&) {  // degenerate covariance: no edge
        continue;
      }
      ceres::ResidualBlockId block = nullptr;
      if (w.spin) {
        // out of the first round
      } else if (!w.slipped && opt_.calibrate) {
        block = problem_.AddResidualBlock(new ceres_adapters::WheelCalibratedCost(*edge), nullptr, x_[w.a].data(),
                                          x_[w.b].data(), c_.data());
        calibrating_.push_back(block);
      } else {
        block = problem_.AddResidualBlock(new ceres_adapters::WheelCost(*edge), w.slipped ? slippedLoss() : nullptr,
                                          x_[w.a].data(), x_[w.b].data());
      }
      wheels_.push_back({*edge, w.a, w.b, w.slipped, w.spin, block});
    }
  }

  void addCalibration() {
    if (calibrating_.empty()) return;
    out_information_ = pb_.calibration.addPriors(&problem_, c_.data(), opt_.calibration_sigma, opt_.calibration_step,
                                                 opt_.calibration_period, newest_t_);
    if (opt_.hold_distance_scale) problem_.SetManifold(c_.data(), new ceres::SubsetManifold(3, {0}));
    c_free_ = true;
  }

  // SE(2) for every keyframe in the problem, the fixed ones held; whether any is.
  bool setManifolds() {
    bool held = false;
    for (std::size_t k = 0; k < x_.size(); ++k) {
      if (!problem_.HasParameterBlock(x_[k].data())) continue;
      problem_.SetManifold(x_[k].data(), new ceres_adapters::SE2Manifold);
      if (pb_.keyframes[k].fixed) {
        problem_.SetParameterBlockConstant(x_[k].data());
        held = true;
      }
    }
    return held;
  }

  void run(int iterations, ceres::Solver::Summary* summary) {
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;  // a window of poses, 3 each: dense Schur beats sparse
    so.num_threads = 1;                          // tracking runs beside it
    so.max_num_iterations = iterations;
    so.logging_type = ceres::SILENT;
    so.callbacks.push_back(&stop_);
    ceres::Solve(so, &problem_, summary);
  }

  void betweenRounds(bool usable) {
    const bool slip_found = judgeWheels(usable);
    // The calibration learns only from windows the wheels agree with once it is applied: a
    // differential drive's calibration cannot explain sideways motion, nor a turn scale that
    // changes from one window to the next (docs/decisions/0001).
    bool consistent = usable && !slip_found;
    for (std::size_t k = 0; consistent && k < wheels_.size(); ++k) {
      double cost = 0;
      if (wheels_[k].slipped || wheels_[k].spin) continue;
      consistent = problem_.EvaluateResidualBlock(wheels_[k].block, false, &cost, nullptr, nullptr) &&
                   2.0 * cost <= kChi2WheelOutlier;
    }
    if (c_free_ && !consistent) {
      c_ = pb_.calibration.c;
      problem_.SetParameterBlockConstant(c_.data());
      c_free_ = false;
    }
    if (opt_.outliers_leave) dropOutliers();
  }

  // Spin edges back where the first round's keyframes agree with them; slipping edges out.
  // Returns whether one was found slipping.
  bool judgeWheels(bool usable) {
    bool slip_found = false;
    for (Wheel& w : wheels_) {
      const Eigen::Vector3d r = w.edge.residual(x_[w.a], x_[w.b]);
      const bool agrees = (w.edge.sqrtInformation() * r).squaredNorm() <= kChi2WheelOutlier;
      if (w.spin) {
        if (usable && agrees && problem_.HasParameterBlock(x_[w.a].data()) &&
            problem_.HasParameterBlock(x_[w.b].data())) {
          w.block = problem_.AddResidualBlock(new ceres_adapters::WheelCost(w.edge), slippedLoss(), x_[w.a].data(),
                                              x_[w.b].data());
        }
        continue;
      }
      if (agrees || !opt_.drop_slipping_wheel_edges || !slipsAgainstTheWindow(w.edge, r)) continue;
      problem_.RemoveResidualBlock(w.block);
      w.block = nullptr;
      ++dropped_;
      slip_found = true;
    }
    return slip_found;
  }

  bool chi2Of(const WindowObservation& o, double* chi2) const {
    PoseObservation po;
    po.P_w = P_[o.point];
    po.z = o.z;
    po.stereo = o.stereo;
    po.sigma_px = o.sigma_px;
    return whitenedChi2(mono_, stereo_, po, x_[o.keyframe], opt_.out_of_plane, chi2);
  }

  // Observations beyond the gate leave; so does a point whose edges all left (mono: all but one),
  // which would make the Schur complement singular.
  void dropOutliers() {
    for (std::size_t k = 0; k < blocks_.size(); ++k) {
      double chi2 = 0;
      if (blocks_[k] && (!chi2Of(pb_.observations[k], &chi2) || chi2 > chi2Gate(pb_.observations[k].stereo))) {
        problem_.RemoveResidualBlock(blocks_[k]);
        blocks_[k] = nullptr;
      }
    }
    std::vector<int> edges_left(P_.size(), 0);
    for (std::size_t k = 0; k < blocks_.size(); ++k) edges_left[pb_.observations[k].point] += blocks_[k] != nullptr;
    for (std::size_t i = 0; i < P_.size(); ++i) {
      if (edges_left[i] < opt_.min_views && problem_.HasParameterBlock(P_[i].data())) {
        problem_.RemoveParameterBlock(P_[i].data());  // with its edges
      }
    }
  }

  WindowSolution finish(WindowSolution out) {
    const std::size_t n = pb_.observations.size();
    out.chi2.assign(n, 1e9);
    out.outlier.assign(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
      const WindowObservation& o = pb_.observations[k];
      out.outlier[k] = !chi2Of(o, &out.chi2[k]) || !(out.chi2[k] <= chi2Gate(o.stereo));
    }
    out.placed.assign(x_.size(), 0);
    for (std::size_t k = 0; k < x_.size(); ++k)
      out.placed[k] = !pb_.keyframes[k].fixed && problem_.HasParameterBlock(x_[k].data());
    out.solved.assign(P_.size(), 0);
    for (std::size_t i = 0; i < P_.size(); ++i) out.solved[i] = problem_.HasParameterBlock(P_[i].data());
    out.calibration = out.calibrated ? c_ : pb_.calibration.c;
    out.calibration_information = out_information_;
    out.newest_t = newest_t_;
    for (const Wheel& w : wheels_) out.wheel_edges += w.block != nullptr;
    out.wheel_edges_dropped = dropped_;
    out.x_w_b = std::move(x_);
    out.P_w = std::move(P_);
    return out;
  }

  const Se2XyzMonoEdge& mono_;
  const Se2XyzStereoEdge* stereo_;
  const WindowProblem& pb_;
  const WindowOptions& opt_;
  ceres::Problem problem_;
  StopFlag stop_;
  std::vector<Eigen::Vector3d> x_, P_;
  WheelCalibration c_;
  double newest_t_ = -1e300;
  std::vector<ceres::ResidualBlockId> blocks_;  // per observation; nullptr: not in the problem
  std::vector<Wheel> wheels_;
  std::vector<ceres::ResidualBlockId> calibrating_;
  Eigen::Matrix3d out_information_ = Eigen::Matrix3d::Zero();
  bool c_free_ = false;
  int dropped_ = 0;
};

}  // namespace

WindowSolution solveWindow(const Se2XyzMonoEdge& mono, const Se2XyzStereoEdge* stereo, const WindowProblem& problem,
                           const WindowOptions& options) {
  for (const WindowObservation& o : problem.observations) {
    if (o.keyframe < 0 || o.keyframe >= static_cast<int>(problem.keyframes.size()) || o.point < 0 ||
        o.point >= static_cast<int>(problem.points.size()))
      throw std::invalid_argument("solveWindow: an observation names a keyframe or point the problem lacks");
  }
  for (const WindowWheelEdge& w : problem.wheels) {
    if (w.a < 0 || w.b < 0 || w.a >= static_cast<int>(problem.keyframes.size()) ||
        w.b >= static_cast<int>(problem.keyframes.size()) || w.a == w.b)
      throw std::invalid_argument("solveWindow: a wheel edge names a keyframe the problem lacks");
  }
  return WindowSolver(mono, stereo, problem, options).solve();
}

}  // namespace rvwo
