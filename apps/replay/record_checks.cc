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
  char s[400];
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
  poses_ = true;
  Reading r;
  r.t = t;
  r.pose = T_odom_o;
  return judge(r);
}

std::string OdometryGate::wheelAngles(double t, double q_left, double q_right) {
  Reading r;
  r.t = t;
  r.q = Eigen::Vector2d(q_left, q_right);
  return judge(r);
}

std::string OdometryGate::wheelSpeeds(double t, double w_left, double w_right) {
  if (std::isnan(last_speeds_t_)) last_speeds_t_ = t;
  if (!(t > last_speeds_t_)) return "";
  const double dt = t - last_speeds_t_;
  const double v_l = w_left * drive_.radius_left, v_r = w_right * drive_.radius_right;
  const double v = std::max(std::fabs(v_l), std::fabs(v_r));
  const std::string why = beyondLimits(v, std::fabs(v_r - v_l) / drive_.track, dt, true);
  if (!why.empty()) return why;
  last_speeds_t_ = t;
  last_v_ = v;
  return "";
}

std::pair<double, double> OdometryGate::motion(const Reading& a, const Reading& b) const {
  const double dt = b.t - a.t;
  if (poses_) {
    const SE2 d = a.pose.inverse() * b.pose;
    return {d.translation().norm() / dt, std::fabs(d.angle()) / dt};
  }
  const double v_l = (b.q.x() - a.q.x()) * drive_.radius_left / dt,
               v_r = (b.q.y() - a.q.y()) * drive_.radius_right / dt;
  return {std::max(std::fabs(v_l), std::fabs(v_r)), std::fabs(v_r - v_l) / drive_.track};
}

Eigen::Vector3d OdometryGate::rate(const Reading& a, const Reading& b) const {
  const double dt = b.t - a.t;
  if (poses_) return (a.pose.inverse() * b.pose).log() / dt;
  return Eigen::Vector3d((b.q.x() - a.q.x()) / dt, (b.q.y() - a.q.y()) / dt, 0.0);
}

std::string OdometryGate::beyondLimits(double v, double omega, double dt, bool acceleration) const {
  if (!(v <= limits_.max_speed))
    return format("a speed of %.3g m/s over %.3g s (Odometry.MaxSpeed %g)", v, dt, limits_.max_speed);
  if (!(omega <= limits_.max_turn_rate))
    return format("a turn rate of %.3g rad/s over %.3g s (Odometry.MaxTurnRate %g)", omega, dt, limits_.max_turn_rate);
  if (acceleration && limits_.max_acceleration > 0 && last_v_ &&
      std::fabs(v - *last_v_) > limits_.max_acceleration * dt + 0.1 * limits_.max_speed) {
    return format("a speed change of %.3g m/s in %.3g s (Odometry.MaxAcceleration %g)", std::fabs(v - *last_v_), dt,
                  limits_.max_acceleration);
  }
  return "";
}

std::string OdometryGate::judge(const Reading& b) {
  restart_.clear();
  if (!last_) last_ = b;
  if (!(b.t > last_->t)) return "";  // the first reading, or a time that does not increase (the backend refuses it)
  const double dt = b.t - last_->t;
  const auto [v, omega] = motion(*last_, b);
  const std::string why = beyondLimits(v, omega, dt, true);
  if (why.empty()) {
    rate_ = rate(*last_, b);
    last_ = b;
    last_v_ = v;
    run_.clear();
    return "";
  }
  // Refused: does it go on from the refused readings before it?
  if (!run_.empty()) {
    const auto [rv, romega] = motion(run_.back(), b);
    if (!(b.t > run_.back().t) || !beyondLimits(rv, romega, b.t - run_.back().t, false).empty()) run_.clear();
  }
  if (run_.empty()) run_why_ = why;
  run_.push_back(b);
  if (static_cast<int>(run_.size()) < kRestartReadings) return why;
  restartAt(b);
  return "";
}

// The run becomes the odometry: from the last reading taken, across the jump to the run's first
// at the rate before it, then as the run itself moves.
void OdometryGate::restartAt(const Reading& b) {
  const Reading& first = run_.front();
  const double gap = first.t - last_->t;
  if (poses_) {
    correction_ = correction_ * last_->pose * SE2::exp(rate_ * gap) * first.pose.inverse();
  } else {
    offset_ += last_->q + rate_.head<2>() * gap - first.q;
  }
  restart_ = format(
      "odometry restarted at t = %.6f: the %d readings from t = %.6f on agree among themselves but not "
      "with the one before (%s); taken as a new origin, the jump bridged at the speed before it",
      b.t, static_cast<int>(run_.size()), first.t, run_why_.c_str());
  rate_ = rate(run_[run_.size() - 2], b);
  last_ = b;
  last_v_.reset();
  run_.clear();
}

}  // namespace rvwo::apps
