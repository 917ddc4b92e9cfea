// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-demo: the RVWO components end to end on a simulated run, solved four ways.
//
// A wheeled robot with a forward-looking stereo camera (640x480, 0.12 m baseline) drives laps of
// a room whose walls carry static landmarks, while people walk across its view (their landmarks
// move with them and are labelled "person" by a simulated segmenter that misses 10 % of the
// time). Its wheel encoders (50 Hz) are noisy and slip once: the wheels spin for two seconds while
// the robot stands still. The whole run is solved as one planar bundle adjustment on SE(2) with
// Ceres, with RVWO's SE(2)-XYZ stereo edges and wheel edges:
//
//   wheel        dead reckoning from the preintegrated encoders alone
//   vo-huber     visual edges only, Huber kernel
//   vw-huber     visual and wheel edges, Huber kernel
//   vw-adaptive  visual and wheel edges, each landmark's Barron shape from the reliability model
//                (semantic labels and reprojection errors, paper eqs. 4 to 7)
//
// It prints the absolute trajectory error (RMSE after a planar rigid alignment) of each and
// writes a PNG of the trajectories. This is a demonstration of the components on known data
// association, not the tracking and mapping pipeline (that is rvwo-replay's job).
#include <ceres/ceres.h>
#include <glog/logging.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "rvwo/ceres/barron_loss.h"
#include "rvwo/ceres/costs.h"
#include "rvwo/ceres/se2_manifold.h"
#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/kernels/reliability.h"
#include "rvwo/kernels/semantic_priors.h"
#include "support/command_line.h"
#include "support/plot.h"
#include "support/trajectory.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Landmark {
  Eigen::Vector3d p;  // static: world position; walker: offset from the walker's centre
  int walker = -1;    // -1: static
};

struct Walker {  // walks back and forth along a segment at constant speed
  Eigen::Vector2d a, b;
  double speed, phase;
  Eigen::Vector2d at(double t) const {
    const double len = (b - a).norm(), s = std::fmod(speed * t + phase, 2 * len);
    return a + (b - a) * ((s < len ? s : 2 * len - s) / len);
  }
};

struct Obs {
  int kf, lm;
  Eigen::Vector3d z;  // u_L, v, u_R
  bool person_label;
};

// Robot path: laps of a rounded rectangle (straights of 6 and 4 m, quarter turns of radius 1 m)
// inside the room at 0.5 m/s; the pose at time t composes the SE(2) exponentials of the pieces.
rvwo::SE2 robotAt(double t) {
  const double v = 0.5, r = 1.0, quarter = 0.5 * kPi * r;
  const double len[8] = {6, quarter, 4, quarter, 6, quarter, 4, quarter};
  const double curvature[8] = {0, 1 / r, 0, 1 / r, 0, 1 / r, 0, 1 / r};
  double lap = 0;
  for (double l : len) lap += l;
  double s = std::fmod(v * t, lap);
  rvwo::SE2 T(-3.0, -3.0, 0.0);
  for (int i = 0; i < 8; ++i) {
    const double d = std::min(s, len[i]);
    T = T * rvwo::SE2::exp(Eigen::Vector3d(d, 0, curvature[i] * d));
    s -= d;
    if (s <= 0) break;
  }
  return T;
}

// ATE: RMSE of the positions after a planar rigid alignment (rvwo-eval's posyaw on z = 0).
double ate(const std::vector<rvwo::SE2>& est, const std::vector<rvwo::SE2>& gt) {
  std::vector<Eigen::Vector3d> e, g;
  for (std::size_t i = 0; i < est.size(); ++i) {
    e.emplace_back(est[i].translation().x(), est[i].translation().y(), 0.0);
    g.emplace_back(gt[i].translation().x(), gt[i].translation().y(), 0.0);
  }
  const rvwo::apps::Similarity A = rvwo::apps::align(g, e, rvwo::apps::Alignment::kPosYaw);
  std::vector<double> errors;
  for (std::size_t i = 0; i < e.size(); ++i) errors.push_back((g[i] - A.apply(e[i])).norm());
  return rvwo::apps::statistics(errors).rmse;
}

// One simulated run, solved four ways; fills the ATE of each mode (wheel, vo-huber, vw-huber,
// vw-adaptive) and writes the plot when plot_path is not empty.
struct RunResult {
  std::size_t keyframes = 0, landmarks = 0, observations = 0;
  double path = 0, slip_from = 0, slip_to = 0;
  double ate[4] = {0, 0, 0, 0};
};

