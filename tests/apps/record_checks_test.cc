// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The replay's record checks: a camera or odometry time corrupted far ahead is skipped, not made
// the new clock, while a real pause in the recording (every sensor jumps and goes on) is kept;
// odometry a wheeled robot cannot give (a reading 1000 m off, encoder ticks that jump by 1e6 or
// back by 5000, a spin faster than the limit, a spike where an acceleration limit is set) is
// refused, and the reading after it is judged against the last one accepted; a robot that drives
// backwards is no fault; a jump that persists (a counter reset) becomes a new origin.
#include "replay/record_checks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "rvwo/settings/settings.h"

namespace rvwo::apps {
namespace {

ReplayEvent frame(double t) {
  estimator::FrameInput f;
  f.timestamp = t;
  return f;
}
ReplayEvent odometry(double t) { return OdometryRecord{t, SE2(), false, false, 0, 0, 0, 0}; }

// What a record stream becomes: "f<t>" / "o<t>" for records taken, "skip" for one refuted.
std::vector<std::string> through(RecordClock* clock, const std::vector<ReplayEvent>& in, std::string* why = nullptr) {
  std::vector<std::string> out;
  const auto note = [&](const std::vector<ReplayEvent>& events) {
    for (const ReplayEvent& e : events) {
      if (const auto* f = std::get_if<estimator::FrameInput>(&e)) out.push_back("f" + std::to_string(f->timestamp));
      if (const auto* o = std::get_if<OdometryRecord>(&e)) out.push_back("o" + std::to_string(o->t));
      if (const auto* s = std::get_if<SkippedRecord>(&e)) {
        out.push_back("skip");
        if (why) *why = s->why;
      }
    }
  };
  for (const ReplayEvent& e : in) note(clock->admit(e));
  note(clock->finish());
  return out;
}

TEST(RecordClock, ACorruptTimeIsSkippedNotTakenAsTheClock) {
  RecordClock clock(1.0);
  std::string why;
  const auto out = through(&clock, {frame(1.0), odometry(1.01), frame(1.8e12), odometry(1.05), frame(1.1)}, &why);
  EXPECT_EQ(out, (std::vector<std::string>{"f" + std::to_string(1.0), "o" + std::to_string(1.01),
                                           "o" + std::to_string(1.05), "skip", "f" + std::to_string(1.1)}));
  EXPECT_EQ(why.rfind("frame at t = 1800000000000.000000: its time jumps 1.8e+12 s ahead of the records before it and "
                      "the next one goes back (a corrupt time; Rawlog.MaxGap",
                      0),
            0u)
      << why;
}

TEST(RecordClock, APauseInTheRecordingIsKept) {
  RecordClock clock(1.0);
  const auto out = through(&clock, {frame(1.0), odometry(1.0), frame(6.0), odometry(6.0), frame(6.1), odometry(6.1)});
  ASSERT_EQ(out.size(), 6u);
  for (const std::string& s : out) EXPECT_NE(s, "skip");
  EXPECT_EQ(out[2], "f" + std::to_string(6.0));  // confirmed by the frame at 6.1, handed on before it
}

TEST(RecordClock, AJumpAtTheEndIsRefuted) {
  RecordClock clock(1.0);
  std::string why;
  const auto out = through(&clock, {odometry(1.0), odometry(1.01), odometry(500.0)}, &why);
  EXPECT_EQ(out.back(), "skip");
  EXPECT_NE(why.find("odometry at t = 500.000000: its time jumps 499 s ahead of the records before it and is the last "
                     "one"),
            std::string::npos)
      << why;
}

DiffDriveParams drive() {
  DiffDriveParams d;
  d.radius_left = d.radius_right = 0.08;
  d.track = 0.4;
  return d;
}

TEST(OdometryGate, APoseReadingFarOffIsRefusedAndTheNextJudgedFromTheLastGood) {
  OdometryGate gate(OdometryLimits(), drive());
  for (int k = 0; k < 10; ++k) EXPECT_EQ(gate.pose(0.01 * k, SE2(0.005 * k, 0, 0.002 * k)), "") << k;
  EXPECT_EQ(gate.pose(0.10, SE2(1000.0, 0, 0)).rfind("a speed of 1e+05 m/s over 0.01 s (Odometry.MaxSpeed 10)", 0), 0u);
  EXPECT_EQ(gate.pose(0.11, SE2(0.055, 0, 0.022)), "");  // over 0.02 s from the reading at 0.09 s
  // Backwards at 0.3 m/s is driving, not a fault.
  for (int k = 1; k <= 10; ++k) EXPECT_EQ(gate.pose(0.11 + 0.01 * k, SE2(0.055 - 0.003 * k, 0, 0.022)), "") << k;
  // Spinning at 12 rad/s is beyond the turn-rate limit.
  EXPECT_NE(gate.pose(0.22, SE2(0.025, 0, 0.022 + 0.12)).find("a turn rate of 12 rad/s"), std::string::npos);
}

TEST(OdometryGate, EncoderTicksThatJumpOrRunBackAreRefused) {
  OdometryGate gate(OdometryLimits(), drive());
  const double tick = 2 * M_PI / 4096;
  double ticks = 0;
  for (int k = 0; k < 20; ++k, ticks += 60) EXPECT_EQ(gate.wheelAngles(0.01 * k, ticks * tick, ticks * tick), "") << k;
  // 60 ticks every 10 ms: 0.74 m/s. +1e6 ticks, then -5000 from the last good reading.
  EXPECT_NE(gate.wheelAngles(0.20, (ticks + 1e6) * tick, ticks * tick).find("a speed of"), std::string::npos);
  EXPECT_NE(gate.wheelAngles(0.21, (ticks - 5000) * tick, (ticks - 5000) * tick).find("a speed of"), std::string::npos);
  EXPECT_EQ(gate.wheelAngles(0.22, (ticks + 120) * tick, (ticks + 120) * tick), "");
  // A spike within the top speed (3 m/s in 10 ms after 0.74 m/s) is a fault only with an
  // acceleration limit set.
  const double spike = (ticks + 120 + 240) * tick;
  OdometryGate same = gate;
  EXPECT_EQ(same.wheelAngles(0.23, spike, spike), "");
  OdometryLimits limited;
  limited.max_acceleration = 20.0;
  OdometryGate strict(limited, drive());
  for (int k = 0; k <= 22; ++k) EXPECT_EQ(strict.wheelAngles(0.01 * k, 60 * k * tick, 60 * k * tick), "") << k;
  EXPECT_NE(strict.wheelAngles(0.23, (60 * 22 + 240) * tick, (60 * 22 + 240) * tick).find("a speed change of"),
            std::string::npos);
}

TEST(OdometryGate, LimitsFromTheSettingsAreChecked) {
  const Settings s = Settings::fromString("%YAML:1.0\nOdometry.MaxSpeed: 1.5\nOdometry.MaxTurnRate: 0\n", "o.yaml");
  try {
    readOdometryLimits(s);
    FAIL() << "a turn-rate limit of 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "o.yaml: Odometry.MaxTurnRate must be > 0");
  }
  try {
    readOdometryLimits(Settings::fromString("%YAML:1.0\nOdometry.MaxAcceleration: -1\n", "o.yaml"));
    FAIL() << "an acceleration limit below 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "o.yaml: Odometry.MaxAcceleration must be >= 0 (0: not checked)");
  }
  const OdometryLimits l = readOdometryLimits(Settings::fromString("%YAML:1.0\nOdometry.MaxSpeed: 1.5\n", "o.yaml"));
  EXPECT_EQ(l.max_speed, 1.5);
  EXPECT_EQ(l.max_turn_rate, OdometryLimits().max_turn_rate);
  OdometryGate gate(l, drive());
  EXPECT_EQ(gate.wheelSpeeds(0.0, 10.0, 10.0), "");
  EXPECT_EQ(gate.wheelSpeeds(0.01, 10.0, 10.0), "");  // 0.8 m/s
  EXPECT_NE(gate.wheelSpeeds(0.02, 25.0, 25.0).find("a speed of 2 m/s"), std::string::npos);
}

// Pose odometry 1000 m off from 0.10 s on while the robot drives on at 0.5 m/s and 0.2 rad/s: the
// first kRestartReadings - 1 readings are refused, then the run is the new origin, and every
// reading from there is where the robot is (constant speed: the bridge across the jump is exact).
TEST(OdometryGate, APoseJumpThatPersistsBecomesANewOrigin) {
  OdometryGate gate(OdometryLimits(), drive());
  const auto truth = [](int k) { return SE2::exp(Eigen::Vector3d(0.005 * k, 0, 0.002 * k)); };
  const SE2 jump(1000.0, -20.0, 1.0);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(gate.pose(0.01 * k, truth(k)), "") << k;
  for (int k = 10; k < 10 + OdometryGate::kRestartReadings - 1; ++k) {
    EXPECT_EQ(gate.pose(0.01 * k, jump * truth(k)).rfind("a speed of ", 0), 0u) << k;
    EXPECT_EQ(gate.restart(), "");
  }
  const int k0 = 10 + OdometryGate::kRestartReadings - 1;
  EXPECT_EQ(gate.pose(0.01 * k0, jump * truth(k0)), "");
  EXPECT_EQ(gate.restart().rfind("odometry restarted at t = 0.140000: the 5 readings from t = 0.100000 on agree among "
                                 "themselves but not with the one before (a speed of 1e+05 m/s over 0.01 s",
                                 0),
            0u)
      << gate.restart();
  for (int k = k0; k < 40; ++k) {
    if (k > k0) {
      EXPECT_EQ(gate.pose(0.01 * k, jump * truth(k)), "") << k;
    }
    const SE2 taken = gate.asTaken(jump * truth(k));
    EXPECT_LT((taken.translation() - truth(k).translation()).norm(), 1e-9) << k;
    EXPECT_NEAR(taken.angle(), truth(k).angle(), 1e-9) << k;
    if (k > k0) {
      EXPECT_EQ(gate.restart(), "") << k;
    }
  }
}

// An encoder counter reset to zero while the wheels turn at 60 and 50 ticks a reading: a new
// origin after the run, the angles going on from where they were.
TEST(OdometryGate, EncoderTicksThatRestartFromZeroGoOnFromTheLastAngle) {
  OdometryGate gate(OdometryLimits(), drive());
  const double tick = 2 * M_PI / 4096;
  const auto q = [&](int k, double from) { return Eigen::Vector2d((from + 60 * k) * tick, (from + 50 * k) * tick); };
  for (int k = 0; k < 30; ++k) EXPECT_EQ(gate.wheelAngles(0.01 * k, q(k, 1e6).x(), q(k, 1e6).y()), "") << k;
  int refused = 0;
  for (int k = 30; k < 60; ++k) {
    const Eigen::Vector2d raw = q(k, -60 * 30);  // the counter reads 0 at k = 30
    refused += !gate.wheelAngles(0.01 * k, raw.x(), raw.y()).empty();
    if (k >= 30 + OdometryGate::kRestartReadings - 1) {
      EXPECT_LT((gate.asTaken(raw.x(), raw.y()) - q(k, 1e6)).norm(), 1e-6) << k;
    }
  }
  EXPECT_EQ(refused, OdometryGate::kRestartReadings - 1);
}

// Faults that do not persist start no new origin: a spike of kRestartReadings - 1 readings, and
// readings that jump about with no motion a robot could make between them.
TEST(OdometryGate, FaultsThatDoNotPersistStartNoNewOrigin) {
  OdometryGate gate(OdometryLimits(), drive());
  const auto truth = [](int k) { return SE2(0.005 * k, 0, 0); };
  int k = 0;
  for (; k < 10; ++k) EXPECT_EQ(gate.pose(0.01 * k, truth(k)), "") << k;
  for (int n = 0; n < OdometryGate::kRestartReadings - 1; ++n, ++k)
    EXPECT_NE(gate.pose(0.01 * k, SE2(500.0, 0, 0) * truth(k)), "") << k;
  EXPECT_EQ(gate.pose(0.01 * k, truth(k)), "");
  EXPECT_EQ(gate.restart(), "");
  ++k;
  for (int n = 0; n < 20; ++n, ++k) {
    EXPECT_NE(gate.pose(0.01 * k, SE2(100.0 * (n % 2 ? 1 : -1) * (n + 1), 0, 0)), "") << k;
    EXPECT_EQ(gate.restart(), "");
  }
  EXPECT_EQ(gate.pose(0.01 * k, truth(k)), "");
  const SE2 taken = gate.asTaken(truth(k));
  EXPECT_EQ(taken.translation(), truth(k).translation());  // no correction: the reading as read
}

}  // namespace
}  // namespace rvwo::apps
