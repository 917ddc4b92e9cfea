// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Records no robot could have produced, caught before they reach a backend: a time that jumps
// ahead of the rawlog's clock and back (RecordClock), and odometry faster, turning faster or
// accelerating harder than a wheeled robot does (OdometryGate). Both name what they refuse, in a
// few words with the figure, for the replay's "skipped" lines.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
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
//
// A jump that persists (a counter reset, an odometry frame restarted) is a run of refused readings
// that agree among themselves (within the speed and turn-rate limits, reading to reading). Once
// kRestartReadings long, it is taken as a new origin: the readings go on from the last one taken,
// the jump bridged at the speed before it, and restart() says so. Pose and encoder odometry only
// (speeds carry no origin). asTaken() gives a reading as the backend must have it: in the first
// reading's frame, the restarts' jumps taken out (unchanged until a restart).
class OdometryGate {
 public:
  static constexpr int kRestartReadings = 5;  // 50 ms at 100 Hz; the faults seen span one reading

  OdometryGate(const OdometryLimits& limits, const DiffDriveParams& drive) : limits_(limits), drive_(drive) {}
  std::string pose(double t, const SE2& T_odom_o);
  std::string wheelAngles(double t, double q_left, double q_right);  // rad, cumulative
  std::string wheelSpeeds(double t, double w_left, double w_right);  // rad/s

  SE2 asTaken(const SE2& T_odom_o) const { return correction_ * T_odom_o; }
  Eigen::Vector2d asTaken(double q_left, double q_right) const { return offset_ + Eigen::Vector2d(q_left, q_right); }
  // What the last reading accepted restarted ("" : it went on from the one before).
  const std::string& restart() const { return restart_; }

 private:
  // A reading as read: a pose, or the two wheel angles (rad).
  struct Reading {
    double t = 0.0;
    SE2 pose;
    Eigen::Vector2d q = Eigen::Vector2d::Zero();
  };
  // v (m/s: the faster wheel's, or the body's) and omega (rad/s) from a to b.
  std::pair<double, double> motion(const Reading& a, const Reading& b) const;
  // Per second from a to b: the twist, or the two wheel rates (rad/s; third entry 0).
  Eigen::Vector3d rate(const Reading& a, const Reading& b) const;
  // Why a speed and turn rate over dt (and the change from the last speed taken) are beyond the
  // limits; "" within.
  std::string beyondLimits(double v, double omega, double dt, bool acceleration) const;
  // The verdict on b against the last reading taken, and on the run of refused ones.
  std::string judge(const Reading& b);
  void restartAt(const Reading& b);

  OdometryLimits limits_;
  DiffDriveParams drive_;
  bool poses_ = false;                                // the readings are poses (else wheel angles)
  std::optional<Reading> last_;                       // the last reading taken
  std::optional<double> last_v_;                      // m/s, over the interval before it
  Eigen::Vector3d rate_ = Eigen::Vector3d::Zero();    // per second over that interval: twist, or wheel rates
  std::vector<Reading> run_;                          // refused readings in a row that agree among themselves
  std::string run_why_;                               // why the run's first was refused
  SE2 correction_;                                    // T_first_odom: the restarts' jumps
  Eigen::Vector2d offset_ = Eigen::Vector2d::Zero();  // rad, the same for wheel angles
  std::string restart_;
  double last_speeds_t_ = NAN;  // wheelSpeeds: the last reading's time
};

}  // namespace rvwo::apps