enum class Mode { kVoHuber, kVwHuber, kVwAdaptive };

// One run: the scene, the wheels and the keyframes' observations simulated from one seed (in that
// order, so that the random draws are the run's), then solved.
class DemoRun {
 public:
  DemoRun(unsigned seed, double seconds, int n_walkers)
      : rng_(seed), edge_(camera_, T_b_c_, kBf), seconds_(seconds), slip_from_(0.4 * seconds) {
    makeScene(n_walkers);
    simulateWheels();
    observe();
    wheel_only_.push_back(truth_[0]);  // dead reckoning from the start
    for (std::size_t k = 0; k + 1 < truth_.size(); ++k) {
      deltas_.push_back(odometry_.integrate(kf_time_[k], kf_time_[k + 1]));
      wheel_only_.push_back(wheel_only_.back() * deltas_.back().pose());
    }
  }

  RunResult result(unsigned seed, const std::string& plot_path) {
    std::vector<rvwo::SE2> vo = solve(Mode::kVoHuber), vw = solve(Mode::kVwHuber), vwa = solve(Mode::kVwAdaptive);
    RunResult r;
    for (std::size_t k = 0; k + 1 < truth_.size(); ++k)
      r.path += (truth_[k + 1].translation() - truth_[k].translation()).norm();
    r.keyframes = truth_.size();
    r.landmarks = landmarks_.size();
    r.observations = obs_.size();
    r.slip_from = slip_from_;
    r.slip_to = slip_from_ + kSlip;
    const std::vector<rvwo::SE2>* trajectories[4] = {&wheel_only_, &vo, &vw, &vwa};
    for (int m = 0; m < 4; ++m) r.ate[m] = ate(*trajectories[m], truth_);
    if (!plot_path.empty()) plot(seed, plot_path, vo, vw, vwa);
    return r;
  }

 private:
  static constexpr double kBf = 0.12 * 400;  // stereo baseline times fx
  static constexpr double kTick = 0.02;      // s between encoder readings (50 Hz)
  static constexpr double kSlip = 2.0;       // s the wheels spin while the robot stands
  static constexpr int kStride = 25;         // ticks between keyframes (0.5 s)

  static Eigen::Isometry3d cameraMount() {
    Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
    T_b_c.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    T_b_c.translation() << 0.15, 0.0, 0.5;
    return T_b_c;
  }

  // Static landmarks on the walls of a 12 x 9 m room; walkers with 60 landmarks each on a 0.25 m
  // cylinder, 0.2 to 1.8 m up.
  void makeScene(int n_walkers) {
    for (int i = 0; i < 1600; ++i) {
      const double s = u_(rng_), z = 0.1 + 2.4 * u_(rng_);
      const int wall = i % 4;
      Eigen::Vector3d p = wall == 0   ? Eigen::Vector3d(-6 + 12 * s, -4.5, z)
                          : wall == 1 ? Eigen::Vector3d(6, -4.5 + 9 * s, z)
                          : wall == 2 ? Eigen::Vector3d(-6 + 12 * s, 4.5, z)
                                      : Eigen::Vector3d(-6, -4.5 + 9 * s, z);
      landmarks_.push_back({p, -1});
    }
    for (int w = 0; w < n_walkers; ++w) {
      const double x = -3 + 6 * u_(rng_);
      people_.push_back(
          {Eigen::Vector2d(x, -3.5), Eigen::Vector2d(x + 2 * u_(rng_) - 1, 3.5), 0.6 + 0.6 * u_(rng_), 7 * u_(rng_)});
      for (int k = 0; k < 60; ++k) {
        const double a = 2 * kPi * u_(rng_);
        landmarks_.push_back({Eigen::Vector3d(0.25 * std::cos(a), 0.25 * std::sin(a), 0.2 + 1.6 * u_(rng_)), w});
      }
    }
  }

