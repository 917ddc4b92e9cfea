// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The segmentation hook: exact labels from tiny generated models (scores and label outputs, NCHW
// and NHWC), a clear error for each bad input (NaN scores too), label images, keypoint labels with dilation, the
// async runner under two producers and a slow model, and the real DeepLabV3 network on real
// TUM frames (skipped without ../shared).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "../common/temp.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/semantics/async_segmenter.h"
#include "rvwo/semantics/label_lookup.h"
#include "rvwo/semantics/onnx_segmenter.h"

namespace rvwo {
namespace {

namespace fs = std::filesystem;
const std::string kData = std::string(RVWO_SOURCE_DIR) + "/tests/semantics/data/";

OnnxSegmenterOptions tiny(const std::string& file) {
  OnnxSegmenterOptions o;
  o.model_path = kData + file;
  o.class_names = {"red", "green", "blue"};
  return o;
}

// A 64 x 64 BGR image of 8 x 8 blocks, each pure red, green or blue; returns the expected labels.
cv::Mat blocks(cv::Mat* expected) {
  cv::Mat img(64, 64, CV_8UC3), want(64, 64, CV_32S);
  const cv::Vec3b bgr[3] = {{0, 0, 255}, {0, 255, 0}, {255, 0, 0}};  // red, green, blue
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const int c = ((x / 8) * 7 + (y / 8) * 3) % 3;
      img.at<cv::Vec3b>(y, x) = bgr[c];
      want.at<int>(y, x) = c;
    }
  }
  *expected = want;
  return img;
}

void expectLabels(const Segmentation& s, const cv::Mat& want) {
  ASSERT_EQ(s.labels.type(), CV_32S);
  ASSERT_EQ(s.labels.size(), want.size());
  EXPECT_EQ(cv::countNonZero(s.labels != want), 0);
}

TEST(OnnxSegmenter, ScoresOutputGivesExactLabels) {
  cv::Mat want;
  const cv::Mat img = blocks(&want);
  OnnxSegmenterOptions o = tiny("tiny_scores.onnx");
  o.confidence = true;
  OnnxSegmenter seg(o);
  EXPECT_EQ(seg.inputWidth(), 8);
  const Segmentation s = seg.segment(img);
  expectLabels(s, want);
  // softmax of (1, -1, -1): e / (e + 2/e)
  const double e = std::exp(1.0);
  EXPECT_NEAR(s.confidence.at<float>(4, 4), e / (e + 2 / e), 1e-5);
}

TEST(OnnxSegmenter, LabelsOutputAndNhwcLayoutGiveTheSameLabels) {
  cv::Mat want;
  const cv::Mat img = blocks(&want);
  OnnxSegmenterOptions labels = tiny("tiny_labels.onnx");
  labels.output = OnnxSegmenterOptions::Output::kLabels;
  expectLabels(OnnxSegmenter(labels).segment(img), want);
  OnnxSegmenterOptions nhwc = tiny("tiny_nhwc.onnx");
  nhwc.layout = OnnxSegmenterOptions::Layout::kNHWC;
  expectLabels(OnnxSegmenter(nhwc).segment(img), want);
}

TEST(OnnxSegmenter, ColourOrderIsHonoured) {
  cv::Mat want;
  const cv::Mat img = blocks(&want);
  OnnxSegmenterOptions o = tiny("tiny_scores.onnx");
  o.colour_order = OnnxSegmenterOptions::ColourOrder::kBGR;  // channel 0 is now blue
  const Segmentation s = OnnxSegmenter(o).segment(img);
  cv::Mat swapped = want.clone();
  swapped.setTo(3, want == 0);
  swapped.setTo(0, want == 2);
  swapped.setTo(2, swapped == 3);
  expectLabels(s, swapped);
}

void expectError(const OnnxSegmenterOptions& o, const std::string& fragment) {
  try {
    OnnxSegmenter seg(o);
    FAIL() << "accepted: " << o.model_path;
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
    EXPECT_EQ(what.rfind("segmenter: ", 0), 0u) << what;
  }
}

