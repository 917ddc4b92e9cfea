// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Trajectory evaluation: closed forms (a rigid or similar copy of the truth has zero error after
// the matching alignment; a constant offset gives that offset), timestamp association, TUM
// parsing errors with file and line, and the rvwo-eval program end to end with its JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "../common/temp.h"
#include "support/trajectory.h"

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;

// A wavy 3-D path with rotating attitude, 200 poses at 10 Hz.
Trajectory path() {
  Trajectory t;
  for (int i = 0; i < 200; ++i) {
    StampedPose p;
    p.t = 1000.0 + 0.1 * i;
    const double s = 0.05 * i;
    p.T.translation() << 3 * std::cos(s), 2 * std::sin(1.3 * s), 0.2 * std::sin(3 * s);
    p.T.linear() = (Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(0.1 * std::sin(s), Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
    t.push_back(p);
  }
  return t;
}

Trajectory transformed(const Trajectory& in, const Eigen::Isometry3d& T, double scale = 1.0) {
  Trajectory out = in;
  for (StampedPose& p : out) {
    p.T.translation() = scale * p.T.translation();
    p.T = T * p.T;
  }
  return out;
}

Eigen::Isometry3d someTransform(bool z_only) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = z_only ? Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitZ()).toRotationMatrix()
                      : Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  T.translation() << 4, -1, 0.3;
  return T;
}

TEST(Eval, RigidCopyHasZeroAteAfterSe3) {
  const Trajectory gt = path(), est = transformed(gt, someTransform(false));
  const auto pairs = associate(gt, est, 0.01);
  ASSERT_EQ(pairs.size(), gt.size());
  EXPECT_LT(ate(gt, est, pairs, Alignment::kSE3).stats.max, 1e-9);
  EXPECT_GT(ate(gt, est, pairs, Alignment::kNone).stats.rmse, 1.0);
  EXPECT_GT(ate(gt, est, pairs, Alignment::kPosYaw).stats.rmse, 0.1);  // a tilt posyaw cannot undo
  EXPECT_LT(rpe(gt, est, pairs, 1, false).stats.max, 1e-9);            // RPE ignores the global frame
}

TEST(Eval, YawCopyHasZeroAteAfterPosYaw) {
  const Trajectory gt = path(), est = transformed(gt, someTransform(true));
  const auto pairs = associate(gt, est, 0.01);
  const AteResult a = ate(gt, est, pairs, Alignment::kPosYaw);
  EXPECT_LT(a.stats.max, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(a.alignment.R).angle(), 1.2, 1e-9);
}

TEST(Eval, ScaledCopyNeedsSim3) {
  const Trajectory gt = path(), est = transformed(gt, someTransform(false), 0.5);
  const auto pairs = associate(gt, est, 0.01);
  const AteResult s = ate(gt, est, pairs, Alignment::kSim3);
  EXPECT_LT(s.stats.max, 1e-9);
  EXPECT_NEAR(s.alignment.s, 2.0, 1e-12);
  EXPECT_GT(ate(gt, est, pairs, Alignment::kSE3).stats.rmse, 0.5);
}

TEST(Eval, ConstantOffsetGivesThatOffset) {
  const Trajectory gt = path();
  Trajectory est = gt;
  for (StampedPose& p : est) p.T.translation() += Eigen::Vector3d(0.1, 0.0, 0.0);  // 10 cm, world frame
  const auto pairs = associate(gt, est, 0.01);
  const ErrorStats s = ate(gt, est, pairs, Alignment::kNone).stats;
  EXPECT_NEAR(s.rmse, 0.1, 1e-12);
  EXPECT_NEAR(s.mean, 0.1, 1e-12);
  EXPECT_NEAR(s.median, 0.1, 1e-12);
  EXPECT_NEAR(s.max, 0.1, 1e-12);
  EXPECT_NEAR(s.std, 0.0, 1e-7);
  EXPECT_LT(ate(gt, est, pairs, Alignment::kSE3).stats.max, 1e-12);
}