  // 50 Hz encoders from the true motion, noisy, slipping at 40 % of the run; the true pose at each
  // tick (the robot stands during the slip).
  void simulateWheels() {
    rvwo::WheelNoise noise;
    noise.sigma_wheel = 0.02;
    odometry_ = rvwo::WheelOdometry(noise);
    double ql = 0, qr = 0;
    double robot_time = 0;  // arc-length clock of the path
    odometry_.addWheelAngles(0, 0, 0, drive_);
    truth_at_.push_back(robotAt(0));
    const int ticks = static_cast<int>(std::lround(seconds_ / kTick));
    for (int i = 1; i <= ticks; ++i) {
      const double t = i * kTick;  // from the tick count, so keyframe times match reading times exactly
      const bool slipping = t > slip_from_ && t <= slip_from_ + kSlip;
      const rvwo::SE2 a = robotAt(robot_time);
      if (!slipping) robot_time += kTick;
      const rvwo::SE2 b = robotAt(robot_time);
      // Encoders: the true motion, or during the slip the motion the wheels would have made.
      const rvwo::SE2 wheel_motion = slipping ? robotAt(robot_time).between(robotAt(robot_time + kTick)) : a.between(b);
      const Eigen::Vector3d xi = wheel_motion.log();
      const double dql = (xi.x() - xi.z() * drive_.track / 2) / drive_.radius_left;
      const double dqr = (xi.x() + xi.z() * drive_.track / 2) / drive_.radius_right;
      ql += dql + noise.sigma_wheel * std::sqrt(std::fabs(dql)) * g_(rng_);
      qr += dqr + noise.sigma_wheel * std::sqrt(std::fabs(dqr)) * g_(rng_);
      odometry_.addWheelAngles(t, ql, qr, drive_);
      truth_at_.push_back(b);
    }
  }

  // Keyframes every 0.5 s: the stereo observations the tracker keeps (a third of the static
  // points, every walker's), 1 px noise, and a label: "person" for a walker's 90 % of the time.
  void observe() {
    for (std::size_t i = 0; i < truth_at_.size(); i += kStride) {
      kf_time_.push_back(i * kTick);
      truth_.push_back(truth_at_[i]);
    }
    seen_.assign(landmarks_.size(), 0);
    const Eigen::Isometry3d T_c_b = T_b_c_.inverse();
    for (std::size_t k = 0; k < truth_.size(); ++k) {
      const Eigen::Vector3d x = truth_[k].vector();
      for (std::size_t l = 0; l < landmarks_.size(); ++l) {
        const Landmark& L = landmarks_[l];
        Eigen::Vector3d P = L.p;
        if (L.walker >= 0) P.head<2>() += people_[L.walker].at(kf_time_[k]);
        Eigen::Vector3d h;
        if (!edge_.predict(x, P, &h)) continue;
        const Eigen::Vector2d p_b = truth_[k].inverse().act(P.head<2>());
        const Eigen::Vector3d P_c = T_c_b * Eigen::Vector3d(p_b.x(), p_b.y(), P.z());
        if (P_c.z() < 0.4 || P_c.z() > 12 || h.x() < 0 || h.x() >= 640 || h.y() < 0 || h.y() >= 480 || h.z() < 0)
          continue;
        if (L.walker < 0 && u_(rng_) > 0.35) continue;  // the tracker keeps a subset of the static points
        const bool person = L.walker >= 0 ? u_(rng_) < 0.9 : u_(rng_) < 0.02;
        const double nz = g_(rng_), ny = g_(rng_), nx = g_(rng_);  // z first, on every compiler
        obs_.push_back({static_cast<int>(k), static_cast<int>(l), h + Eigen::Vector3d(nx, ny, nz), person});
        ++seen_[l];
      }
    }
    obs_at_.resize(truth_.size());
    for (std::size_t i = 0; i < obs_.size(); ++i) obs_at_[obs_[i].kf].push_back(static_cast<int>(i));
  }

  static ceres::LossFunction* lossFor(Mode mode, double alpha) {
    if (mode == Mode::kVwAdaptive) return new rvwo::ceres_adapters::BarronLoss(alpha, 1.0);
    return new ceres::HuberLoss(1.0);
  }

  // The run solved one way: tracked keyframe by keyframe, then one bundle adjustment.
  std::vector<rvwo::SE2> solve(Mode mode) {
    Estimate e{std::vector<Eigen::Vector3d>(truth_.size()),
               std::vector<Eigen::Vector3d>(landmarks_.size(), Eigen::Vector3d::Zero()),
               std::vector<bool>(landmarks_.size(), false), rvwo::ReliabilityManager()};
    track(mode, &e);
    bundleAdjust(mode, &e);
    std::vector<rvwo::SE2> out;
    for (const auto& xk : e.x) out.push_back(rvwo::SE2::fromVector(xk));
    return out;
  }