TEST(OnnxSegmenter, BadInputsGetOneClearError) {
  expectError(tiny("does_not_exist.onnx"), "model file not found");
  const std::string text = (rvwo::test::scratch("rvwo_not_onnx.onnx")).string();
  std::ofstream(text) << "this is not a protobuf";
  OnnxSegmenterOptions o = tiny("");
  o.model_path = text;
  expectError(o, "not a model ONNX Runtime 1.21 can load");
  expectError(tiny("tiny_rank3.onnx"), "has rank 3, expected 4");
  expectError(tiny("tiny_int_input.onnx"), "has element type int32, expected float32");
  o = tiny("tiny_scores.onnx");
  o.class_names = {"a", "b"};
  expectError(o, "scores 3 classes, the label set has 2");
  o = tiny("tiny_scores.onnx");
  o.input_width = 16;
  expectError(o, "takes width 8, the options say 16");
  o = tiny("tiny_scores.onnx");
  o.layout = OnnxSegmenterOptions::Layout::kNHWC;  // the model is NCHW: 8 channels where NHWC has them
  expectError(o, "has 8 channels where the NHWC layout puts them, expected 3");
  o = tiny("tiny_scores.onnx");
  o.input_name = "rgb";
  expectError(o, "no input named 'rgb' (it has: image)");
  o = tiny("tiny_scores.onnx");
  o.output = OnnxSegmenterOptions::Output::kLabels;
  expectError(o, "has element type float32, expected int64, int32 or uint8 labels");
  o = tiny("tiny_scores.onnx");
  o.class_names.clear();
  expectError(o, "no class names");
  OnnxSegmenter ok(tiny("tiny_scores.onnx"));
  EXPECT_THROW(ok.segment(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(ok.segment(cv::Mat(10, 10, CV_16UC3)), std::invalid_argument);
  EXPECT_NO_THROW(ok.segment(cv::Mat(10, 10, CV_8UC1, cv::Scalar(7))));  // grey is accepted
  // A network whose scores are not numbers gives no labels (not every pixel the first class).
  cv::Mat want;
  OnnxSegmenter nan(tiny("tiny_nan.onnx"));
  try {
    nan.segment(blocks(&want));
    FAIL() << "labels from NaN scores";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "segmenter: 64 of the network's 192 scores are not finite numbers: no labels from it");
  }
}

TEST(LabelImageSegmenter, NearestTimestampAndValueMapping) {
  const fs::path dir = rvwo::test::scratch("rvwo_label_images");
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat a(4, 6, CV_8U, cv::Scalar(1)), b(4, 6, CV_8U, cv::Scalar(1));
  b.at<uint8_t>(2, 3) = 0;
  cv::imwrite((dir / "100.000000.png").string(), a);
  cv::imwrite((dir / "100.500000.png").string(), b);
  std::ofstream(dir / "notes.txt") << "ignored";
  LabelImageSegmenter seg(dir.string(), {"background", "person"}, {{0, 1}, {1, 0}}, 0.05);
  EXPECT_EQ(seg.size(), 2u);
  const Segmentation s = seg.segment(cv::Mat(4, 6, CV_8UC3), {7, 100.48});
  EXPECT_EQ(s.labels.at<int>(2, 3), 1);  // DynaSLAM's 0 = person
  EXPECT_EQ(s.labels.at<int>(0, 0), 0);
  EXPECT_THROW(seg.segment(cv::Mat(4, 6, CV_8UC3), {8, 100.3}), std::runtime_error);  // none within 50 ms
  EXPECT_THROW(seg.segment(cv::Mat(5, 6, CV_8UC3), {9, 100.0}), std::runtime_error);  // wrong size
  EXPECT_THROW(LabelImageSegmenter((dir / "nope").string(), {"x"}), std::invalid_argument);
}

// A damaged label image is refused in the reader's words (rvwo/semantics/image_file.h), naming the
// file; libpng prints nothing of its own.
TEST(LabelImageSegmenter, DamagedLabelImageIsRefusedInOneLineOfOurs) {
  const fs::path dir = rvwo::test::scratch("rvwo_label_images_damaged");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::vector<unsigned char> png;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(4, 6, CV_8U, cv::Scalar(1)), png));
  png.resize(8 + 25);  // its signature and header chunk (IHDR), then nothing
  const fs::path file = dir / "100.000000.png";
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  LabelImageSegmenter seg(dir.string(), {"background", "person"});
  testing::internal::CaptureStderr();
  try {
    seg.segment(cv::Mat(4, 6, CV_8UC3), {1, 100.0});
    ADD_FAILURE() << "labels from a damaged PNG";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "label images: cannot read image " + file.string() + ": a PNG cut short (at byte 33, before IEND)");
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(LabelLookup, DilatesAroundDynamicClasses) {
  Segmentation s;
  s.labels = cv::Mat(100, 100, CV_32S, cv::Scalar(0));
  s.labels(cv::Rect(40, 40, 10, 10)).setTo(15);  // a person
  s.labels(cv::Rect(80, 80, 5, 5)).setTo(9);     // a chair (not dynamic)
  const LabelLookup lookup(s, {15}, 20);
  EXPECT_EQ(lookup.labelAt({45, 45}), 15);
  EXPECT_EQ(lookup.labelAt({45, 25}), 15);  // 15 px above the person: within 20
  EXPECT_EQ(lookup.labelAt({45, 15}), 0);   // 25 px: outside
  EXPECT_EQ(lookup.labelAt({82, 82}), 9);
  EXPECT_EQ(lookup.labelAt({-1, 5}), -1);
  EXPECT_EQ(lookup.labelAt({100.5f, 5}), -1);
  EXPECT_EQ(LabelLookup(s, {15}, 0).labelAt({45, 35}), 0);
}

