// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// ns per kernel evaluation (rho, rho', rho'') for the Barron kernel at the paper's landmark
// shapes and at a general alpha, next to Ceres's Huber loss (virtual call, like ours through the
// adapter) and the bare core. Inputs cycle over 4096 squared errors in [0, 50].
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rvwo/kernels/barron.h"
#include "rvwo/kernels/reliability.h"
#ifdef RVWO_BENCH_CERES
#include <ceres/loss_function.h>

#include "rvwo/ceres/barron_loss.h"
#endif

namespace {

const std::vector<double>& inputs() {
  static const std::vector<double> s = [] {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(0.0, 50.0);
    std::vector<double> v(4096);
    for (double& x : v) x = u(rng);
    return v;
  }();
  return s;
}

template <typename Eval>
void run(benchmark::State& state, Eval&& eval) {
  const std::vector<double>& s = inputs();
  std::size_t i = 0;
  double rho[3];
  for (auto _ : state) {
    eval(s[i++ & 4095], rho);
    benchmark::DoNotOptimize(rho);
    benchmark::ClobberMemory();
  }
}

double alphaOf(int64_t code) {
  switch (code) {
    case 0:
      return 1.0;
    case 1:
      return 0.0;
    case 2:
      return -2.0;
    case 3:
      return -std::numeric_limits<double>::infinity();
    default:
      return -0.73;  // a general shape from the reliability model
  }
}

void BM_BarronCore(benchmark::State& state) {
  const rvwo::BarronKernel k(alphaOf(state.range(0)));
  state.SetLabel("alpha=" + std::to_string(k.alpha()));
  run(state, [&](double s, double* rho) { k.evaluate(s, rho); });
}
BENCHMARK(BM_BarronCore)->DenseRange(0, 4);

void BM_ReliabilityObserve(benchmark::State& state) {
  rvwo::ReliabilityManager m;
  std::uint64_t id = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(m.observe(id++ % 10000, 0.95, 1.3));
  }
}
BENCHMARK(BM_ReliabilityObserve);

#ifdef RVWO_BENCH_CERES
void BM_CeresHuber(benchmark::State& state) {
  const ceres::HuberLoss huber(1.0);
  const ceres::LossFunction* loss = &huber;
  run(state, [&](double s, double* rho) { loss->Evaluate(s, rho); });
}
BENCHMARK(BM_CeresHuber);

// ns per evaluation of a loss over the 4096 inputs, in one block (the harness' loop body).
double block(const ceres::LossFunction* loss) {
  const std::vector<double>& s = inputs();
  double rho[3];
  const auto t0 = std::chrono::steady_clock::now();
  for (const double x : s) {
    loss->Evaluate(x, rho);
    benchmark::DoNotOptimize(rho);
    benchmark::ClobberMemory();
  }
  return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / s.size();
}

// BarronLoss against Ceres' loss of the same shape, at the scale where both compute the same
// values (Cauchy's b = 2 c^2 for alpha = 0, SoftLOne's b = c^2 for alpha = 1), timed in
// alternating blocks, each one's fastest block kept: a virtual machine's speed drifts by 2x within
// a run, and both see the drift. Counters: barron_ns, ceres_ns and their ratio (docs/decisions/0014).
void BM_BarronOverCeres(benchmark::State& state) {
  const bool cauchy = state.range(0) == 0;
  const rvwo::ceres_adapters::BarronLoss barron(cauchy ? 0.0 : 1.0);
  const ceres::CauchyLoss cauchy_loss(std::sqrt(2.0));
  const ceres::SoftLOneLoss soft_l_one(1.0);
  const ceres::LossFunction* ceres_loss = cauchy ? static_cast<const ceres::LossFunction*>(&cauchy_loss) : &soft_l_one;
  double best_barron = 1e300, best_ceres = 1e300;
  for (auto _ : state) {
    best_barron = std::min(best_barron, block(&barron));
    best_ceres = std::min(best_ceres, block(ceres_loss));
  }
  state.SetLabel(cauchy ? "alpha=0 against CauchyLoss" : "alpha=1 against SoftLOneLoss");
  state.counters["barron_ns"] = best_barron;
  state.counters["ceres_ns"] = best_ceres;
  state.counters["ratio"] = best_barron / best_ceres;
}
BENCHMARK(BM_BarronOverCeres)->Arg(0)->Arg(1);

void BM_CeresBarron(benchmark::State& state) {
  const rvwo::ceres_adapters::BarronLoss barron(alphaOf(state.range(0)));
  const ceres::LossFunction* loss = &barron;
  state.SetLabel("alpha=" + std::to_string(barron.alpha()));
  run(state, [&](double s, double* rho) { loss->Evaluate(s, rho); });
}
BENCHMARK(BM_CeresBarron)->DenseRange(0, 4);
#endif

}  // namespace

BENCHMARK_MAIN();
