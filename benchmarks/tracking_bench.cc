// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// One frame's pose on SE(2) (rvwo::optimisePlanarPose), as tracking runs it for every frame: n
// matches (two in three stereo), 10 % gross outliers, a prediction 10 cm and 3 degrees off, the
// wheel edge from the previous frame. Arguments: matches, kernel (0 Huber, 1 adaptive Barron with
// alphas spread over [-2, 1]). Run: build/benchmarks/rvwo_bench_tracking
#include <benchmark/benchmark.h>

#include <random>

#include "rvwo/edges/se2.h"
#include "rvwo/tracking/planar_pose.h"

namespace {

Eigen::Isometry3d forwardCamera() {
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // looking along the robot's x
  T_b_c.translation() << 0.2, 0, 0.3;
  return T_b_c;
}

struct Frame {
  rvwo::PinholeCamera camera{450, 450, 319.5, 239.5};
  Eigen::Isometry3d T_b_c = forwardCamera();
  rvwo::Se2XyzMonoEdge mono{camera, T_b_c};
  rvwo::Se2XyzStereoEdge stereo{camera, T_b_c, 0.12 * 450};
  std::vector<rvwo::PoseObservation> obs;
  Eigen::Vector3d x_true{2.0, -1.0, 0.3}, x_prev{1.95, -1.02, 0.29};
  rvwo::WheelDelta delta;

  Frame(int n, bool adaptive) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-1, 1), depth(1.5, 12.0), off(20, 60), coin(0, 1);
    std::normal_distribution<double> g(0, 1);
    const Eigen::Isometry3d T_w_c = rvwo::SE2::fromVector(x_true).isometry3() * T_b_c;
    while (static_cast<int>(obs.size()) < n) {
      const double z = depth(rng);
      rvwo::PoseObservation o;
      o.P_w = T_w_c * Eigen::Vector3d(u(rng) * 0.7 * z, u(rng) * 0.5 * z, z);
      o.stereo = obs.size() % 3 != 0;
      o.sigma_px = rvwo::pyramidSigma(static_cast<int>(obs.size() % 4));
      o.alpha = adaptive ? -0.5 + 1.5 * u(rng) : 1.0;
      Eigen::Vector3d h;
      if (!stereo.predict(x_true, o.P_w, &h)) continue;
      o.z = h + o.sigma_px * Eigen::Vector3d(g(rng), g(rng), g(rng));
      if (coin(rng) < 0.1) o.z.head<2>() += off(rng) * Eigen::Vector2d(u(rng), u(rng)).normalized();
      obs.push_back(o);
    }
    const rvwo::SE2 T = rvwo::SE2::fromVector(x_prev).inverse() * rvwo::SE2::fromVector(x_true);
    delta.dp = T.translation();
    delta.dphi = T.angle();
    delta.covariance = Eigen::Vector3d(1e-5, 1e-5, 1e-5).asDiagonal();
  }
};

void BM_OptimisePlanarPose(benchmark::State& state) {
  const Frame f(static_cast<int>(state.range(0)), state.range(1) != 0);
  const rvwo::WheelEdge edge(f.delta);
  rvwo::PlanarPoseOptions opt;
  opt.huber = state.range(1) == 0;
  opt.out_of_plane.sigma_z = 0.01;
  opt.out_of_plane.sigma_rollpitch = Eigen::Matrix2d::Identity() * 1e-4;
  int inliers = 0;
  for (auto _ : state) {
    Eigen::Vector3d x = f.x_true + Eigen::Vector3d(0.08, -0.06, 0.05);
    inliers = optimisePlanarPose(f.mono, &f.stereo, f.obs, rvwo::WheelPrior{&edge, f.x_prev}, opt, &x).inliers;
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["inliers"] = inliers;
  state.SetItemsProcessed(state.iterations() * state.range(0));  // matches a second
}
BENCHMARK(BM_OptimisePlanarPose)
    ->ArgsProduct({{100, 300, 1000}, {0, 1}})
    ->ArgNames({"matches", "adaptive"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