// A slow fake network: labels every pixel with the frame id modulo 7 after a short sleep.
class SlowSegmenter final : public Segmenter {
 public:
  Segmentation segment(const cv::Mat& image, const FrameInfo& info) override {
    std::this_thread::sleep_for(std::chrono::microseconds(300));
    if (info.id % 97 == 13) throw std::runtime_error("fake failure");
    Segmentation s;
    s.labels = cv::Mat(image.size(), CV_32S, cv::Scalar(static_cast<int>(info.id % 7)));
    return s;
  }
  const std::vector<std::string>& classNames() const override { return names_; }

 private:
  std::vector<std::string> names_{"a", "b", "c", "d", "e", "f", "g"};
};

TEST(AsyncSegmenter, TwoProducersSlowModelNoDeadlock) {
  auto runner = std::make_unique<AsyncSegmenter>(std::make_shared<SlowSegmenter>(), 2, 64);
  const cv::Mat img(8, 8, CV_8UC3, cv::Scalar(0));
  std::atomic<int> got{0};
  auto produce = [&](int base) {
    for (int i = 0; i < 500; ++i) {
      const std::uint64_t id = base + i;
      ASSERT_TRUE(runner->submit(img, {id, 0.0}));
      if (auto s = runner->take(id - 3)) {
        EXPECT_EQ(s->labels.at<int>(0, 0), static_cast<int>((id - 3) % 7));
        ++got;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
  };
  std::thread a(produce, 0), b(produce, 100000);
  a.join();
  b.join();
  // The last frame of a producer is eventually processed: it is never dropped by a later one of its own.
  const auto last = runner->waitFor(100499, std::chrono::seconds(5));
  const auto st = runner->stats();
  EXPECT_EQ(st.submitted, 1000u);
  EXPECT_GT(st.dropped, 0u);  // frames came faster than the network
  EXPECT_GT(st.processed, 0u);
  EXPECT_LE(st.processed + st.dropped + st.failed, 1000u);
  runner->shutdown();
  runner->shutdown();  // idempotent
  EXPECT_FALSE(runner->submit(img, {1, 0.0}));
  const auto after = runner->stats();
  EXPECT_EQ(after.processed + after.dropped + after.failed, 1000u) << "every request accounted for";
  runner.reset();  // destructor after shutdown: no hang
}

TEST(AsyncSegmenter, FailuresAreCountedNotFatal) {
  AsyncSegmenter runner(std::make_shared<SlowSegmenter>(), 4);
  const cv::Mat img(8, 8, CV_8UC3, cv::Scalar(0));
  runner.submit(img, {13, 0.0});
  EXPECT_FALSE(runner.waitFor(13, std::chrono::seconds(5)).has_value());
  EXPECT_EQ(runner.stats().failed, 1u);
  EXPECT_EQ(runner.lastError(), "fake failure");
  runner.submit(img, {14, 0.0});
  const auto ok = runner.waitFor(14, std::chrono::seconds(5));
  ASSERT_TRUE(ok.has_value());
  EXPECT_EQ(ok->labels.at<int>(0, 0), 0);
}

// A network that holds each frame until the test opens the gate; id 13 fails.
class GatedSegmenter final : public Segmenter {
 public:
  Segmentation segment(const cv::Mat& image, const FrameInfo& info) override {
    std::unique_lock<std::mutex> lock(m_);
    started_ = info.id;
    cv_.notify_all();
    cv_.wait(lock, [&] { return open_; });
    if (info.id == 13) throw std::runtime_error("fake failure");
    Segmentation s;
    s.labels = cv::Mat(image.size(), CV_32S, cv::Scalar(1));
    return s;
  }
  void waitStarted(std::uint64_t id) {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return started_ == id; });
  }
  void open() {
    std::lock_guard<std::mutex> lock(m_);
    open_ = true;
    cv_.notify_all();
  }
  const std::vector<std::string>& classNames() const override { return names_; }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  std::uint64_t started_ = 0;
  bool open_ = false;
  std::vector<std::string> names_{"a", "b"};
};

