// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// ms per frame of the shared DeepLabV3-MobileNetV2 (VOC-21) on a real 640x480 TUM frame, with 1
// and 2 intra-op threads, end to end (resize, normalise, inference, argmax, upsample). Needs
// ../shared (the model is not shipped): skips otherwise.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/semantics/onnx_segmenter.h"

namespace {

void BM_DeepLabV3(benchmark::State& state) {
  const std::string shared = RVWO_SHARED_DIR;
  const std::string model = shared + "/models/deeplabv3_mnv2_voc21.onnx";
  const std::string frame = shared + "/data/tum_fr3_walking_xyz/rgb/1341846313.592026.png";
  if (!std::filesystem::exists(model) || !std::filesystem::exists(frame)) {
    state.SkipWithError("../shared is absent: no model to time");
    return;
  }
  rvwo::OnnxSegmenterOptions o;
  o.model_path = model;
  o.class_names = rvwo::SemanticPriors::builtin("voc21").classes();
  o.intra_op_threads = static_cast<int>(state.range(0));
  rvwo::OnnxSegmenter seg(o);
  const cv::Mat img = cv::imread(frame, cv::IMREAD_COLOR);
  seg.segment(img);  // warm-up
  for (auto _ : state) benchmark::DoNotOptimize(seg.segment(img));
  state.SetLabel(std::to_string(state.range(0)) + " thread(s), 640x480 -> 257x257");
}
BENCHMARK(BM_DeepLabV3)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