TEST(Eval, RpeOfAKnownScaleErrorPerFrameAndPerMetre) {
  // The estimate travels 10 % too far: each relative motion's error is 10 % of its length.
  const Trajectory gt = path(), est = transformed(gt, Eigen::Isometry3d::Identity(), 1.1);
  const auto pairs = associate(gt, est, 0.01);
  const RpeResult r = rpe(gt, est, pairs, 5, false);
  ASSERT_EQ(r.stats.n, (gt.size() - 1) / 5);
  for (std::size_t k = 0; k < r.errors.size(); ++k) {
    const std::size_t a = 5 * k, b = a + 5;
    EXPECT_NEAR(r.errors[k], 0.1 * (gt[b].T.translation() - gt[a].T.translation()).norm(), 1e-12);
  }
  const RpeResult m = rpe(gt, est, pairs, 1.0, true, true);
  EXPECT_GT(m.stats.n, 5u);
  EXPECT_NEAR(m.stats.mean, 0.1, 0.02);  // chords of about a metre along a smooth curve
  EXPECT_THROW(rpe(gt, est, pairs, 1.5, false), std::invalid_argument);
}

TEST(Eval, AssociationByNearestTimestamp) {
  const Trajectory gt = path();
  Trajectory late = gt;
  for (StampedPose& p : late) p.t += 0.004;
  EXPECT_EQ(associate(gt, late, 0.01).size(), gt.size());
  for (StampedPose& p : late) p.t += 0.02;
  EXPECT_EQ(associate(gt, late, 0.01).size(), 0u);
  // An estimate at a third of the rate pairs with every third ground-truth pose.
  Trajectory sparse;
  for (std::size_t i = 0; i < gt.size(); i += 3) sparse.push_back(gt[i]);
  const auto pairs = associate(gt, sparse, 0.01);
  ASSERT_EQ(pairs.size(), sparse.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) EXPECT_EQ(pairs[k].first, 3 * k);
}

TEST(Eval, LostFramesAreHeldAtTheLastPoseKept) {
  const Trajectory gt = path();
  std::vector<double> times;
  for (const StampedPose& p : gt) times.push_back(p.t + 0.003);  // frames a little off the poses
  // Kept: frames 5-19 and 30 on (the first 5 before initialisation, 20-29 lost).
  Trajectory kept;
  for (std::size_t i = 0; i < gt.size(); ++i)
    if ((i >= 5 && i < 20) || i >= 30) kept.push_back(gt[i]);
  const Trajectory held = heldAtLastPose(kept, times, 0.01);
  ASSERT_EQ(held.size(), gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const std::size_t from = i < 5 ? 5 : (i >= 20 && i < 30) ? 19 : i;
    EXPECT_EQ(held[i].t, times[i]);
    EXPECT_TRUE(held[i].T.isApprox(gt[from].T, 1e-15)) << i;
  }
  // Over every frame the lost stretch counts: at least its frames' travel since frame 19.
  const auto pairs = associate(gt, held, 0.01);
  ASSERT_EQ(pairs.size(), gt.size());
  const ErrorStats s = ate(gt, held, pairs, Alignment::kNone).stats;
  EXPECT_NEAR(s.max, (gt[29].T.translation() - gt[19].T.translation()).norm(), 1e-12);
  EXPECT_LT(ate(gt, kept, associate(gt, kept, 0.01), Alignment::kNone).stats.max, 1e-12);
  EXPECT_TRUE(heldAtLastPose({}, times, 0.01).empty());
}