// pending(): what the estimator asks before trusting a keyframe's new landmarks (their labels may
// still come) or giving up on its labels (they never will).
TEST(AsyncSegmenter, PendingWhileQueuedRunningOrUntakenNotWhenDroppedFailedOrTaken) {
  auto net = std::make_shared<GatedSegmenter>();
  AsyncSegmenter runner(net, 2, 8);
  const cv::Mat img(4, 4, CV_8UC3, cv::Scalar(0));
  EXPECT_FALSE(runner.pending(1)) << "never submitted";
  runner.submit(img, {1, 0.0});
  net->waitStarted(1);
  runner.submit(img, {2, 0.0});
  runner.submit(img, {13, 0.0});
  EXPECT_TRUE(runner.pending(1)) << "being segmented";
  EXPECT_TRUE(runner.pending(2)) << "queued";
  EXPECT_TRUE(runner.pending(13)) << "queued";
  runner.submit(img, {4, 0.0});  // the queue holds 2: the oldest waiting (2) is dropped
  EXPECT_FALSE(runner.pending(2)) << "dropped";
  EXPECT_TRUE(runner.pending(4));
  net->open();
  EXPECT_FALSE(runner.waitFor(13, std::chrono::seconds(5)).has_value());
  EXPECT_FALSE(runner.pending(13)) << "failed";
  ASSERT_TRUE(runner.waitFor(4, std::chrono::seconds(5)).has_value());
  EXPECT_FALSE(runner.pending(4)) << "taken";
  EXPECT_TRUE(runner.pending(1)) << "done, not yet taken";
  ASSERT_TRUE(runner.take(1).has_value());
  EXPECT_FALSE(runner.pending(1)) << "taken";
  runner.submit(img, {5, 0.0});
  runner.shutdown();
  EXPECT_FALSE(runner.pending(5)) << "shut down";
}

// The real network on real frames: person IoU against DynaSLAM's masks.
TEST(OnnxSegmenter, RealNetworkSegmentsPeopleOnTumFrames) {
  const std::string shared = RVWO_SHARED_DIR;
  const std::string model = shared + "/models/deeplabv3_mnv2_voc21.onnx";
  if (!fs::exists(model)) GTEST_SKIP() << "../shared is absent: no real model to run";
  OnnxSegmenterOptions o;
  o.model_path = model;
  o.class_names = SemanticPriors::builtin("voc21").classes();
  o.intra_op_threads = 2;
  OnnxSegmenter seg(o);
  const int person = SemanticPriors::builtin("voc21").labelOf("person");
  int frames = 0;
  for (const auto& entry : fs::directory_iterator(shared + "/data/tum_fr3_walking_xyz/rgb")) {
    const cv::Mat rgb = cv::imread(entry.path().string(), cv::IMREAD_COLOR);
    const cv::Mat mask =
        cv::imread(shared + "/data/tum_fr3_walking_xyz/mask/" + entry.path().filename().string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(rgb.empty());
    ASSERT_FALSE(mask.empty());
    const Segmentation s = seg.segment(rgb);
    const cv::Mat predicted = s.labels == person, truth = mask == 0;
    const double inter = cv::countNonZero(predicted & truth), uni = cv::countNonZero(predicted | truth);
    const double iou = inter / uni;
    std::cout << entry.path().filename().string() << ": person IoU " << iou << "\n";
    EXPECT_GE(iou, 0.75);
    ++frames;
  }
  EXPECT_EQ(frames, 2);
}

}  // namespace
}  // namespace rvwo