  struct Estimate {
    std::vector<Eigen::Vector3d> x, P;
    std::vector<bool> mapped;
    rvwo::ReliabilityManager reliability;
  };

  // Keyframe by keyframe: predict, optimise the pose alone against the mapped landmarks (with the
  // wheel edge to the previous keyframe in vw modes), then map new ones from the stereo pair.
  void track(Mode mode, Estimate* e) {
    const rvwo::SemanticPriors priors = rvwo::SemanticPriors::builtin("voc21");
    const double p_person = priors.prior(priors.labelOf("person")), p_background = priors.prior(0);
    for (std::size_t k = 0; k < truth_.size(); ++k) {
      if (k == 0) {
        e->x[0] = truth_[0].vector();
      } else if (mode == Mode::kVoHuber) {  // constant velocity
        const rvwo::SE2 prev = rvwo::SE2::fromVector(e->x[k - 1]);
        const rvwo::SE2 vel = k > 1 ? rvwo::SE2::fromVector(e->x[k - 2]).between(prev) : rvwo::SE2();
        e->x[k] = (prev * vel).vector();
      } else {
        e->x[k] = (rvwo::SE2::fromVector(e->x[k - 1]) * deltas_[k - 1].pose()).vector();
      }
      for (int i : obs_at_[k]) {
        const Obs& o = obs_[i];
        e->reliability.observe(o.lm, o.person_label ? p_person : p_background, std::nullopt);
      }
      if (k > 0) optimiseKeyFramePose(mode, k, e);
      for (int i : obs_at_[k]) {
        const Obs& o = obs_[i];
        if (e->mapped[o.lm]) continue;
        const double disparity = o.z.x() - o.z.z();
        if (disparity < 1.0) continue;
        const Eigen::Vector3d P_b = T_b_c_ * ((kBf / disparity) * camera_.unproject(o.z.head<2>()));
        const Eigen::Vector2d xy = rvwo::SE2::fromVector(e->x[k]).act(P_b.head<2>());
        e->P[o.lm] = Eigen::Vector3d(xy.x(), xy.y(), P_b.z());
        e->mapped[o.lm] = true;
      }
    }
  }

  void optimiseKeyFramePose(Mode mode, std::size_t k, Estimate* e) {
    ceres::Problem problem;
    int used = 0;
    for (int i : obs_at_[k]) {
      const Obs& o = obs_[i];
      const double alpha = e->reliability.alpha(o.lm);
      Eigen::Vector3d h;
      if (!e->mapped[o.lm] || (mode == Mode::kVwAdaptive && std::isinf(alpha)) ||
          !edge_.predict(e->x[k], e->P[o.lm], &h))
        continue;
      problem.AddResidualBlock(new rvwo::ceres_adapters::Se2XyzCost<3>(edge_, o.z, Eigen::Matrix3d::Identity()),
                               lossFor(mode, alpha), e->x[k].data(), e->P[o.lm].data());
      problem.SetParameterBlockConstant(e->P[o.lm].data());
      ++used;
    }
    if (mode != Mode::kVoHuber) {
      problem.AddResidualBlock(new rvwo::ceres_adapters::WheelCost(rvwo::WheelEdge(deltas_[k - 1])), nullptr,
                               e->x[k - 1].data(), e->x[k].data());
      problem.SetParameterBlockConstant(e->x[k - 1].data());
    }
    if (used == 0 && mode == Mode::kVoHuber) return;
    problem.SetManifold(e->x[k].data(), new rvwo::ceres_adapters::SE2Manifold);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 20;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
  }

