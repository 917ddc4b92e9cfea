// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Throughput of the edges: preintegration readings per second (pose and encoder input, then
// integrate over a 0.1 s keyframe interval), and residual-plus-Jacobian evaluations per second
// for the SE(2)-XYZ edge (mono pinhole, mono fisheye, stereo) and the wheel edge.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "rvwo/edges/se2_xyz_edge.h"
#include "rvwo/edges/wheel_edge.h"
#include "rvwo/edges/wheel_preintegration.h"

namespace {

void BM_PreintegratePoseReadings(benchmark::State& state) {
  // 200 Hz odometry poses on an arc; each iteration adds one reading, and every 20 readings
  // integrates a 0.1 s interval ending inside a reading, then drops what is older.
  rvwo::WheelOdometry odo;
  double t = 0;
  rvwo::SE2 T;
  const rvwo::SE2 step = rvwo::SE2::exp(Eigen::Vector3d(0.005, 0, 0.002));
  odo.addPose(t, T);
  std::int64_t n = 0;
  for (auto _ : state) {
    t += 0.005;
    T = T * step;
    odo.addPose(t, T);
    if (++n % 20 == 0 && t > 0.2) {
      benchmark::DoNotOptimize(odo.integrate(t - 0.1025, t - 0.0025));
      odo.dropBefore(t - 0.2);
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("readings");
}
BENCHMARK(BM_PreintegratePoseReadings);

void BM_PreintegrateEncoderReadings(benchmark::State& state) {
  rvwo::WheelOdometry odo;
  const rvwo::DiffDriveParams drive;
  double t = 0, ql = 0, qr = 0;
  odo.addWheelAngles(t, ql, qr, drive);
  std::int64_t n = 0;
  for (auto _ : state) {
    t += 0.005;
    ql += 0.05;
    qr += 0.052;
    odo.addWheelAngles(t, ql, qr, drive);
    if (++n % 20 == 0 && t > 0.2) {
      benchmark::DoNotOptimize(odo.integrate(t - 0.1025, t - 0.0025));
      odo.dropBefore(t - 0.2);
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("readings");
}
BENCHMARK(BM_PreintegrateEncoderReadings);

Eigen::Isometry3d cameraOnRobot() {
  Eigen::Matrix3d R_b_c;
  R_b_c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_b_c;
  T.translation() << 0.2, 0, 0.3;
  return T;
}

struct States {
  std::vector<Eigen::Vector3d> x, P;
  States() {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 1024; ++i) {
      x.emplace_back(u(rng), u(rng), 0.2 * u(rng));
      P.emplace_back(x.back().x() + 5 + 3 * u(rng), x.back().y() + 2 * u(rng), 0.3 + u(rng));
    }
  }
};

template <int N>
void edgeBench(benchmark::State& state, const rvwo::CameraModel& cam, double bf) {
  static const States s;
  const rvwo::Se2XyzEdge<N> edge(cam, cameraOnRobot(), bf);
  typename rvwo::Se2XyzEdge<N>::Vector z = rvwo::Se2XyzEdge<N>::Vector::Zero(), r;
  typename rvwo::Se2XyzEdge<N>::Jacobian Jx, Jp;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ & 1023;
    benchmark::DoNotOptimize(edge.residual(s.x[k], s.P[k], z, &r, &Jx, &Jp));
    benchmark::DoNotOptimize(Jx.data());
    benchmark::DoNotOptimize(Jp.data());
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_Se2XyzMonoPinhole(benchmark::State& state) { edgeBench<2>(state, rvwo::PinholeCamera(450, 450, 320, 240), 0); }
void BM_Se2XyzMonoFisheye(benchmark::State& state) {
  edgeBench<2>(state, rvwo::KannalaBrandtCamera(286, 286, 424, 400, -0.01, 0.046, -0.043, 0.008), 0);
}
void BM_Se2XyzStereo(benchmark::State& state) { edgeBench<3>(state, rvwo::PinholeCamera(450, 450, 320, 240), 54); }
BENCHMARK(BM_Se2XyzMonoPinhole);
BENCHMARK(BM_Se2XyzMonoFisheye);
BENCHMARK(BM_Se2XyzStereo);

void BM_Se2XyzInflatedCovariance(benchmark::State& state) {
  static const States s;
  const rvwo::PinholeCamera cam(450, 450, 320, 240);
  const rvwo::Se2XyzMonoEdge edge(cam, cameraOnRobot());
  rvwo::OutOfPlaneNoise noise{0.01, Eigen::Matrix2d::Identity() * 1e-4};
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ & 1023;
    benchmark::DoNotOptimize(edge.covariance(s.x[k], s.P[k], 1.2, noise));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Se2XyzInflatedCovariance);

void BM_WheelEdge(benchmark::State& state) {
  static const States s;
  rvwo::WheelDelta d;
  d.dp << 0.1, 0.01;
  d.dphi = 0.02;
  d.covariance = Eigen::Matrix3d::Identity() * 1e-4;
  const rvwo::WheelEdge edge(d);
  Eigen::Matrix3d Ji, Jj;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ & 1023;
    benchmark::DoNotOptimize(edge.residual(s.x[k], s.x[(k + 1) & 1023], &Ji, &Jj));
    benchmark::DoNotOptimize(Ji.data());
    benchmark::DoNotOptimize(Jj.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WheelEdge);

}  // namespace

BENCHMARK_MAIN();
