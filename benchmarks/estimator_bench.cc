// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The estimator's per-frame front end: ORB extraction on the grid, stereo matching. Image: a real
// TUM frame (../shared) as the left image and the same shifted 12 px as the right one.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "rvwo/estimator/features.h"

namespace {

cv::Mat tumFrame() {
  const std::filesystem::path dir = std::filesystem::path(RVWO_SHARED_DIR) / "data/tum_fr3_walking_xyz/rgb";
  if (!std::filesystem::exists(dir)) return {};
  for (const auto& e : std::filesystem::directory_iterator(dir))
    return cv::imread(e.path().string(), cv::IMREAD_GRAYSCALE);
  return {};
}

void BM_ExtractOrb(benchmark::State& state) {
  const cv::Mat image = tumFrame();
  if (image.empty()) {
    state.SkipWithError("../shared is absent: no image");
    return;
  }
  rvwo::estimator::FeatureParams p;
  p.features = static_cast<int>(state.range(0));
  p.levels = static_cast<int>(state.range(1));
  const rvwo::estimator::FeatureExtractor extractor(p);
  std::size_t n = 0;
  for (auto _ : state) n = extractor.extract(image).size();
  state.counters["keypoints"] = static_cast<double>(n);
}
BENCHMARK(BM_ExtractOrb)
    ->Args({1000, 8})
    ->Args({1000, 6})
    ->Args({1000, 4})
    ->Args({500, 8})
    ->Unit(benchmark::kMillisecond);

void BM_MatchStereo(benchmark::State& state) {
  const cv::Mat left = tumFrame();
  if (left.empty()) {
    state.SkipWithError("../shared is absent: no image");
    return;
  }
  cv::Mat right;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -12, 0, 1, 0);
  cv::warpAffine(left, right, shift, left.size());
  const rvwo::estimator::FeatureExtractor extractor{rvwo::estimator::FeatureParams{}};
  const rvwo::estimator::Features fl0 = extractor.extract(left);
  int matched = 0;
  for (auto _ : state) {
    rvwo::estimator::Features fl = fl0;
    rvwo::estimator::matchStereo(left, right, 48.0, 0.5, 240, &fl);
    matched = static_cast<int>(std::count_if(fl.depth.begin(), fl.depth.end(), [](float d) { return d > 0; }));
  }
  state.counters["matched"] = matched;
}
BENCHMARK(BM_MatchStereo)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
