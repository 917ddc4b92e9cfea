// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The policy suite (tests/common/policy_scenes.h) through RVWO's estimator: its tracker, map and
// local mapping as the estimator runs them (deterministic), fed each frame's features as its front
// end would make them (one descriptor a landmark, stereo column and depth from the truth).
#include <gtest/gtest.h>

#include <future>
#include <random>

#include "../common/policy_scenes.h"
#include "front_end.h"
#include "map.h"
#include "mapper.h"
#include "tracker.h"
#include "wheels.h"

namespace {

using namespace rvwo::estimator;
using rvwo::test::PolicyRig;
using rvwo::test::PolicyScene;

Rig rigOf(const PolicyRig& r) {
  Rig rig;
  rig.sensor = Sensor::kStereo;
  rig.camera = std::make_shared<rvwo::PinholeCamera>(r.fx, r.fx, r.cx, r.cy);
  rig.width = r.width;
  rig.height = r.height;
  rig.fps = r.fps;
  rig.baseline = r.baseline;
  rig.T_b_c = r.T_b_c;
  return rig;
}

// Each landmark's descriptor: 32 random bytes (two differ in about 128 bits of 256).
cv::Mat descriptors(int n) {
  std::mt19937 rng(7);
  cv::Mat d(n, 32, CV_8U);
  for (int k = 0; k < n; ++k)
    for (int b = 0; b < 32; ++b) d.at<std::uint8_t>(k, b) = static_cast<std::uint8_t>(rng() & 0xFF);
  return d;
}

// A network that finds nobody: every pixel background. It makes a run labelled (the keyframes are
// segmented) without labelling the scenes' walkers, as a network that misses them would.
class LabelsNothing final : public rvwo::Segmenter {
 public:
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    return {cv::Mat::zeros(image.size(), CV_32S), cv::Mat()};
  }
  const std::vector<std::string>& classNames() const override { return names_; }

 private:
  std::vector<std::string> names_{"background"};
};

FrameFeatures featuresAt(const PolicyScene& s, const PolicyRig& r, double t, const cv::Mat& descriptors) {
  FrameFeatures out;
  out.raw_image = cv::Mat(r.height, r.width, CV_8U, cv::Scalar(128));  // for the segmenter
  Features& f = out.f;
  for (const rvwo::test::Sighting& g : s.sightings(r, t)) {
    f.keypoints.emplace_back(static_cast<float>(g.u), static_cast<float>(g.v), 31.f, -1.f, 100.f, 0);
    f.descriptors.push_back(descriptors.row(g.landmark));
    f.u_right.push_back(static_cast<float>(g.u_right));
    f.depth.push_back(static_cast<float>(g.depth));
  }
  f.buildGrid(r.width, r.height);
  return out;
}

// labelled: semantics on, keyframes segmented by LabelsNothing; otherwise no semantics.
rvwo::test::PolicyOutcome replay(const PolicyScene& s, bool labelled) {
  const PolicyRig pr;
  EstimatorOptions opt;
  opt.deterministic = true;
  opt.semantics = labelled;
  Context ctx(rigOf(pr), opt);
  Wheels wheels(ctx);
  Map map(ctx, false);
  Mapper mapper(ctx, map, wheels, labelled ? std::make_shared<LabelsNothing>() : nullptr);
  const FrontEnd front_end(ctx);
  Tracker tracker(ctx, map, wheels, mapper, front_end);
  const cv::Mat d = descriptors(s.size());
  double odometry_t = 0;
  for (int i = 0; i < s.frames(pr); ++i) {
    const double t = i / pr.fps;
    for (; odometry_t <= t + 0.011; odometry_t += 0.01) wheels.addPose(odometry_t, s.claimed(odometry_t));
    std::promise<FrameFeatures> made;
    made.set_value(featuresAt(s, pr, t, d));
    FrameInput in;
    in.timestamp = t;
    tracker.processFrame(in, made.get_future());
  }
  rvwo::test::PolicyOutcome o;
  std::lock_guard<std::mutex> lock(map.mutex);
  EXPECT_EQ(map.counters.segmented_keyframes > 0, labelled) << "keyframes segmented only with labels";
  for (const FrameRecord& f : map.frames) {
    if (f.slip) o.slip_t.push_back(f.t);
    o.blind += !f.visual;
    o.max_error = std::max(o.max_error, (s.truth(f.t).inverse() * map.pose(f)).translation().norm());
  }
  return o;
}

class EstimatorPolicy : public ::testing::TestWithParam<PolicyScene> {};

TEST_P(EstimatorPolicy, DecidesAsTheSceneSays) {
  rvwo::test::expectCalls(GetParam(), rvwo::test::PolicyHost::kEstimator, replay(GetParam(), false));
}

// With labels (none of which marks a walker) the estimator runs the creep test, as the plugin does.
TEST_P(EstimatorPolicy, DecidesAsTheSceneSaysWithLabels) {
  rvwo::test::expectCalls(GetParam(), rvwo::test::PolicyHost::kEstimatorLabelled, replay(GetParam(), true));
}

// The creep test trusts vision alone's track, which only labels, heeded by the adaptive kernel,
// keep off walkers: without labels (the scenes above) or with Huber the estimator leaves the
// creep to the slip test, and mono has its stall test.
TEST(EstimatorPolicyOptions, TheCreepTestRunsWithLabelsAndTheAdaptiveKernel) {
  Rig rig = rigOf(PolicyRig());
  EstimatorOptions opt;
  EXPECT_EQ(Tracker::arbiterOptions(rig, opt, true).drift, rvwo::DriftTest::kCreep);
  EXPECT_EQ(Tracker::arbiterOptions(rig, opt, false).drift, rvwo::DriftTest::kNone);
  opt.kernel = KernelChoice::kHuber;
  EXPECT_EQ(Tracker::arbiterOptions(rig, opt, true).drift, rvwo::DriftTest::kNone);
  opt.kernel = KernelChoice::kAdaptive;
  rig.sensor = Sensor::kMono;
  EXPECT_EQ(Tracker::arbiterOptions(rig, opt, true).drift, rvwo::DriftTest::kStall);
}

INSTANTIATE_TEST_SUITE_P(Scenes, EstimatorPolicy, ::testing::ValuesIn(rvwo::test::policyScenes()),
                         [](const ::testing::TestParamInfo<PolicyScene>& i) { return i.param.name; });

}  // namespace