  // One bundle adjustment over the whole run, in two rounds: after the first, edges beyond the
  // stereo chi2 gate (7.815, 95 %) are outliers and leave the second, as ORB-SLAM does. The
  // adaptive kernel also refreshes each landmark's outlier probability from its errors (eq. 6)
  // between rounds.
  void bundleAdjust(Mode mode, Estimate* e) {
    std::vector<bool> outlier(obs_.size(), false);
    for (int round = 0; round < 2; ++round) {
      ceres::Problem problem;
      for (std::size_t i = 0; i < obs_.size(); ++i) {
        const Obs& o = obs_[i];
        if (seen_[o.lm] < 2 || !e->mapped[o.lm] || outlier[i]) continue;
        Eigen::Vector3d h;
        if (!edge_.predict(e->x[o.kf], e->P[o.lm], &h)) continue;
        const double alpha = e->reliability.alpha(o.lm);
        // alpha = -inf rejects the landmark: its edges leave the problem (a point held only by
        // zero-weight residuals would make the Schur complement singular).
        if (mode == Mode::kVwAdaptive && std::isinf(alpha)) continue;
        problem.AddResidualBlock(new rvwo::ceres_adapters::Se2XyzCost<3>(edge_, o.z, Eigen::Matrix3d::Identity()),
                                 lossFor(mode, alpha), e->x[o.kf].data(), e->P[o.lm].data());
      }
      if (mode != Mode::kVoHuber) {
        for (std::size_t k = 0; k + 1 < e->x.size(); ++k) {
          problem.AddResidualBlock(new rvwo::ceres_adapters::WheelCost(rvwo::WheelEdge(deltas_[k])), nullptr,
                                   e->x[k].data(), e->x[k + 1].data());
        }
      }
      for (auto& xk : e->x) {
        if (problem.HasParameterBlock(xk.data())) problem.SetManifold(xk.data(), new rvwo::ceres_adapters::SE2Manifold);
      }
      if (problem.HasParameterBlock(e->x[0].data())) problem.SetParameterBlockConstant(e->x[0].data());
      ceres::Solver::Options so;
      so.linear_solver_type = ceres::SPARSE_SCHUR;
      so.max_num_iterations = 50;
      so.num_threads = 1;  // deterministic: same seed, same numbers
      ceres::Solver::Summary summary;
      ceres::Solve(so, &problem, &summary);
      for (std::size_t i = 0; i < obs_.size(); ++i) {
        Eigen::Vector3d r;
        outlier[i] = !edge_.residual(e->x[obs_[i].kf], e->P[obs_[i].lm], obs_[i].z, &r) || r.squaredNorm() > 7.815;
      }
      if (mode == Mode::kVwAdaptive) refreshOutlierProbabilities(e);
    }
  }

  // Eq. 6: each landmark's outlier probability from its RMS error.
  void refreshOutlierProbabilities(Estimate* e) const {
    std::vector<double> sum(landmarks_.size(), 0.0);
    std::vector<int> n(landmarks_.size(), 0);
    for (const Obs& o : obs_) {
      Eigen::Vector3d r;
      if (!edge_.residual(e->x[o.kf], e->P[o.lm], o.z, &r)) continue;
      sum[o.lm] += r.squaredNorm();
      ++n[o.lm];
    }
    for (std::size_t l = 0; l < landmarks_.size(); ++l) {
      if (n[l] > 0) e->reliability.observe(l, std::nullopt, std::sqrt(sum[l] / n[l]));
    }
  }

  void plot(unsigned seed, const std::string& path, const std::vector<rvwo::SE2>& vo, const std::vector<rvwo::SE2>& vw,
            const std::vector<rvwo::SE2>& vwa) const {
    rvwo::apps::Plot plot("rvwo-demo: trajectories from above (seed " + std::to_string(seed) + ")", "x [m]", "y [m]",
                          true);
    std::vector<Eigen::Vector2d> walls;
    for (const Landmark& L : landmarks_) {
      if (L.walker < 0) walls.push_back(L.p.head<2>());
    }
    plot.add(walls, mrpt::img::TColor(190, 190, 190), "wall landmarks", 0);
    auto xy = [](const std::vector<rvwo::SE2>& t) {
      std::vector<Eigen::Vector2d> out;
      for (const rvwo::SE2& T : t) out.push_back(T.translation());
      return out;
    };
    plot.add(xy(wheel_only_), mrpt::img::TColor(230, 140, 0), "wheel (dead reckoning)");
    plot.add(xy(vo), mrpt::img::TColor(60, 90, 230), "vo-huber");
    plot.add(xy(vw), mrpt::img::TColor(170, 60, 200), "vw-huber");
    plot.add(xy(vwa), mrpt::img::TColor(0, 160, 60), "vw-adaptive (RVWO)");
    plot.add(xy(truth_), mrpt::img::TColor(0, 0, 0), "ground truth", 1);
    plot.save(path, 1000, 800);
  }

  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> u_{0, 1};
  std::normal_distribution<double> g_{0, 1};
  const rvwo::PinholeCamera camera_{400, 400, 320, 240};
  const Eigen::Isometry3d T_b_c_ = cameraMount();
  const rvwo::Se2XyzStereoEdge edge_;
  const double seconds_, slip_from_;
  rvwo::DiffDriveParams drive_;
  rvwo::WheelOdometry odometry_;
  std::vector<Landmark> landmarks_;
  std::vector<Walker> people_;
  std::vector<rvwo::SE2> truth_at_;  // robot pose at each 20 ms tick
  std::vector<double> kf_time_;
  std::vector<rvwo::SE2> truth_;  // at each keyframe
  std::vector<Obs> obs_;
  std::vector<std::vector<int>> obs_at_;  // observations grouped by keyframe
  std::vector<int> seen_;                 // observations of each landmark
  std::vector<rvwo::WheelDelta> deltas_;  // between keyframes
  std::vector<rvwo::SE2> wheel_only_;
};