TEST(Eval, TumParsingErrorsNameFileAndLine) {
  const fs::path dir = rvwo::test::scratch("rvwo_eval_test");
  fs::create_directories(dir);
  const auto expectError = [&](const std::string& text, const std::string& fragment) {
    const std::string f = (dir / "t.txt").string();
    std::ofstream(f) << text;
    try {
      readTum(f);
      FAIL() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(f + ":" + fragment), std::string::npos) << e.what();
    }
  };
  expectError("# h\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0\n", "3: expected 8 numbers");
  expectError("1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", "2: timestamps must increase");
  expectError("1 0 0 0 0 0 0 2\n", "1: quaternion of norm 2");
  expectError("1 0 0 nan 0 0 0 1\n", "1: a value is not finite");
  const std::string f = (dir / "blocks.txt").string();
  std::ofstream(f)
      << "scene: home\nframe: base_link\n\nseq: 1\n1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\nseq: 2\n9 5 0 0 0 0 0 1\n";
  EXPECT_EQ(readTum(f, 1).size(), 2u);
  EXPECT_EQ(readTum(f, 2).size(), 1u);
  EXPECT_EQ(readTum(f, 0).size(), 3u);
  EXPECT_THROW(readTum(f, 3), std::runtime_error);
}

TEST(Eval, ProgramEndToEndWithJson) {
  const fs::path dir = rvwo::test::scratch("rvwo_eval_app");
  fs::create_directories(dir);
  const Trajectory gt = path();
  Trajectory est = transformed(gt, someTransform(false));
  est[50].T.translation() += Eigen::Vector3d(0, 0.3, 0);  // one bad pose
  writeTum((dir / "gt.txt").string(), gt);
  writeTum((dir / "est.txt").string(), est);
  EXPECT_EQ(readTum((dir / "gt.txt").string()).size(), gt.size());  // round trip
  const std::string cmd = std::string(RVWO_EVAL) + " --gt " + (dir / "gt.txt").string() + " --est " +
                          (dir / "est.txt").string() + " --json " + (dir / "r.json").string() + " --plot " +
                          (dir / "p.png").string() + " > " + (dir / "out.txt").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::stringstream json;
  json << std::ifstream(dir / "r.json").rdbuf();
  for (const char* key : {"\"ate\": {\"rmse\": ", "\"rpe\": {\"rmse\": ", "\"pairs\": 200", "\"median\": "}) {
    EXPECT_NE(json.str().find(key), std::string::npos) << key << " in " << json.str();
  }
  EXPECT_GT(fs::file_size(dir / "p.png"), 10000u);
  // A delta longer than the run: an error, not an RPE of 0 over no pairs (nor a JSON written).
  for (const auto& [delta, line] : std::vector<std::pair<std::string, std::string>>{
           {"--delta 500", "rvwo-eval: error: --delta 500 frames spans no pair of poses (200 poses paired over "},
           {"--delta 1000 --delta-unit m",
            "rvwo-eval: error: --delta 1000 m spans no pair of poses (200 poses paired over "},
           {"--delta 0", "rvwo-eval: error: --delta must be > 0\n"}}) {
    fs::remove(dir / "r2.json");
    const std::string long_delta = std::string(RVWO_EVAL) + " --gt " + (dir / "gt.txt").string() + " --est " +
                                   (dir / "est.txt").string() + " " + delta + " --json " + (dir / "r2.json").string() +
                                   " > /dev/null 2> " + (dir / "err2.txt").string();
    const int rc = std::system(long_delta.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 1) << delta;
    std::stringstream err2;
    err2 << std::ifstream(dir / "err2.txt").rdbuf();
    const std::string e2 = err2.str();
    EXPECT_EQ(e2.rfind(line, 0), 0u) << e2;
    EXPECT_EQ(std::count(e2.begin(), e2.end(), '\n'), 1) << e2;
    EXPECT_FALSE(fs::exists(dir / "r2.json")) << delta;
  }
  // Bad input: one line on stderr, exit status 1, no crash.
  const std::string bad = std::string(RVWO_EVAL) + " --gt " + (dir / "missing.txt").string() + " --est " +
                          (dir / "est.txt").string() + " 2> " + (dir / "err.txt").string();
  EXPECT_NE(std::system(bad.c_str()), 0);
  std::stringstream err;
  err << std::ifstream(dir / "err.txt").rdbuf();
  EXPECT_EQ(err.str(), "rvwo-eval: error: " + (dir / "missing.txt").string() + ": cannot be read\n");
}

}  // namespace
}  // namespace rvwo::apps
