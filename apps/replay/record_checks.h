// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Records no robot could have produced, caught before they reach a backend: a time that jumps
// ahead of the rawlog's clock and back (RecordClock), and odometry faster, turning faster or
// accelerating harder than a wheeled robot does (OdometryGate). Both name what they refuse, in a
// few words with the figure, for the replay's "skipped" lines.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "replay/input.h"
#include "rvwo/edges/se2.h"
#include "rvwo/edges/wheel_preintegration.h"

namespace rvwo {
class Settings;
}

namespace rvwo::apps {

// Camera frames and odometry readings against one clock: a record more than max_gap seconds
// ahead of the last one taken (of either) is held until its sensor's next record. If that one
// goes on from there, the clock jumped (a pause in the recording) and both are taken; if it goes
// back, the held record's time is corrupt and it becomes a SkippedRecord. Labels and skipped
// records pass; times that do not increase pass too (the backend refuses them, naming them).
class RecordClock {
 public:
  explicit RecordClock(double max_gap) : max_gap_(max_gap) {}
  // The events to handle now, in order, for the next one read.
  std::vector<ReplayEvent> admit(ReplayEvent e);
  // At the end of the rawlog: a record still held is refuted (nothing after it confirms its time).
  std::vector<ReplayEvent> finish();

 private:
  void take(ReplayEvent e, double t, std::vector<ReplayEvent>* out);
  static SkippedRecord refuted(const ReplayEvent& held, double t_held, double last, const char* why);

  double max_gap_;
  double last_ = NAN;                                      // s: the latest time taken
  std::optional<std::pair<ReplayEvent, double>> held_[2];  // per sensor (camera, odometry): the event, its time
};

// A wheeled robot's limits (settings keys beside each; docs/decisions/0012 for the defaults).
struct OdometryLimits {
  double max_speed = 10.0;        // m/s, of either wheel or the body (Odometry.MaxSpeed)
  double max_turn_rate = 10.0;    // rad/s (Odometry.MaxTurnRate)
  double max_acceleration = 0.0;  // m/s^2, between readings' speeds; 0: not checked (Odometry.MaxAcceleration)
};
// Throws std::invalid_argument naming the key of a limit out of range (speed and turn rate above
// 0, acceleration 0 or above).
OdometryLimits readOdometryLimits(const Settings& s);

// Each odometry reading against the last one it accepted: the speed (of each wheel, or of the
// body for pose odometry), the turn rate and the acceleration they imply must be within the
// limits. A reading refused leaves the last one accepted where it was, so that the next reading
// is judged over both intervals. Returns "" for a reading accepted, else why not.
class OdometryGate {
 public:
  OdometryGate(const OdometryLimits& limits, const DiffDriveParams& drive) : limits_(limits), drive_(drive) {}
  std::string pose(double t, const SE2& T_odom_o);
  std::string wheelAngles(double t, double q_left, double q_right);  // rad, cumulative
  std::string wheelSpeeds(double t, double w_left, double w_right);  // rad/s

 private:
  // v: m/s, the faster wheel's (or the body's); omega: rad/s; over [last t, t].
  std::string judge(double t, double v, double omega);

  OdometryLimits limits_;
  DiffDriveParams drive_;
  double last_t_ = NAN;
  SE2 last_pose_;
  double last_q_left_ = 0.0, last_q_right_ = 0.0;
  std::optional<double> last_v_;  // m/s, over the interval before
};

}  // namespace rvwo::apps