RunResult runOnce(unsigned run_seed, double seconds, int n_walkers, const std::string& plot_path) {
  return DemoRun(run_seed, seconds, n_walkers).result(run_seed, plot_path);
}

}  // namespace

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-demo", [&] {
    TCLAP::CmdLine cmd(
        "rvwo-demo: simulates a wheeled robot with a stereo camera among walking people and solves the run as a "
        "planar bundle adjustment with RVWO's edges four ways (wheels only; vision with Huber; vision and wheels "
        "with Huber; vision and wheels with the adaptive Barron kernel), printing each one's trajectory error.",
        ' ', RVWO_VERSION);
    TCLAP::ValueArg<double> seconds("", "seconds", "length of the run in seconds (default 90)", false, 90, "s", cmd);
    TCLAP::ValueArg<int> walkers("", "walkers", "people walking across the room (default 4)", false, 4, "N", cmd);
    TCLAP::ValueArg<unsigned> seed("", "seed", "first random seed: same seed, same run (default 1)", false, 1, "N",
                                   cmd);
    TCLAP::ValueArg<int> runs("", "runs", "runs with seeds seed, seed+1, ... (default 3)", false, 3, "N", cmd);
    TCLAP::ValueArg<std::string> plot("", "plot", "PNG of the trajectories (default rvwo-demo.png)", false,
                                      "rvwo-demo.png", "file", cmd);
    if (const auto status = rvwo::apps::parseCommandLine(cmd, argc, argv)) return *status;
    FLAGS_minloglevel = 2;  // Ceres reports steps that put a point behind the camera; expected here
    if (!(seconds.getValue() >= 10 && seconds.getValue() <= 3600)) throw std::invalid_argument("--seconds: 10 to 3600");
    if (walkers.getValue() < 0 || walkers.getValue() > 20) throw std::invalid_argument("--walkers: 0 to 20");
    if (runs.getValue() < 1 || runs.getValue() > 100) throw std::invalid_argument("--runs: 1 to 100");

    const auto t_start = std::chrono::steady_clock::now();
    const char* names[4] = {"wheel", "vo-huber", "vw-huber", "vw-adaptive"};
    double mean[4] = {0, 0, 0, 0};
    std::printf("%-6s", "seed");
    for (const char* n : names) std::printf(" %12s", n);
    std::printf("   (ATE [m] after a planar rigid alignment; %% of path in brackets)\n");
    RunResult first;
    for (int i = 0; i < runs.getValue(); ++i) {
      const unsigned run_seed = seed.getValue() + i;
      const RunResult r = runOnce(run_seed, seconds.getValue(), walkers.getValue(), i == 0 ? plot.getValue() : "");
      if (i == 0) first = r;
      std::printf("%-6u", run_seed);
      for (int m = 0; m < 4; ++m) {
        std::printf(" %6.3f (%3.1f%%)", r.ate[m], 100 * r.ate[m] / r.path);
        mean[m] += r.ate[m] / runs.getValue();
      }
      std::printf("\n");
      std::fflush(stdout);
    }
    std::printf("%-6s", "mean");
    for (int m = 0; m < 4; ++m) std::printf(" %6.3f        ", mean[m]);
    std::printf(
        "\nper run: %zu keyframes over a %.0f m path, %zu landmarks (%d walkers), %zu observations, wheel slip "
        "at %.0f-%.0f s\n",
        first.keyframes, first.path, first.landmarks, walkers.getValue(), first.observations, first.slip_from,
        first.slip_to);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("plot of seed %u: %s   (%.1f s)\n", seed.getValue(), plot.getValue().c_str(), secs);
    return 0;
  });
}
