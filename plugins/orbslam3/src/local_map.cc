// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// ORB-SLAM3's local and global maps on SE(2) through RVWO's window bundle adjustment
// (rvwo::solveWindow), and its essential graph after a loop with wheel edges.
#include <ceres/ceres.h>

#include "wheel_input_impl.h"

namespace rvwo::orbslam3 {

bool WheelInput::optimisesLocalMaps() const {
  return optimisesPoses() && impl_->params.wheels && impl_->params.local_map;
}

// The problem on the plane: keyframes as robot poses x_w_b (out of the plane parts dropped, as
// tracking drops them), points in the planar world (T_w_c0 = T_b_c), each point's shape (eq. 7),
// and the wheels between keyframes (ORB-SLAM3's local window is the covisible keyframes: mostly
// the last ones, whose wheel edges chain them to the fixed ones before). Locks the mutex.
WindowProblem WheelInput::Impl::windowProblem(const LocalMapProblem& pb, std::vector<Span>* spans) {
  WindowProblem w;
  const std::size_t nk = pb.keyframes.size();
  std::vector<double> t(nk);
  std::vector<char> fixed(nk);
  for (std::size_t k = 0; k < nk; ++k) {
    const MapKeyFrame& kf = pb.keyframes[k];
    w.keyframes.push_back({planarOf(kf.T_c_w), kf.t, kf.fixed});
    t[k] = kf.t;
    fixed[k] = kf.fixed;
  }
  const bool has_stereo = pb.keyframes.front().bf > 0;
  for (const MapObservation& o : pb.observations) {
    w.observations.push_back({o.keyframe, o.point, Eigen::Vector3d(o.u, o.v, o.u_right), o.u_right >= 0 && has_stereo,
                              std::pow(pb.scale_factor, o.level)});
  }
  std::lock_guard<std::mutex> lock(mutex);
  for (const MapPointEstimate& p : pb.points)
    w.points.push_back({params.T_b_c * p.P_w, params.huber ? 1.0 : reliability.alpha(p.id)});
  w.calibration = calibration;
  *spans = wheelSpans(t, fixed);
  for (const Span& sp : *spans)
    w.wheels.push_back({static_cast<int>(sp.a), static_cast<int>(sp.b), sp.delta, sp.slipped, sp.spin});
  return w;
}

// ORB-SLAM3's contract: outliers judged but not dropped between the rounds (it erases them
// afterwards), nothing solved unless a fixed keyframe holds the window, the abort flag obeyed.
WindowOptions WheelInput::Impl::windowOptions(const ceres_adapters::WheelCalibrationEstimate& cal,
                                              const bool* stop) const {
  WindowOptions o;
  o.huber = params.huber;
  o.barron_scale = params.tracking.barron_scale;
  o.out_of_plane = params.tracking.outOfPlane();
  o.min_views = 1;
  o.outliers_leave = false;
  o.drop_slipping_wheel_edges = false;
  o.slipped_wheel_chi2 = kChi2WheelOutlier;
  o.calibrate = params.calibrate;
  o.hold_distance_scale = !params.calibrate_distance;
  o.calibration_sigma = params.calibration_sigma;
  o.calibration_step = cal.counting ? params.calibration_drift : params.calibration_step;
  o.calibration_period = params.calibration_period;
  o.needs_a_fixed_keyframe = true;
  o.stop = stop;
  return o;
}

bool WheelInput::optimiseLocalMap(const LocalMapProblem& pb, LocalMapSolution* out, const bool* stop) {
  if (!optimisesLocalMaps()) return false;
  Impl& m = *impl_;
  const std::size_t nk = pb.keyframes.size(), np = pb.points.size();
  out->T_c_w.resize(nk);
  out->P_w = std::vector<Eigen::Vector3d>(np);
  out->placed.assign(nk, 0);
  out->solved.assign(np, 0);
  out->outlier.assign(pb.observations.size(), 0);
  out->wheel_edges = 0;
  out->calibrated = false;
  for (std::size_t k = 0; k < nk; ++k) out->T_c_w[k] = pb.keyframes[k].T_c_w;
  for (std::size_t i = 0; i < np; ++i) out->P_w[i] = pb.points[i].P_w;
  if (nk == 0) return true;

  std::vector<Impl::Span> spans;
  const WindowProblem w = m.windowProblem(pb, &spans);
  const MapKeyFrame& k0 = pb.keyframes.front();
  const PinholeCamera camera(k0.fx, k0.fy, k0.cx, k0.cy);
  const Se2XyzMonoEdge mono(camera, m.params.T_b_c);
  std::optional<Se2XyzStereoEdge> stereo;  // none for mono (bf 0)
  if (k0.bf > 0) stereo.emplace(camera, m.params.T_b_c, k0.bf);
  const WindowSolution sol = solveWindow(mono, stereo ? &*stereo : nullptr, w, m.windowOptions(w.calibration, stop));
  if (sol.ran) ++m.local_maps_solved;
  out->wheel_edges = sol.wheel_edges;
  out->calibrated = sol.calibrated;
  if (sol.calibrated) {
    ++m.local_maps_calibrated;
    m.learnCalibration(w, spans, sol);
  }
  out->outlier.assign(sol.outlier.begin(), sol.outlier.end());
  const Eigen::Isometry3d T_c0_w = m.params.T_b_c.inverse();
  // What was not in the problem (no edge: a keyframe neither seeing nor reached by the wheels, a
  // rejected point) stays as given.
  for (std::size_t k = 0; k < nk; ++k)
    if (sol.placed[k]) {
      out->T_c_w[k] = m.cameraOf(sol.x_w_b[k]);
      out->placed[k] = 1;
    }
  for (std::size_t i = 0; i < np; ++i)
    if (sol.solved[i]) {
      out->P_w[i] = T_c0_w * sol.P_w[i];
      out->solved[i] = 1;
    }
  return true;
}

// The calibration a local map taught, with what it knew of it (counting: the priors' and the
// information of the calibrated wheel edges ending after the last local map that refined it).
void WheelInput::Impl::learnCalibration(const WindowProblem& w, const std::vector<Span>& spans,
                                        const WindowSolution& sol) {
  Eigen::Matrix3d known = sol.calibration_information;
  const ceres_adapters::WheelCalibrationEstimate& cal = w.calibration;
  for (const Span& sp : spans) {
    if (sp.spin || sp.slipped || !params.calibrate || !cal.counting || w.keyframes[sp.b].t <= cal.t) continue;
    try {
      const WheelEdge edge(sp.delta);
      known += ceres_adapters::wheelCalibrationInformation(edge, sol.x_w_b[sp.a], sol.x_w_b[sp.b], sol.calibration);
    } catch (const std::invalid_argument&) {  // degenerate covariance: no edge
    }
  }
  std::lock_guard<std::mutex> lock(mutex);
  calibration.refined(sol.calibration, sol.newest_t, known);
}

bool WheelInput::optimisesEssentialGraphs() const { return optimisesLocalMaps() && impl_->params.essential_graph; }

bool WheelInput::optimiseEssentialGraph(const EssentialGraph& g, EssentialGraphSolution* out) {
  if (!optimisesEssentialGraphs()) return false;
  Impl& m = *impl_;
  const std::size_t nk = g.keyframes.size();
  out->T_c_w.resize(nk);
  out->wheel_edges = 0;
  std::vector<Eigen::Vector3d> x(nk);
  std::vector<double> t(nk);
  std::vector<char> fixed(nk);
  for (std::size_t k = 0; k < nk; ++k) {
    out->T_c_w[k] = g.keyframes[k].T_c_w;
    x[k] = m.planarOf(g.keyframes[k].T_c_w);
    t[k] = g.keyframes[k].t;
    fixed[k] = g.keyframes[k].fixed;
  }
  std::vector<Impl::Span> spans;
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    spans = m.wheelSpans(t, fixed);
  }

  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  // Vision's relative poses on the plane, in eq. 14's form (the residual of any measured T_bi_bj).
  // ORB-SLAM3 weighs them all alike (identity information on sim(3)); with the wheel edges beside
  // them they need a covariance of their own: graph_sigma_*.
  const Eigen::Isometry3d& T_b_c = m.params.T_b_c;
  WheelDelta seen;
  const double s_xy = m.params.graph_sigma_xy, s_yaw = m.params.graph_sigma_yaw;
  seen.covariance = Eigen::Vector3d(s_xy * s_xy, s_xy * s_xy, s_yaw * s_yaw).asDiagonal();
  for (const GraphEdge& e : g.edges) {
    if (e.i == e.j || e.i < 0 || e.j < 0 || static_cast<std::size_t>(std::max(e.i, e.j)) >= nk) continue;
    const SE2 T_bi_bj = planar(T_b_c * e.T_cj_ci.inverse() * T_b_c.inverse());
    seen.dp = T_bi_bj.translation();
    seen.dphi = T_bi_bj.angle();
    problem.AddResidualBlock(new ceres_adapters::WheelCost(WheelEdge(seen)), nullptr, x[e.i].data(), x[e.j].data());
  }
  for (const Impl::Span& sp : spans) {
    try {
      const WheelEdge edge(sp.delta);
      // Across a slip tracking caught, Huber at the 99.9 % gate, as in the local map.
      problem.AddResidualBlock(new ceres_adapters::WheelCost(edge),
                               sp.slipped ? new ceres::HuberLoss(std::sqrt(kChi2WheelOutlier)) : nullptr,
                               x[sp.a].data(), x[sp.b].data());
      ++out->wheel_edges;
    } catch (const std::invalid_argument&) {  // degenerate covariance: no edge
    }
  }
  for (std::size_t k = 0; k < nk; ++k) {
    if (!problem.HasParameterBlock(x[k].data())) continue;
    problem.SetManifold(x[k].data(), new ceres_adapters::SE2Manifold);
    if (fixed[k]) problem.SetParameterBlockConstant(x[k].data());
  }
  if (problem.NumResidualBlocks() == 0) return true;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;  // hundreds of keyframes, a few edges each
  so.max_num_iterations = 20;                             // ORB-SLAM3's
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) return true;  // as given
  for (std::size_t k = 0; k < nk; ++k)
    if (!fixed[k] && problem.HasParameterBlock(x[k].data())) out->T_c_w[k] = m.cameraOf(x[k]);
  return true;
}

}  // namespace rvwo::orbslam3
