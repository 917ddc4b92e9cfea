// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Reliability model (paper eqs. 4 to 7): the filter against hand-computed values, the shape
// function at its landmarks, the behaviours the paper promises, and the thread-safe manager.
#include "rvwo/kernels/reliability.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

#include "rvwo/kernels/semantic_priors.h"

namespace rvwo {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Reliability, FilterMatchesHandComputation) {
  // Defaults: l1 = 0.95, l2 = 0.01, Ps0 = 0; person prior 0.95. By hand:
  //   P- = 0.95 Ps + 0.01 (1 - Ps);  Ps = 0.95 P- / (0.95 P- + 0.05 (1 - P-))
  //   frame 1: P- = 0.01                Ps = 0.0095 / 0.059          = 0.161016949152542
  //   frame 2: P- = 0.161355932203390   Ps = 0.153288135593220 / ... = 0.785205764889738
  //   frame 3: P- = 0.748093418996354   Ps =                           0.982585916863067
  const ReliabilityParams p;
  LandmarkReliabilityFilter f(p);
  const double want[] = {0.161016949152542, 0.785205764889738, 0.982585916863067};
  for (double w : want) {
    f.observeLabel(0.95, p);
    EXPECT_NEAR(f.state().ps, w, 1e-14);
  }
  EXPECT_NEAR(predictMoving(0.5, p), 0.48, 1e-15);
  EXPECT_NEAR(updateMoving(0.3, 0.5), 0.3, 1e-15);  // prior 0.5 carries no evidence
  EXPECT_EQ(updateMoving(0.0, 1.0), 0.0);           // contradictory certainties: no NaN
}

TEST(Reliability, PersonForThreeFramesIsRejected) {
  const ReliabilityParams p;
  LandmarkReliabilityFilter f(p);
  f.observeError(0.5, p);  // small reprojection error: the semantic channel alone must do it
  f.observeLabel(0.95, p);
  f.observeLabel(0.95, p);
  EXPECT_TRUE(std::isfinite(f.state().alpha)) << "two labels should not yet reject";
  EXPECT_LT(f.state().alpha, -4.0);
  f.observeLabel(0.95, p);
  EXPECT_EQ(f.state().alpha, -kInf);
}

TEST(Reliability, StaticLandmarkWithSmallErrorKeepsAlphaOne) {
  const ReliabilityParams p;
  LandmarkReliabilityFilter unlabelled(p), background(p);
  EXPECT_EQ(unlabelled.state().alpha, 1.0);
  for (int i = 0; i < 20; ++i) {
    unlabelled.observeError(1.0, p);
    background.observeError(1.0, p);
    background.observeLabel(SemanticPriors::builtin("voc21").prior(0), p);
  }
  EXPECT_EQ(unlabelled.state().alpha, 1.0);
  EXPECT_GT(background.state().alpha, 0.98);
  EXPECT_LE(background.state().alpha, 1.0);
}

TEST(Reliability, OneMissedLabelDoesNotHandAWalkerBack) {
  // A walker labelled person five times, missed once by the segmenter, then seen again.
  const ReliabilityParams p;
  const SemanticPriors voc = SemanticPriors::builtin("voc21");
  LandmarkReliabilityFilter f(p);
  for (int i = 0; i < 5; ++i) f.observeLabel(voc.prior(voc.labelOf("person")), p);
  f.observeLabel(voc.prior(voc.labelOf("background")), p);
  EXPECT_LT(f.state().alpha, -5.0);
  f.observeLabel(voc.prior(voc.labelOf("person")), p);
  EXPECT_EQ(f.state().alpha, -kInf);
}

TEST(Reliability, OutlierProbabilityClampsOnBothSides) {
  const ReliabilityParams p;
  EXPECT_EQ(outlierProbability(0.0, p), 0.0);  // eq. 6 as printed would give > 0 here
  EXPECT_EQ(outlierProbability(p.e_th, p), 0.0);
  EXPECT_NEAR(outlierProbability(0.5 * (p.e_th + p.e_max), p), 0.5, 1e-15);
  EXPECT_EQ(outlierProbability(p.e_max, p), 1.0);
  EXPECT_EQ(outlierProbability(1e9, p), 1.0);
  LandmarkReliabilityFilter f(p);
  f.observeError(std::nan(""), p);
  EXPECT_EQ(f.state().po, 1.0);
}

TEST(Reliability, ShapeFunctionLandmarks) {
  const ReliabilityParams p;
  EXPECT_EQ(shapeFromReliability(1.0, p), 1.0);
  EXPECT_NEAR(shapeFromReliability(0.5, p), -2.0, 1e-15);
  EXPECT_NEAR(shapeFromReliability(0.1, p), -7.28, 1e-14);  // u = Ph: still finite
  EXPECT_EQ(shapeFromReliability(0.1 - 1e-12, p), -kInf);
  EXPECT_NEAR(reliability(0.2, 0.4, p), 1.0 - (0.95 * 0.2 + 0.05 * 0.4), 1e-15);
}

