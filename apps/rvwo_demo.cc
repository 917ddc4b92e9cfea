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

RunResult runOnce(unsigned run_seed, double seconds, int n_walkers, const std::string& plot_path) {
  std::mt19937_64 rng(run_seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);

  // ---- scene ----
  std::vector<Landmark> landmarks;
  for (int i = 0; i < 1600; ++i) {  // walls of a 12 x 9 m room
    const double s = u(rng), z = 0.1 + 2.4 * u(rng);
    const int wall = i % 4;
    Eigen::Vector3d p = wall == 0   ? Eigen::Vector3d(-6 + 12 * s, -4.5, z)
                        : wall == 1 ? Eigen::Vector3d(6, -4.5 + 9 * s, z)
                        : wall == 2 ? Eigen::Vector3d(-6 + 12 * s, 4.5, z)
                                    : Eigen::Vector3d(-6, -4.5 + 9 * s, z);
    landmarks.push_back({p, -1});
  }
  std::vector<Walker> people;
  for (int w = 0; w < n_walkers; ++w) {
    const double x = -3 + 6 * u(rng);
    people.push_back(
        {Eigen::Vector2d(x, -3.5), Eigen::Vector2d(x + 2 * u(rng) - 1, 3.5), 0.6 + 0.6 * u(rng), 7 * u(rng)});
    for (int k = 0; k < 60; ++k) {  // on a 0.25 m cylinder, 0.2 to 1.8 m up
      const double a = 2 * kPi * u(rng);
      landmarks.push_back({Eigen::Vector3d(0.25 * std::cos(a), 0.25 * std::sin(a), 0.2 + 1.6 * u(rng)), w});
    }
  }

  // ---- camera ----
  const rvwo::PinholeCamera camera(400, 400, 320, 240);
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T_b_c.translation() << 0.15, 0.0, 0.5;
  const double bf = 0.12 * 400;
  const rvwo::Se2XyzStereoEdge edge(camera, T_b_c, bf);

  // ---- wheels: 50 Hz encoders from the true motion, noisy, slipping at 40 % of the run ----
  rvwo::DiffDriveParams drive;
  rvwo::WheelNoise noise;
  noise.sigma_wheel = 0.02;
  rvwo::WheelOdometry odometry(noise);
  const double dt = 0.02, slip_from = 0.4 * seconds, slip_to = slip_from + 2.0;
  double ql = 0, qr = 0;
  std::vector<double> clock;  // true time of each keyframe; the robot stands still during the slip
  double robot_time = 0;      // arc-length clock of the path
  odometry.addWheelAngles(0, 0, 0, drive);
  std::vector<rvwo::SE2> truth_at;  // robot pose at each 20 ms tick
  truth_at.push_back(robotAt(0));
  const int ticks = static_cast<int>(std::lround(seconds / dt));
  for (int i = 1; i <= ticks; ++i) {
    const double t = i * dt;  // from the tick count, so keyframe times match reading times exactly
    const bool slipping = t > slip_from && t <= slip_to;
    const rvwo::SE2 a = robotAt(robot_time);
    if (!slipping) robot_time += dt;
    const rvwo::SE2 b = robotAt(robot_time);
    // Encoders: the true motion, or during the slip the motion the wheels would have made.
    const rvwo::SE2 wheel_motion = slipping ? robotAt(robot_time).between(robotAt(robot_time + dt)) : a.between(b);
    const Eigen::Vector3d xi = wheel_motion.log();
    const double dql = (xi.x() - xi.z() * drive.track / 2) / drive.radius_left;
    const double dqr = (xi.x() + xi.z() * drive.track / 2) / drive.radius_right;
    ql += dql + noise.sigma_wheel * std::sqrt(std::fabs(dql)) * g(rng);
    qr += dqr + noise.sigma_wheel * std::sqrt(std::fabs(dqr)) * g(rng);
    odometry.addWheelAngles(t, ql, qr, drive);
    truth_at.push_back(b);
  }

  // ---- keyframes every 0.5 s: stereo observations, labels ----
  const int stride = 25;
  std::vector<double> kf_time;
  std::vector<rvwo::SE2> truth;
  for (std::size_t i = 0; i < truth_at.size(); i += stride) {
    kf_time.push_back(i * dt);
    truth.push_back(truth_at[i]);
  }
  std::vector<Obs> obs;
  std::vector<int> seen(landmarks.size(), 0);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const Eigen::Vector3d x = truth[k].vector();
    for (std::size_t l = 0; l < landmarks.size(); ++l) {
      const Landmark& L = landmarks[l];
      Eigen::Vector3d P = L.p;
      if (L.walker >= 0) P.head<2>() += people[L.walker].at(kf_time[k]);
      Eigen::Vector3d h;
      if (!edge.predict(x, P, &h)) continue;
      const Eigen::Vector2d p_b = truth[k].inverse().act(P.head<2>());
      const Eigen::Vector3d P_c = T_b_c.inverse() * Eigen::Vector3d(p_b.x(), p_b.y(), P.z());
      if (P_c.z() < 0.4 || P_c.z() > 12 || h.x() < 0 || h.x() >= 640 || h.y() < 0 || h.y() >= 480 || h.z() < 0)
        continue;
      if (L.walker < 0 && u(rng) > 0.35) continue;  // the tracker keeps a subset of the static points
      const bool person = L.walker >= 0 ? u(rng) < 0.9 : u(rng) < 0.02;
      obs.push_back({static_cast<int>(k), static_cast<int>(l), h + Eigen::Vector3d(g(rng), g(rng), g(rng)), person});
      ++seen[l];
    }
  }

  // ---- wheel deltas between keyframes and dead reckoning ----
  std::vector<rvwo::WheelDelta> deltas;
  std::vector<rvwo::SE2> wheel_only{truth[0]};
  for (std::size_t k = 0; k + 1 < truth.size(); ++k) {
    deltas.push_back(odometry.integrate(kf_time[k], kf_time[k + 1]));
    wheel_only.push_back(wheel_only.back() * deltas.back().pose());
  }

  const rvwo::SemanticPriors priors = rvwo::SemanticPriors::builtin("voc21");
  const double p_person = priors.prior(priors.labelOf("person")), p_background = priors.prior(0);

  enum class Mode { kVoHuber, kVwHuber, kVwAdaptive };
  // Observations grouped by keyframe, for tracking.
  std::vector<std::vector<int>> obs_at(truth.size());
  for (std::size_t i = 0; i < obs.size(); ++i) obs_at[obs[i].kf].push_back(static_cast<int>(i));

  auto lossFor = [](Mode mode, double alpha) -> ceres::LossFunction* {
    if (mode == Mode::kVwAdaptive) return new rvwo::ceres_adapters::BarronLoss(alpha, 1.0);
    return new ceres::HuberLoss(1.0);
  };
  auto solve = [&](Mode mode, std::vector<rvwo::SE2>* out) {
    std::vector<Eigen::Vector3d> x(truth.size()), P(landmarks.size(), Eigen::Vector3d::Zero());
    std::vector<bool> mapped(landmarks.size(), false);
    rvwo::ReliabilityManager reliability;
    // ---- tracking, keyframe by keyframe: predict, optimise the pose alone against the mapped
    // landmarks (with the wheel edge to the previous keyframe in vw modes), then map new ones.
    for (std::size_t k = 0; k < truth.size(); ++k) {
      if (k == 0) {
        x[0] = truth[0].vector();
      } else if (mode == Mode::kVoHuber) {  // constant velocity
        const rvwo::SE2 prev = rvwo::SE2::fromVector(x[k - 1]);
        const rvwo::SE2 vel = k > 1 ? rvwo::SE2::fromVector(x[k - 2]).between(prev) : rvwo::SE2();
        x[k] = (prev * vel).vector();
      } else {
        x[k] = (rvwo::SE2::fromVector(x[k - 1]) * deltas[k - 1].pose()).vector();
      }
      for (int i : obs_at[k]) {
        const Obs& o = obs[i];
        reliability.observe(o.lm, o.person_label ? p_person : p_background, std::nullopt);
      }
      if (k > 0) {
        ceres::Problem problem;
        int used = 0;
        for (int i : obs_at[k]) {
          const Obs& o = obs[i];
          const double alpha = reliability.alpha(o.lm);
          Eigen::Vector3d h;
          if (!mapped[o.lm] || (mode == Mode::kVwAdaptive && std::isinf(alpha)) || !edge.predict(x[k], P[o.lm], &h))
            continue;
          problem.AddResidualBlock(new rvwo::ceres_adapters::Se2XyzCost<3>(edge, o.z, Eigen::Matrix3d::Identity()),
                                   lossFor(mode, alpha), x[k].data(), P[o.lm].data());
          problem.SetParameterBlockConstant(P[o.lm].data());
          ++used;
        }
        if (mode != Mode::kVoHuber) {
          problem.AddResidualBlock(new rvwo::ceres_adapters::WheelCost(rvwo::WheelEdge(deltas[k - 1])), nullptr,
                                   x[k - 1].data(), x[k].data());
          problem.SetParameterBlockConstant(x[k - 1].data());
        }
        if (used > 0 || mode != Mode::kVoHuber) {
          problem.SetManifold(x[k].data(), new rvwo::ceres_adapters::SE2Manifold);
          ceres::Solver::Options so;
          so.linear_solver_type = ceres::DENSE_QR;
          so.max_num_iterations = 20;
          ceres::Solver::Summary summary;
          ceres::Solve(so, &problem, &summary);
        }
      }
      for (int i : obs_at[k]) {  // map: triangulate new landmarks from the stereo pair
        const Obs& o = obs[i];
        if (mapped[o.lm]) continue;
        const double disparity = o.z.x() - o.z.z();
        if (disparity < 1.0) continue;
        const Eigen::Vector3d P_b = T_b_c * ((bf / disparity) * camera.unproject(o.z.head<2>()));
        const Eigen::Vector2d xy = rvwo::SE2::fromVector(x[k]).act(P_b.head<2>());
        P[o.lm] = Eigen::Vector3d(xy.x(), xy.y(), P_b.z());
        mapped[o.lm] = true;
      }
    }
    // ---- then one bundle adjustment over the whole run (three rounds for the adaptive kernel,
    // refreshing each landmark's outlier probability from its errors between rounds).
    // Two rounds in every mode; after the first, edges beyond the stereo chi2 gate (7.815, 95 %)
    // are outliers and leave the second, as ORB-SLAM does. The adaptive kernel also refreshes
    // each landmark's outlier probability from its errors (eq. 6) between rounds.
    const int rounds = 2;
    std::vector<bool> outlier(obs.size(), false);
    for (int round = 0; round < rounds; ++round) {
      ceres::Problem problem;
      for (std::size_t i = 0; i < obs.size(); ++i) {
        const Obs& o = obs[i];
        if (seen[o.lm] < 2 || !mapped[o.lm] || outlier[i]) continue;
        Eigen::Vector3d h;
        if (!edge.predict(x[o.kf], P[o.lm], &h)) continue;
        const double alpha = reliability.alpha(o.lm);
        // alpha = -inf rejects the landmark: its edges leave the problem (a point held only by
        // zero-weight residuals would make the Schur complement singular).
        if (mode == Mode::kVwAdaptive && std::isinf(alpha)) continue;
        problem.AddResidualBlock(new rvwo::ceres_adapters::Se2XyzCost<3>(edge, o.z, Eigen::Matrix3d::Identity()),
                                 lossFor(mode, alpha), x[o.kf].data(), P[o.lm].data());
      }
      if (mode != Mode::kVoHuber) {
        for (std::size_t k = 0; k + 1 < x.size(); ++k) {
          problem.AddResidualBlock(new rvwo::ceres_adapters::WheelCost(rvwo::WheelEdge(deltas[k])), nullptr,
                                   x[k].data(), x[k + 1].data());
        }
      }
      for (auto& xk : x) {
        if (problem.HasParameterBlock(xk.data())) problem.SetManifold(xk.data(), new rvwo::ceres_adapters::SE2Manifold);
      }
      if (problem.HasParameterBlock(x[0].data())) problem.SetParameterBlockConstant(x[0].data());
      ceres::Solver::Options so;
      so.linear_solver_type = ceres::SPARSE_SCHUR;
      so.max_num_iterations = 50;
      so.num_threads = 1;  // deterministic: same seed, same numbers
      ceres::Solver::Summary summary;
      ceres::Solve(so, &problem, &summary);
      for (std::size_t i = 0; i < obs.size(); ++i) {
        Eigen::Vector3d r;
        outlier[i] = !edge.residual(x[obs[i].kf], P[obs[i].lm], obs[i].z, &r) || r.squaredNorm() > 7.815;
      }
      if (mode == Mode::kVwAdaptive) {  // eq. 6: outlier probability from each landmark's RMS error
        std::vector<double> sum(landmarks.size(), 0.0);
        std::vector<int> n(landmarks.size(), 0);
        for (const Obs& o : obs) {
          Eigen::Vector3d r;
          if (!edge.residual(x[o.kf], P[o.lm], o.z, &r)) continue;
          sum[o.lm] += r.squaredNorm();
          ++n[o.lm];
        }
        for (std::size_t l = 0; l < landmarks.size(); ++l) {
          if (n[l] > 0) reliability.observe(l, std::nullopt, std::sqrt(sum[l] / n[l]));
        }
      }
    }
    out->clear();
    for (const auto& xk : x) out->push_back(rvwo::SE2::fromVector(xk));
  };

  std::vector<rvwo::SE2> vo, vw, vwa;
  solve(Mode::kVoHuber, &vo);
  solve(Mode::kVwHuber, &vw);
  solve(Mode::kVwAdaptive, &vwa);

  double path = 0;
  for (std::size_t k = 0; k + 1 < truth.size(); ++k)
    path += (truth[k + 1].translation() - truth[k].translation()).norm();
  RunResult result;
  result.keyframes = truth.size();
  result.landmarks = landmarks.size();
  result.observations = obs.size();
  result.path = path;
  result.slip_from = slip_from;
  result.slip_to = slip_to;
  const std::vector<rvwo::SE2>* trajectories[4] = {&wheel_only, &vo, &vw, &vwa};
  for (int m = 0; m < 4; ++m) result.ate[m] = ate(*trajectories[m], truth);
  if (plot_path.empty()) return result;
  // ---- plot ----
  rvwo::apps::Plot plot("rvwo-demo: trajectories from above (seed " + std::to_string(run_seed) + ")", "x [m]", "y [m]",
                        true);
  std::vector<Eigen::Vector2d> walls;
  for (const Landmark& L : landmarks) {
    if (L.walker < 0) walls.push_back(L.p.head<2>());
  }
  plot.add(walls, mrpt::img::TColor(190, 190, 190), "wall landmarks", 0);
  auto xy = [](const std::vector<rvwo::SE2>& t) {
    std::vector<Eigen::Vector2d> out;
    for (const rvwo::SE2& T : t) out.push_back(T.translation());
    return out;
  };
  plot.add(xy(wheel_only), mrpt::img::TColor(230, 140, 0), "wheel (dead reckoning)");
  plot.add(xy(vo), mrpt::img::TColor(60, 90, 230), "vo-huber");
  plot.add(xy(vw), mrpt::img::TColor(170, 60, 200), "vw-huber");
  plot.add(xy(vwa), mrpt::img::TColor(0, 160, 60), "vw-adaptive (RVWO)");
  plot.add(xy(truth), mrpt::img::TColor(0, 0, 0), "ground truth", 1);
  plot.save(plot_path, 1000, 800);
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    TCLAP::CmdLine cmd(
        "rvwo-demo: simulates a wheeled robot with a stereo camera among walking people and solves the run as a "
        "planar bundle adjustment with RVWO's edges four ways (wheels only; vision with Huber; vision and wheels "
        "with Huber; vision and wheels with the adaptive Barron kernel), printing each one's trajectory error.",
        ' ', "0.1");
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
  } catch (const TCLAP::ArgException& e) {
    std::fprintf(stderr, "rvwo-demo: %s (%s)\n", e.error().c_str(), e.argId().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rvwo-demo: error: %s\n", e.what());
  }
  return 1;
}
