// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// ns per kernel evaluation (rho, rho', rho'') for the Barron kernel at the paper's landmark
// shapes and at a general alpha, next to Ceres's Huber loss (virtual call, like ours through the
// adapter) and the bare core. Inputs cycle over 4096 squared errors in [0, 50].
#include <benchmark/benchmark.h>

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