TEST(Reliability, ParamsBySettingsKey) {
  ReliabilityParams p;
  EXPECT_EQ(ReliabilityParams::keys().size(), 11u);
  EXPECT_TRUE(p.set("Reliability.Ph", 0.8));
  EXPECT_EQ(p.p_h, 0.8);
  EXPECT_EQ(*p.get("Reliability.a"), -8.0);
  EXPECT_FALSE(p.set("Reliability.Nope", 1.0));
  EXPECT_FALSE(p.get("Reliability.Nope").has_value());
  p.set("Reliability.Ws", 0.7);
  try {
    p.validate();
    FAIL() << "Ws + Wo != 1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("Reliability.Wo"), std::string::npos) << e.what();
  }
  ReliabilityParams q;
  q.e_max = q.e_th;
  EXPECT_THROW(q.validate(), std::invalid_argument);
  EXPECT_THROW(ReliabilityManager{q}, std::invalid_argument);
}

TEST(ReliabilityManager, ObserveGetForget) {
  ReliabilityManager m;
  EXPECT_FALSE(m.get(7).has_value());
  EXPECT_EQ(m.alpha(7), 1.0);
  for (int i = 0; i < 3; ++i) m.observe(7, 0.95, 0.3);
  m.observe(8, std::nullopt, 100.0);
  EXPECT_EQ(m.alpha(7), -kInf);
  EXPECT_EQ(m.get(7)->labelled, 3u);
  EXPECT_EQ(m.get(8)->po, 1.0);
  EXPECT_NEAR(m.alpha(8), shapeFromReliability(1.0 - 0.05, m.params()), 1e-15);
  EXPECT_EQ(m.size(), 2u);
  m.forget(7);
  EXPECT_FALSE(m.get(7).has_value());
  EXPECT_EQ(m.size(), 1u);
}

TEST(ReliabilityManager, TwoThreadsAtOnce) {
  // Tracking and mapping update overlapping landmarks concurrently; every observation must land
  // exactly once (run under ThreadSanitizer in the sanitizer build).
  ReliabilityManager m;
  constexpr int kIds = 500, kRounds = 40;
  auto work = [&](int thread) {
    for (int r = 0; r < kRounds; ++r) {
      for (int id = 0; id < kIds; ++id) m.observe(id, (id % 2) ? 0.95 : 0.1, 0.1 * thread);
      if (thread == 1 && r == kRounds - 1) m.forget(kIds + 1);  // forgetting absent ids is fine
    }
  };
  std::thread a(work, 0), b(work, 1);
  a.join();
  b.join();
  EXPECT_EQ(m.size(), static_cast<std::size_t>(kIds));
  for (int id = 0; id < kIds; ++id) {
    EXPECT_EQ(m.get(id)->labelled, 2u * kRounds);
    EXPECT_EQ(m.alpha(id) == -kInf, id % 2 == 1) << id;
  }
}

TEST(SemanticPriors, BuiltinTables) {
  const struct {
    const char* name;
    std::size_t size;
  } sets[] = {{"voc21", 21}, {"coco80", 80}, {"ade20k150", 150}};
  for (const auto& s : sets) {
    const SemanticPriors p = SemanticPriors::builtin(s.name);
    EXPECT_EQ(p.size(), s.size) << s.name;
    EXPECT_EQ(p.prior(p.labelOf("person")), 0.95) << s.name;
    EXPECT_EQ(p.dynamicLabels(0.9), std::vector<int>{p.labelOf("person")}) << s.name;
    EXPECT_EQ(p.prior(-1), SemanticPriors::kNoEvidence);
    EXPECT_EQ(p.prior(static_cast<int>(s.size)), SemanticPriors::kNoEvidence);
  }
  EXPECT_EQ(SemanticPriors::builtin("voc21").labelOf("person"), 15);  // the shared model's id
  EXPECT_EQ(SemanticPriors::builtin("ade20k150").labelOf("person"), 12);
  EXPECT_EQ(SemanticPriors::builtin("coco80").labelOf("person"), 0);
  EXPECT_THROW(SemanticPriors::builtin("cityscapes"), std::invalid_argument);
}

TEST(SemanticPriors, OverrideFromStream) {
  SemanticPriors p = SemanticPriors::builtin("voc21");
  std::istringstream ok("# my robot's world\n\nchair: 0.6   # chairs on wheels\n  dog :0.99\n");
  p.overrideFrom(ok, "mine.txt");
  EXPECT_EQ(p.prior(p.labelOf("chair")), 0.6);
  EXPECT_EQ(p.prior(p.labelOf("dog")), 0.99);
  const struct {
    const char* text;
    const char* expect;
  } bad[] = {{"chair 0.6\n", "mine.txt:1: expected"},
             {"\nunicorn: 0.5\n", "mine.txt:2: class 'unicorn'"},
             {"chair: 1.5\n", "mine.txt:1: class 'chair': prior must be in [0, 1]"},
             {"chair: 0.5x\n", "mine.txt:1: '0.5x' is not a number"}};
  for (const auto& b : bad) {
    std::istringstream in(b.text);
    try {
      p.overrideFrom(in, "mine.txt");
      FAIL() << "accepted: " << b.text;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(b.expect, 0), 0u) << e.what();
    }
  }
  EXPECT_THROW(SemanticPriors("x", {"a", "b"}, {0.1}), std::invalid_argument);
}

}  // namespace
}  // namespace rvwo
