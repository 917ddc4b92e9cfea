// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "replay/record_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "rvwo/settings/settings.h"

namespace rvwo::apps {

namespace {

// The sensor an event belongs to (0 camera, 1 odometry) and its time; -1 for the others.
int sensorOf(const ReplayEvent& e, double* t) {
  if (const auto* f = std::get_if<estimator::FrameInput>(&e)) {
    *t = f->timestamp;
    return 0;
  }
  if (const auto* o = std::get_if<OdometryRecord>(&e)) {
    *t = o->t;
    return 1;
  }
  return -1;
}

template <typename... Number>
std::string format(const char* pattern, Number... n) {
  char s[200];
  std::snprintf(s, sizeof s, pattern, n...);
  return s;
}

}  // namespace

std::vector<ReplayEvent> RecordClock::admit(ReplayEvent e) {
  std::vector<ReplayEvent> out;
  double t = NAN;
  const int sensor = sensorOf(e, &t);
  if (sensor < 0 || !std::isfinite(t)) {
    out.push_back(std::move(e));
    return out;
  }
  if (held_[sensor]) {
    auto [held, t_held] = std::move(*held_[sensor]);
    held_[sensor].reset();
    if (t > t_held) {
      take(std::move(held), t_held, &out);
    } else {
      out.push_back(refuted(held, t_held, last_, "and the next one goes back"));
    }
  }
  if (!std::isnan(last_) && t - last_ > max_gap_) {
    held_[sensor].emplace(std::move(e), t);
  } else {
    take(std::move(e), t, &out);
  }
  return out;
}

std::vector<ReplayEvent> RecordClock::finish() {
  std::vector<ReplayEvent> out;
  for (auto& h : held_) {
    if (h) out.push_back(refuted(h->first, h->second, last_, "and is the last one"));
    h.reset();
  }
  return out;
}

void RecordClock::take(ReplayEvent e, double t, std::vector<ReplayEvent>* out) {
  if (std::isnan(last_) || t > last_) last_ = t;
  out->push_back(std::move(e));
}

SkippedRecord RecordClock::refuted(const ReplayEvent& held, double t_held, double last, const char* why) {
  double t = NAN;
  const char* what = sensorOf(held, &t) == 0 ? "frame" : "odometry";
  return {std::string(what) + " at t = " + std::to_string(t_held) + ": its time jumps " +
          format("%.3g", t_held - last) + " s ahead of the records before it " + why +
          " (a corrupt time; Rawlog.MaxGap is the largest pause believed without a record after it)"};
}

OdometryLimits readOdometryLimits(const Settings& s) {
  OdometryLimits l;
  const auto read = [&](const char* key, double* value, bool zero_allowed) {
    *value = s.number(key).value_or(*value);
    if (!(zero_allowed ? *value >= 0 : *value > 0) || !std::isfinite(*value))
      throw std::invalid_argument(s.path() + ": " + key +
                                  (zero_allowed ? " must be >= 0 (0: not checked)" : " must be > 0"));
  };
  read("Odometry.MaxSpeed", &l.max_speed, false);
  read("Odometry.MaxTurnRate", &l.max_turn_rate, false);
  read("Odometry.MaxAcceleration", &l.max_acceleration, true);
  return l;
}

std::string OdometryGate::pose(double t, const SE2& T_odom_o) {
  if (std::isnan(last_t_)) {
    last_t_ = t;
    last_pose_ = T_odom_o;
  }
  if (!(t > last_t_)) return "";  // the first reading, or a time that does not increase (the backend refuses it)
  const SE2 d = last_pose_.inverse() * T_odom_o;
  const double dt = t - last_t_;
  const std::string why = judge(t, d.translation().norm() / dt, std::fabs(d.angle()) / dt);
  if (why.empty()) last_pose_ = T_odom_o;
  return why;
}

std::string OdometryGate::wheelAngles(double t, double q_left, double q_right) {
  if (std::isnan(last_t_)) {
    last_t_ = t;
    last_q_left_ = q_left;
    last_q_right_ = q_right;
  }
  if (!(t > last_t_)) return "";
  const double dt = t - last_t_;
  const double v_l = (q_left - last_q_left_) * drive_.radius_left / dt,
               v_r = (q_right - last_q_right_) * drive_.radius_right / dt;
  const std::string why = judge(t, std::max(std::fabs(v_l), std::fabs(v_r)), std::fabs(v_r - v_l) / drive_.track);
  if (why.empty()) {
    last_q_left_ = q_left;
    last_q_right_ = q_right;
  }
  return why;
}

std::string OdometryGate::wheelSpeeds(double t, double w_left, double w_right) {
  if (std::isnan(last_t_)) last_t_ = t;
  if (!(t > last_t_)) return "";
  const double v_l = w_left * drive_.radius_left, v_r = w_right * drive_.radius_right;
  return judge(t, std::max(std::fabs(v_l), std::fabs(v_r)), std::fabs(v_r - v_l) / drive_.track);
}

std::string OdometryGate::judge(double t, double v, double omega) {
  const double dt = t - last_t_;
  std::string why;
  if (!(v <= limits_.max_speed)) {
    why = format("a speed of %.3g m/s over %.3g s (Odometry.MaxSpeed %g)", v, dt, limits_.max_speed);
  } else if (!(omega <= limits_.max_turn_rate)) {
    why = format("a turn rate of %.3g rad/s over %.3g s (Odometry.MaxTurnRate %g)", omega, dt, limits_.max_turn_rate);
  } else if (limits_.max_acceleration > 0 && last_v_ &&
             std::fabs(v - *last_v_) > limits_.max_acceleration * dt + 0.1 * limits_.max_speed) {
    why = format("a speed change of %.3g m/s in %.3g s (Odometry.MaxAcceleration %g)", std::fabs(v - *last_v_), dt,
                 limits_.max_acceleration);
  }
  if (!why.empty()) return why;
  last_t_ = t;
  last_v_ = v;
  return "";
}

}  // namespace rvwo::apps
