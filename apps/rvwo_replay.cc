// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-replay: replays a rawlog (camera + wheel odometry) through the RVWO estimator and writes
// the robot base's pose at every frame.
//
//   rvwo-replay --settings S.yaml --rawlog R.rawlog --out traj.txt [--gt groundtruth.txt]
//
// Inputs follow docs/rawlog.md (rvwo-sim and rvwo-convert write them). The estimator
// (rvwo/estimator/estimator.h) tracks ORB features against a local map, optimises the pose on
// SE(2) with RVWO's SE(2)-XYZ and wheel edges and each landmark's adaptive Barron kernel, and runs
// local bundle adjustment on a window of keyframes; keyframes are segmented in a thread of their
// own and the labels feed the landmarks' reliability.
//
// Output: traj.txt (TUM: t x y z qx qy qz qw, base frame, z = 0), a progress line on stderr, a
// report on stdout (frames, keyframes, frames on wheels only and when, per-stage timings, speed,
// peak memory, ATE with --gt) and a PNG (trajectory against ground truth, error over time).
//
// Ablations: --mode wheel|vo|vw, --kernel huber|fixed:<alpha>|adaptive, --no-semantics.
// Pace: as fast as it goes (default; --backend orbslam3: as recorded, below); --realtime <x> feeds
// each record no sooner than the robot lived it, sped up x times, so that local mapping and
// segmentation have the slack they would have on the robot (at full speed tracking outruns them);
// --realtime 0: as fast as it goes; --deterministic runs everything inline.
// In a build given ORB_SLAM3_ROOT (a patched ORB-SLAM3 v1.0, patches/orbslam3/), --backend orbslam3
// replays the same rawlog through ORB-SLAM3 instead: --mode vw hands it the wheel readings, --mode vo
// does not (upstream's behaviour), for side-by-side runs; its keyframes go to the segmenter
// (--segmenter), whose labels reach its tracking's adaptive kernel (patch 0005): with --mode vo
// only when --segmenter is given, and then in 6-DoF (the paper's Table I, TUM RGB-D). It is
// fed at the recorded pace unless --realtime says otherwise, as ORB-SLAM3's own examples feed it:
// its local mapping skips a keyframe's local map while tracking outruns it (mono fed flat out
// solved 7 to 15 in 90 s against 69 to 127 as recorded, and about one run in five drifted).
// Bad records (odometry going backwards or NaN, an image of the wrong size or missing) are
// skipped with a line on stderr; a truncated or corrupt rawlog stops the replay there: what was
// estimated so far is written, and the exit status is 1. The settings, --gt, the rawlog's gz
// stream (its CRC), the sensors it holds and the output paths are checked before the replay
// starts; SIGINT, SIGTERM or SIGHUP stop it at the frame it is on, with what it has written (exit
// 130, 143, 129). Files are written whole or not at all (support/output.h).
#include <glog/logging.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <variant>

#include "rvwo/estimator/estimator.h"
#include "support/command_line.h"
#include "support/interrupt.h"
#include "support/output.h"
#ifdef RVWO_WITH_ORBSLAM3
#include "replay/orbslam3_backend.h"
#endif
#include "replay/input.h"
#include "replay/record_checks.h"
#include "replay/request.h"
#include "rvwo/semantics/onnx_segmenter.h"
#include "rvwo/semantics/shipped_model.h"
#include "support/plot.h"
#include "support/trajectory.h"

namespace {

namespace fs = std::filesystem;
using rvwo::apps::parseKernel;
using rvwo::apps::parseMode;
using rvwo::apps::ReplayArgs;
using rvwo::apps::ReplayRequest;
using rvwo::estimator::FrameInput;

double peakMemoryMb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0;
}

// Seconds of CPU this process used so far, all threads, user and system.
double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto sec = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return sec(u.ru_utime) + sec(u.ru_stime);
}

rvwo::apps::Trajectory toTrajectory(const std::vector<rvwo::estimator::PoseEstimate>& poses) {
  rvwo::apps::Trajectory out;
  for (const auto& p : poses) out.push_back({p.timestamp, p.T_w_b.isometry3()});
  return out;
}

// --realtime: a record of time t goes in no sooner than (t - t_ref) / x after t_ref's. A time that
// is not after the last paced one (a bad record, skipped further on) does not move the pace, and a
// gap of over kMaxGap (a recording paused, or a corrupt time) is not waited for.
class Pacer {
 public:
  Pacer(double speedup, std::chrono::steady_clock::time_point start) : speedup_(speedup), wall_(start) {}
  void wait(double t) {
    constexpr double kMaxGap = 1.0;  // s of data
    if (!(speedup_ > 0) || !std::isfinite(t)) return;
    if (std::isnan(ref_) || t - last_ > kMaxGap) {
      ref_ = last_ = t;
      wall_ = std::chrono::steady_clock::now();
      return;
    }
    if (!(t > last_)) return;
    last_ = t;
    std::this_thread::sleep_until(wall_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                              std::chrono::duration<double>((t - ref_) / speedup_)));
  }

 private:
  double speedup_, ref_ = NAN, last_ = NAN;
  std::chrono::steady_clock::time_point wall_;
};

// rvwo-replay: the command line read (configure), the rawlog fed to a backend (replay), the
// trajectory and the report written (report), the plot drawn (plot).
class ReplayApp {
 public:
  int run(int argc, char** argv) {
    ReplayArgs args;
    if (const auto status = rvwo::apps::parseCommandLine(args.cmd, argc, argv)) return *status;
    req_.emplace(args);
    rvwo::apps::installInterruptHandlers();  // a signal from here on stops the replay before or at its frame
    FLAGS_minloglevel = 2;
    configure();
    checkPaths();
    checkStream();
    surveyRawlog();
    makeSegmenter();
    makeBackend();
    replay();
    finish();
    if (const int signal = rvwo::apps::interruptSignal(); signal && frames_ == 0) {
      std::fprintf(stderr, "rvwo-replay: interrupted (%s) before the first frame: nothing written\n",
                   rvwo::apps::signalName(signal).c_str());
      return rvwo::apps::interruptedStatus(signal);
    }
    checkWhatWasRead();
    rvwo::apps::writeTum(req().out, est_);
    report();
    plot();
    if (const int signal = rvwo::apps::interruptSignal()) {
      std::fprintf(stderr, "rvwo-replay: interrupted (%s) at t = %.2f s: the %zu frames before it are written to %s\n",
                   rvwo::apps::signalName(signal).c_str(), last_t_ - first_t_, rep_.frames, req().out.c_str());
      return rvwo::apps::interruptedStatus(signal);
    }
    if (!read_error_.empty()) {
      std::fprintf(stderr, "rvwo-replay: error: %s (the %zu frames before it are written to %s)\n", read_error_.c_str(),
                   rep_.frames, req().out.c_str());
      return 1;
    }
    return checkLabels();
  }

 private:
  const ReplayRequest& req() const { return *req_; }
  bool vw() const { return opt_.mode == rvwo::estimator::Mode::kVw; }

  // Settings and options; a combination that cannot run is refused here, before any work.
  void configure() {
    settings_ = rvwo::Settings::load(req().settings);
    const rvwo::Settings& settings = *settings_;
    rig_ = rvwo::estimator::readRig(settings);
    opt_.mode = parseMode(req().mode);
    parseKernel(req().kernel, &opt_);
    opt_.semantics = !req().no_semantics;
    opt_.deterministic = req().deterministic;
    realtime_ = req().realtime;
    if (req().realtime_set && !(realtime_ >= 0 && std::isfinite(realtime_)))
      throw std::invalid_argument("--realtime must be a speed-up above 0 (1: as recorded) or 0 (as fast as it goes)");
    if (realtime_ > 0 && opt_.deterministic)
      throw std::invalid_argument(
          "--realtime paces the threads; --deterministic has none (its output does not "
          "depend on time): give one of the two");
    opt_ = rvwo::estimator::readEstimatorOptions(settings, opt_);
    ticks_per_rev_ = settings.number("Odometry.TicksPerRevolution").value_or(0);
    odometry_input_ = settings.text("Odometry.Input").value_or(ticks_per_rev_ > 0 ? "encoders" : "pose");
    if (odometry_input_ != "encoders" && odometry_input_ != "velocities" && odometry_input_ != "pose")
      throw std::invalid_argument(settings.path() +
                                  ": Odometry.Input must be \"encoders\", \"velocities\" or \"pose\"");
    if (odometry_input_ == "encoders" && !(ticks_per_rev_ > 0))
      throw std::invalid_argument(settings.path() + ": missing key Odometry.TicksPerRevolution (for encoders)");
    // Ticks and speeds become distances through the wheels' size: a default would scale every metre.
    if (odometry_input_ != "pose" && opt_.mode != rvwo::estimator::Mode::kVo) {
      for (const char* key : {"Odometry.WheelRadiusLeft", "Odometry.WheelRadiusRight", "Odometry.Track"}) {
        if (!settings.number(key))
          throw std::invalid_argument(settings.path() + ": missing key " + key + " (m: Odometry.Input " +
                                      odometry_input_ + " becomes distance through the wheels' size)");
      }
    }
    if (rig_.sensor == rvwo::estimator::Sensor::kRgbd) rig_.depth_factor = 1.0;  // the reader gives metres
    limits_ = rvwo::apps::readOdometryLimits(settings);
    max_gap_ = settings.number("Rawlog.MaxGap").value_or(max_gap_);
    if (!(max_gap_ > 0) || !std::isfinite(max_gap_))
      throw std::invalid_argument(settings.path() + ": Rawlog.MaxGap must be > 0 s");
#ifdef RVWO_WITH_ORBSLAM3
    if (req().backend == "orbslam3") {
      use_orbslam3_ = true;
      if (opt_.mode == rvwo::estimator::Mode::kWheel)
        throw std::invalid_argument("--backend orbslam3 takes --mode vw or vo (wheel: --backend rvwo)");
      if (req().vocabulary.empty())
        throw std::invalid_argument("--backend orbslam3 needs --vocabulary (rvwo-orbslam3-vocab makes one)");
      if (opt_.kernel == rvwo::estimator::KernelChoice::kFixed)
        throw std::invalid_argument("--backend orbslam3 takes --kernel adaptive or huber");
      if (opt_.deterministic)
        throw std::invalid_argument("--deterministic is RVWO's estimator's; ORB-SLAM3 runs threads of its own");
      if (!req().realtime_set) realtime_ = 1.0;  // as ORB-SLAM3's examples feed it (header)
    } else if (req().backend != "rvwo") {
      throw std::invalid_argument("--backend must be rvwo or orbslam3, not '" + req().backend + "'");
    }
#endif
  }

  // The outputs (--out, the plot) are none of the inputs and can be written; --gt is read now.
  void checkPaths() {
    plot_path_ = req().plot.empty() ? fs::path(req().out).replace_extension(".png").string() : req().plot;
    const std::string model = req().segmenter.rfind("onnx:", 0) == 0 ? req().segmenter.substr(5) : "";
    rvwo::apps::checkOutputs(
        {{"--out", req().out}, {req().plot.empty() ? "--plot (from --out)" : "--plot", plot_path_}},
        {{"--settings", req().settings},
         {"--rawlog", req().rawlog},
         {"--gt", req().gt},
         {"--segmenter", model},
         {"--vocabulary", req().vocabulary}});
    if (fs::weakly_canonical(req().out) == fs::weakly_canonical(plot_path_))
      throw std::invalid_argument("--plot " + plot_path_ + " is the --out file: give the plot another path");
    if (!req().gt.empty()) {
      gt_ = rvwo::apps::readTum(req().gt);
      alignment_ = rvwo::apps::parseAlignment(req().align);
    }
  }

  // The sensors the replay needs are in the rawlog (read until they have been seen); else one line
  // saying what the file has and which setting names the label.
  void surveyRawlog() {
    camera_label_ = settings_->text("Rawlog.CameraLabel")
                        .value_or(rig_.sensor == rvwo::estimator::Sensor::kRgbd ? "RGBD" : "CAMERA");
    odometry_label_ = settings_->text("Rawlog.OdometryLabel").value_or("ODOMETRY");
    labels_label_ = settings_->text("Rawlog.LabelsLabel").value_or("LABELS");
    const bool wheels = opt_.mode != rvwo::estimator::Mode::kVo;
    std::vector<std::string> needed{camera_label_};
    if (wheels) needed.push_back(odometry_label_);
    const rvwo::apps::RawlogSurvey survey = rvwo::apps::surveyRawlog(req().rawlog, needed);
    if (!survey.whole) return;  // all seen, or damaged before: the replay reports it where it comes
    const std::string& rawlog = req().rawlog;
    if (survey.records == 0) throw std::runtime_error(rawlog + ": no records (an empty rawlog)");
    // A label the settings do not name: the file's only sensor of the class asked for (MRPT's own
    // RGB-D grabbers write OPENNI2, ...), said on stdout.
    const char* camera_class = rig_.sensor == rvwo::estimator::Sensor::kRgbd     ? "CObservation3DRangeScan"
                               : rig_.sensor == rvwo::estimator::Sensor::kStereo ? "CObservationStereoImages"
                                                                                 : "CObservationImage";
    adoptOnlyLabel(survey, "Rawlog.CameraLabel", camera_class, &camera_label_);
    if (wheels) adoptOnlyLabel(survey, "Rawlog.OdometryLabel", "CObservationOdometry", &odometry_label_);
    if (!survey.has(camera_label_))
      throw std::runtime_error(rawlog + ": no camera frames (sensor label '" + camera_label_ + "'; the file has " +
                               survey.describe() + "): set Rawlog.CameraLabel in " + req().settings);
    if (wheels && !survey.has(odometry_label_))
      throw std::runtime_error(rawlog + ": no odometry (sensor label '" + odometry_label_ + "'; the file has " +
                               survey.describe() + "): set Rawlog.OdometryLabel in " + req().settings +
                               ", or run --mode vo");
  }

  // When the file has no sensor `*label` and the settings do not name one (`key`): its only sensor
  // of `type`, if it has exactly one.
  void adoptOnlyLabel(const rvwo::apps::RawlogSurvey& survey, const char* key, const char* type, std::string* label) {
    if (survey.has(*label) || settings_->text(key)) return;
    const rvwo::apps::RawlogSurvey::Sensor* only = nullptr;
    for (const auto& s : survey.sensors) {
      if (s.type != type) continue;
      if (only) return;  // two or more: the settings must say which
      only = &s;
    }
    if (!only) return;
    std::printf("rvwo-replay: %s: sensor label '%s' (the file's only %s; %s is '%s' by default)\n",
                req().rawlog.c_str(), only->label.c_str(), type, key, label->c_str());
    *label = only->label;
  }

  // The gz stream whole before any record is used: a damaged one is refused (its CRC covers the
  // whole stream, so no record of it can be trusted); one cut short replays up to the cut.
  void checkStream() {
    stream_ = rvwo::apps::checkRawlogStream(req().rawlog);
    if (stream_.result == rvwo::apps::StreamCheck::Result::kDamaged)
      throw std::runtime_error(req().rawlog + ": damaged (zlib: " + stream_.error +
                               "): no record of it can be trusted; nothing replayed (copy it again from its source)");
  }

  void makeSegmenter() {
    const std::string& seg = req().segmenter;
    if (!req().labels_out.empty() && (!opt_.semantics || seg == "none"))
      throw std::invalid_argument(
          "--labels-out writes a segmenter's labels: it takes no --segmenter none or "
          "--no-semantics");
    if (!opt_.semantics) {
      seg_name_ = "off (--no-semantics)";
      return;
    }
    if (seg == "none") return;
    if (seg == "auto" || seg == "rawlog") {
      rawlog_labels_ = std::make_shared<rvwo::apps::RawlogLabels>(opt_.priors.classes());
      segmenter_ = rawlog_labels_;
      seg_name_ = "label images from the rawlog";
    } else if (seg == "onnx" || seg.rfind("onnx:", 0) == 0) {
      rvwo::OnnxSegmenterOptions o;
      o.model_path = seg == "onnx" ? shippedModel() : seg.substr(5);
      o.class_names = opt_.priors.classes();
      segmenter_ = std::make_shared<rvwo::OnnxSegmenter>(o);
      network_ = true;
      seg_name_ = std::string(seg == "onnx" ? "the shipped network " : "ONNX model ") + o.model_path;
    } else {
      throw std::invalid_argument("--segmenter must be rawlog, onnx, onnx:<file> or none, not '" + seg + "'");
    }
    if (!req().labels_out.empty()) {
      label_writer_ = std::make_shared<rvwo::apps::LabelWriter>(segmenter_, req().labels_out);
      segmenter_ = label_writer_;
    }
  }

  // The network RVWO ships, which speaks VOC's classes: the settings' label set must be that one.
  std::string shippedModel() const {
    if (opt_.priors.name() != rvwo::kShippedModelLabelSet)
      throw std::invalid_argument("--segmenter onnx: the shipped network speaks " +
                                  std::string(rvwo::kShippedModelLabelSet) + ", but " + req().settings +
                                  " sets Semantics.LabelSet to " + opt_.priors.name() +
                                  ": give that label set's network as onnx:<file>");
    return rvwo::shippedModelPath();
  }

  // ORB-SLAM3's segmenter: the replay's with the wheels; without, only one --segmenter names (the
  // default leaves ORB-SLAM3 as upstream, for side-by-side runs).
  std::shared_ptr<rvwo::Segmenter> orbslam3Segmenter() const {
    return vw() || req().segmenter != "auto" ? segmenter_ : nullptr;
  }

  void makeBackend() {
#ifdef RVWO_WITH_ORBSLAM3
    if (use_orbslam3_)
      orbslam3_ = std::make_unique<rvwo::apps::OrbSlam3Backend>(rig_, opt_, vw(), *settings_, req().vocabulary,
                                                                req().out, orbslam3Segmenter());
#endif
    if (!use_orbslam3_) {
      estimator_ = std::make_unique<rvwo::estimator::Estimator>(rig_, opt_, segmenter_);
      estimator_->setFrameCallback([this](const rvwo::estimator::PoseEstimate& p) { progress(p); });
    }
  }

  // The progress line: every 0.5 s on a terminal, every 10 s otherwise.
  void progress(const rvwo::estimator::PoseEstimate& p) {
    ++frames_;
    if (req().quiet) return;
    const double el = elapsed();
    if (el - last_progress_ < (tty_ ? 0.5 : 10.0)) return;
    last_progress_ = el;
    std::fprintf(stderr, "%srvwo-replay: t = %.1f s, %zu frames, %.1f frames/s (%.1fx real time), pose %s%s",
                 tty_ ? "\r" : "", p.timestamp - first_t_, frames_, frames_ / el, (p.timestamp - first_t_) / el,
                 p.visual ? "visual     " : (use_orbslam3_ ? "lost       " : "wheels only"), tty_ ? "  " : "\n");
  }
#ifdef RVWO_WITH_ORBSLAM3
  std::function<void(double, bool)> orbslam3Progress() {
    return [this](double t, bool tracked) {
      rvwo::estimator::PoseEstimate p;
      p.timestamp = t;
      p.visual = tracked;
      progress(p);
    };
  }
#endif
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count(); }

  // A bad record: the first ten named on stderr, all counted.
  void skip(const std::string& why) {
    if (first_skip_.empty()) first_skip_ = why;
    ++skipped_;
    if (skipped_ <= 10) std::fprintf(stderr, "%srvwo-replay: skipped %s\n", tty_ ? "\n" : "", why.c_str());
    if (skipped_ == 10) std::fprintf(stderr, "rvwo-replay: (further skips are counted, not shown)\n");
  }

  // The held frame to the backend. A frame is held until the next record, so that its label image
  // (written after it) is there when the estimator makes it a keyframe.
  void flush() {
    if (!held_) return;
    try {
#ifdef RVWO_WITH_ORBSLAM3
      if (orbslam3_) orbslam3_->addFrame(*held_, vw(), orbslam3Progress());
#endif
      if (estimator_) estimator_->addFrame(*held_);
    } catch (const std::invalid_argument& ex) {
      skip("frame at t = " + std::to_string(held_->timestamp) + ": " + ex.what());
    }
    held_.reset();
  }

  // One odometry record, as the settings' Odometry.Input says it is to be read, if the gate
  // finds it one a wheeled robot can give (else invalid_argument saying why).
  void addOdometry(const rvwo::apps::OdometryRecord& o) {
    const auto pass = [](const std::string& why) {
      if (!why.empty()) throw std::invalid_argument(why);
    };
    if (odometry_input_ == "encoders") {
      if (!o.has_encoders) throw std::invalid_argument("no encoder ticks (Odometry.Input is encoders)");
      const double k = 2 * M_PI / ticks_per_rev_;
      if (std::isnan(q_left0_)) {
        q_left0_ = o.ticks_left;
        q_right0_ = o.ticks_right;
      }
      const double ql_read = (o.ticks_left - q_left0_) * k, qr_read = (o.ticks_right - q_right0_) * k;
      pass(gate_->wheelAngles(o.t, ql_read, qr_read));
      const Eigen::Vector2d q = gate_->asTaken(ql_read, qr_read);  // after a counter reset: from the angle before
      const double ql = q.x(), qr = q.y();
#ifdef RVWO_WITH_ORBSLAM3
      if (orbslam3_) orbslam3_->addWheels(rvwo::orbslam3::WheelReading::angles(o.t, ql, qr), orbslam3Progress());
#endif
      if (estimator_) estimator_->addWheelAngles(o.t, ql, qr);
    } else if (odometry_input_ == "velocities") {
      if (!o.has_velocities) throw std::invalid_argument("no velocities (Odometry.Input is velocities)");
      const double b = opt_.drive.track;
      const double wl = (o.v - o.omega * b / 2) / opt_.drive.radius_left,
                   wr = (o.v + o.omega * b / 2) / opt_.drive.radius_right;
      pass(gate_->wheelSpeeds(o.t, wl, wr));
#ifdef RVWO_WITH_ORBSLAM3
      if (orbslam3_) orbslam3_->addWheels(rvwo::orbslam3::WheelReading::speeds(o.t, wl, wr), orbslam3Progress());
#endif
      if (estimator_) estimator_->addWheelSpeeds(o.t, wl, wr);
    } else {
      pass(gate_->pose(o.t, o.pose));
      const rvwo::SE2 T_odom_o = gate_->asTaken(o.pose);
#ifdef RVWO_WITH_ORBSLAM3
      if (orbslam3_) {
        orbslam3_->addWheels(rvwo::orbslam3::WheelReading::pose(o.t, T_odom_o.translation().x(),
                                                                T_odom_o.translation().y(), T_odom_o.angle()),
                             orbslam3Progress());
      }
#endif
      if (estimator_) estimator_->addOdometryPose(o.t, T_odom_o);
    }
    if (!gate_->restart().empty()) {
      ++odometry_restarts_;
      std::fprintf(stderr, "%srvwo-replay: %s\n", tty_ ? "\n" : "", gate_->restart().c_str());
    }
  }

  // Every record of the rawlog, in order, to the backend, past the record clock.
  void replay() {
    rvwo::apps::Prefetcher reader(req().rawlog, camera_label_, odometry_label_, rawlog_labels_ ? labels_label_ : "",
                                  opt_.mode != rvwo::estimator::Mode::kWheel, network_);
    tty_ = isatty(fileno(stderr)) && !req().quiet;
    t_start_ = std::chrono::steady_clock::now();
    Pacer pacer(realtime_, t_start_);
    rvwo::apps::RecordClock clock(max_gap_);
    gate_.emplace(limits_, opt_.drive);
    while (auto e = reader.next()) {
      if (rvwo::apps::interruptSignal()) break;  // stop at the frame it is on
      for (rvwo::apps::ReplayEvent& event : clock.admit(std::move(*e))) handle(event, pacer);
    }
    if (!rvwo::apps::interruptSignal()) {
      for (rvwo::apps::ReplayEvent& event : clock.finish()) handle(event, pacer);
    }
    flush();
#ifdef RVWO_WITH_ORBSLAM3
    if (orbslam3_) orbslam3_->flush(orbslam3Progress());
#endif
    read_error_ = reader.error();
  }

  // One record to the backend (a frame is held until the next record: flush).
  void handle(rvwo::apps::ReplayEvent& e, Pacer& pacer) {
    if (auto* l = std::get_if<rvwo::apps::LabelsRecord>(&e)) {
      if (rawlog_labels_) rawlog_labels_->add(l->t, l->image);
      if (held_ && std::fabs(held_->timestamp - l->t) < 1e-6) flush();
      return;
    }
    flush();
    if (auto* f = std::get_if<FrameInput>(&e)) {
      pacer.wait(f->timestamp);
      if (std::isnan(first_t_)) first_t_ = f->timestamp;
      last_t_ = f->timestamp;
      held_ = std::move(*f);
    } else if (auto* o = std::get_if<rvwo::apps::OdometryRecord>(&e)) {
      ++odometry_count_;
      pacer.wait(o->t);
      if (opt_.mode == rvwo::estimator::Mode::kVo) return;
      try {
        addOdometry(*o);
        ++odometry_used_;
      } catch (const std::invalid_argument& ex) {
        skip("odometry at t = " + std::to_string(o->t) + ": " + ex.what());
      }
    } else if (auto* s = std::get_if<rvwo::apps::SkippedRecord>(&e)) {
      skip(s->why);
    }
  }

  // The backend's trajectory and report, and which poses followed the wheels alone.
  void finish() {
    if (estimator_) {
      estimator_->finish();
      const auto poses = estimator_->trajectory();
      est_ = toTrajectory(poses);
      for (const auto& p : poses) on_wheels_.push_back(!p.visual && opt_.mode != rvwo::estimator::Mode::kWheel);
      rep_ = estimator_->report();
    }
#ifdef RVWO_WITH_ORBSLAM3
    if (orbslam3_) {
      est_ = orbslam3_->finish(&rep_);
      for (const auto& p : est_) {
        on_wheels_.push_back(std::any_of(rep_.wheel_only_intervals.begin(), rep_.wheel_only_intervals.end(),
                                         [&](const auto& i) { return i.first <= p.t && p.t <= i.second; }));
      }
    }
#endif
    wall_ = elapsed();
    if (tty_) std::fprintf(stderr, "\n");
  }

  // No trajectory to write: one line saying what the rawlog lacked.
  void checkWhatWasRead() const {
    const std::string& rawlog = req().rawlog;
    if (frames_ == 0 && !read_error_.empty()) throw std::runtime_error(read_error_);  // (not a rawlog, or cut short)
    if (frames_ == 0 && skipped_ > 0)
      throw std::runtime_error(rawlog + ": no camera frame could be used (" + std::to_string(skipped_) +
                               " records skipped; the first: " + first_skip_ + ")");
    if (frames_ == 0)
      throw std::runtime_error(rawlog + ": no camera frames (sensor label '" + camera_label_ +
                               "'; Rawlog.CameraLabel names another)");
    if (opt_.mode != rvwo::estimator::Mode::kVo && odometry_count_ == 0)
      throw std::runtime_error(rawlog + ": no odometry (sensor label '" + odometry_label_ +
                               "'): --mode vo runs without it");
    if (opt_.mode != rvwo::estimator::Mode::kVo && odometry_used_ == 0)
      throw std::runtime_error(rawlog + ": none of the " + std::to_string(odometry_count_) +
                               " odometry records could be used (see the lines above): fix them, or run --mode vo");
    if (rawlog_labels_ && !rawlog_labels_->any() && req().segmenter == "rawlog")
      throw std::runtime_error(rawlog + ": no label images (sensor label '" + labels_label_ + "')");
    if (est_.empty()) throw std::runtime_error("ORB-SLAM3 kept no pose (its log: the --out file with .orbslam3.log)");
  }

  // The default segmenter on a rawlog without label images: none (each keyframe's "no label image").
  bool labelsAbsent() const { return rawlog_labels_ && !rawlog_labels_->any() && req().segmenter == "auto"; }

  // Labels asked for that never came are a run without semantics: an error once the outputs are
  // written (a run where only some failed says so in one line).
  int checkLabels() const {
    if (rep_.segmentation_failures == 0 || labelsAbsent()) return 0;
    if (rep_.segmented_keyframes == 0) {
      std::fprintf(stderr,
                   "rvwo-replay: error: no keyframe could use its labels (%zu failed; the first: %s): the run went "
                   "without semantics (its trajectory is written to %s)\n",
                   rep_.segmentation_failures, rep_.segmentation_error.c_str(), req().out.c_str());
      return 1;
    }
    std::fprintf(stderr, "rvwo-replay: warning: %zu of %zu keyframes could not use their labels (the first: %s)\n",
                 rep_.segmentation_failures, rep_.segmentation_failures + rep_.segmented_keyframes,
                 rep_.segmentation_error.c_str());
    return 0;
  }

  // "what: count (t0-t1 s, ...)", at most eight stretches.
  void stretches(const char* what, std::size_t count, const std::vector<std::pair<double, double>>& in) const {
    std::printf("  %s: %zu", what, count);
    for (std::size_t i = 0; i < in.size() && i < 8; ++i)
      std::printf("%s%.2f-%.2f s", i ? ", " : " (", in[i].first - first_t_, in[i].second - first_t_);
    if (in.size() > 8) std::printf(", ... %zu stretches", in.size());
    std::printf("%s\n", in.empty() ? "" : ")");
  }

  // The report on stdout: what ran, what it saw, what it decided, how fast.
  void report() const {
    const double seq_s = last_t_ - first_t_;
    const std::string& rawlog = req().rawlog;
    if (use_orbslam3_) {
      const bool labels = orbslam3Segmenter() != nullptr;
      std::printf("rvwo-replay: %s, ORB-SLAM3 (patched), %s\n", rawlog.c_str(),
                  vw()     ? "with the wheels"
                  : labels ? "without the wheels, RVWO's labels and kernel in its 6-DoF tracking"
                           : "without the wheels (upstream behaviour)");
      std::printf("  frames %zu over %.1f s, keyframes %zu, poses kept %zu, semantics %s, segmented keyframes %zu\n",
                  rep_.frames, seq_s, rep_.keyframes, est_.size(), labels || vw() ? seg_name_.c_str() : "none",
                  rep_.segmented_keyframes);
    } else {
      std::printf("rvwo-replay: %s, mode %s, kernel %s, semantics %s\n", rawlog.c_str(), req().mode.c_str(),
                  req().kernel.c_str(), labelsAbsent() ? "none (the rawlog has no label images)" : seg_name_.c_str());
      std::printf(
          "  frames %zu over %.1f s, keyframes %zu, map points made %zu (rejected by the kernel: %zu), segmented "
          "keyframes %zu\n",
          rep_.frames, seq_s, rep_.keyframes, rep_.map_points_created, rep_.map_points_rejected,
          rep_.segmented_keyframes);
    }
    if (rep_.segmentation_failures > 0 && !labelsAbsent())
      std::printf("  keyframes whose labels could not be used: %zu (they went unlabelled; the first: %s)\n",
                  rep_.segmentation_failures, rep_.segmentation_error.c_str());
    if (label_writer_)
      std::printf("  label images written: %zu, in %s\n", label_writer_->written(), label_writer_->folder().c_str());
    reportDecisions();
    using Check = rvwo::apps::StreamCheck::Result;
    std::printf("  rawlog check: %s, %.1f MB in %.2f s\n",
                stream_.result == Check::kIntact         ? "gz CRC intact"
                : stream_.result == Check::kUncompressed ? "none (uncompressed: damage cannot be detected)"
                                                         : "cut short (replayed up to the cut)",
                stream_.bytes / 1e6, stream_.seconds);
    if (skipped_ > 0) std::printf("  records skipped: %zu (see stderr)\n", skipped_);
    if (opt_.mode != rvwo::estimator::Mode::kVo && odometry_used_ < odometry_count_)
      std::printf("  odometry records used: %zu of %zu\n", odometry_used_, odometry_count_);
    if (odometry_restarts_ > 0)
      std::printf("  odometry restarts taken as a new origin: %zu (see stderr)\n", odometry_restarts_);
    // CPU as well as wall time: the wall time depends on what else the machine runs, the CPU says
    // how much of it a second of data takes (on two cores, 2x real time needs at most 1 s of CPU a
    // data second, and threads that keep both cores busy).
    const double cpu = cpuSeconds();
    std::printf("  speed: %.1f s of data in %.1f s: %.2fx real time, %.1f frames/s; ", seq_s, wall_, seq_s / wall_,
                rep_.frames / wall_);
    std::printf("CPU %.1f s (%.2f cores); peak memory %.0f MB\n", cpu, cpu / wall_, peakMemoryMb());
    if (!use_orbslam3_)
      std::printf("  map at the end: %zu keyframes and %zu points in memory, %zu keyframes retired (poses kept)\n",
                  rep_.map_keyframes, rep_.map_points, rep_.retired_keyframes);
    std::printf("  timings [ms]     mean     p50     p95     max   count\n");
    for (const auto& [stage, s] : rep_.timings) {
      std::printf("  %-14s %7.2f %7.2f %7.2f %7.1f %7zu\n", stage.c_str(), s.mean, s.p50, s.p95, s.max, s.count);
    }
    std::printf("  trajectory: %s\n", req().out.c_str());
  }

  // The report's lines on the wheels: frames on them alone, slips, the calibration learnt.
  void reportDecisions() const {
#ifdef RVWO_WITH_ORBSLAM3
    if (orbslam3_)
      stretches("frames ORB-SLAM3 did not track (lost, not initialised)", orbslam3_->lostFrames(), orbslam3_->lost());
#endif
    if (!use_orbslam3_ || vw()) stretches("frames on wheels only", rep_.wheel_only_frames, rep_.wheel_only_intervals);
    if (vw() && use_orbslam3_)
      std::printf("  frames where vision overruled the wheels (a slip): %zu\n", rep_.slip_frames);
    if (vw() && !use_orbslam3_) {
      std::printf(
          "  frames where vision overruled the wheels (a slip): %zu; wheel edges local BA found wrong: %zu; "
          "relocalised: %zu; placed by the landmarks the wheels explain: %zu\n",
          rep_.slip_frames, rep_.wheel_edge_outliers, rep_.relocalisations, rep_.wheel_gated);
    }
    if (vw() && opt_.calibrate) {
      const rvwo::WheelCalibration& c = rep_.wheel_calibration;
      std::printf("  wheel calibration (estimated): distance x%.4f, turn x%.4f, curvature %+.4f rad/m\n", 1 + c.x(),
                  1 + c.y(), c.z());
    }
#ifdef RVWO_WITH_ORBSLAM3
    // ORB-SLAM3 skips a local map while keyframes wait; fed faster than real time, few are solved.
    if (orbslam3_ && vw())
      std::printf("  local maps on SE(2): %zu, of which %zu refined the wheel calibration%s\n", orbslam3_->localMaps(),
                  orbslam3_->calibratedLocalMaps(),
                  realtime_ > 0 ? "" : " (frames fed as fast as tracking goes; --realtime 1: as recorded)");
#endif
  }

  // The ATE of a trajectory against the ground truth (frames paired by time), one report line;
  // the pairs to pairs_out unless null.
  rvwo::apps::AteResult reportAte(const rvwo::apps::Trajectory& gt, rvwo::apps::Alignment alignment,
                                  const std::string& what, const rvwo::apps::Trajectory& traj,
                                  std::vector<std::pair<std::size_t, std::size_t>>* pairs_out) const {
    auto pairs = rvwo::apps::associate(gt, traj, 0.01);
    if (pairs.size() < 3) throw std::runtime_error(req().gt + ": fewer than 3 poses match the frames' times");
    auto a = rvwo::apps::ate(gt, traj, pairs, alignment);
    const double path = rvwo::apps::pathLength(gt, pairs);
    std::printf("  %s: rmse %.4f m = %.3f %% of the %.1f m path; mean %.4f, max %.4f m\n", what.c_str(), a.stats.rmse,
                100 * a.stats.rmse / path, path, a.stats.mean, a.stats.max);
    if (pairs_out) *pairs_out = std::move(pairs);
    return a;
  }

  // The PNG: the trajectory from above (against the ground truth, aligned, when given) and the
  // error over time; with --gt, the ATE lines of the report first.
  void plot() const {
    std::vector<Eigen::Vector2d> est_xy, gt_xy, wheel_xy, err_t;
    if (!req().gt.empty()) {
      const rvwo::apps::Trajectory& gt = gt_;
      const rvwo::apps::Alignment alignment = alignment_;
      std::vector<std::pair<std::size_t, std::size_t>> pairs;
      const auto a = reportAte(gt, alignment, "ATE (" + req().align + ")", est_, &pairs);
      const auto step = rvwo::apps::rpe(gt, est_, pairs, 1, false);
#ifdef RVWO_WITH_ORBSLAM3
      // ORB-SLAM3 without the wheels loses frames (a blackout), and those of a map it started
      // afterwards and never merged are not in its saved trajectory (only its biggest map's are):
      // the ATE above says nothing of them. Over every frame, one without a pose at the last pose
      // kept, the figure is what its user had, comparable with a run that kept them all
      // (upstream, blackout: 2162 of 2698 frames kept, 0.0077 m over those, 0.87 m over all).
      if (orbslam3_ && est_.size() < orbslam3_->frameTimes().size()) {
        reportAte(gt, alignment, "ATE over every frame (one without a pose at the last pose kept)",
                  rvwo::apps::heldAtLastPose(est_, orbslam3_->frameTimes(), 1e-6), nullptr);
      }
#endif
      std::printf("  largest frame-to-frame error (RPE, 1 frame): %.4f m\n", step.stats.max);
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        gt_xy.push_back(a.ref[k].head<2>());
        est_xy.push_back(a.est_aligned[k].head<2>());
        if (on_wheels_[pairs[k].second]) wheel_xy.push_back(a.est_aligned[k].head<2>());
        err_t.emplace_back(a.t[k] - first_t_, a.errors[k]);
      }
    } else {
      for (std::size_t k = 0; k < est_.size(); ++k) {
        est_xy.push_back(est_[k].T.translation().head<2>());
        if (on_wheels_[k]) wheel_xy.push_back(est_xy.back());
      }
    }
    const std::string title =
        use_orbslam3_ ? "rvwo-replay: ORB-SLAM3, " + std::string(vw() ? "with" : "no") + " wheels (from above)"
                      : "rvwo-replay: " + req().mode + ", " + req().kernel + " (from above)";
    rvwo::apps::Plot traj_plot(title, "x [m]", "y [m]", true);
    if (!gt_xy.empty()) traj_plot.add(gt_xy, mrpt::img::TColor(0, 0, 0), "ground truth");
    traj_plot.add(est_xy, mrpt::img::TColor(0, 150, 60), "estimate" + std::string(gt_xy.empty() ? "" : " (aligned)"));
    if (!wheel_xy.empty()) traj_plot.add(wheel_xy, mrpt::img::TColor(230, 120, 0), "wheels only", 0);
    std::vector<const rvwo::apps::Plot*> panels{&traj_plot};
    std::unique_ptr<rvwo::apps::Plot> err_plot;
    if (!err_t.empty()) {
      err_plot = std::make_unique<rvwo::apps::Plot>("position error after alignment", "t [s]", "error [m]");
      err_plot->add(err_t, mrpt::img::TColor(200, 40, 40), "ATE");
      panels.push_back(err_plot.get());
    }
    rvwo::apps::savePanels(plot_path_, panels);
    std::printf("  plot: %s\n", plot_path_.c_str());
  }

  std::optional<ReplayRequest> req_;
  std::optional<rvwo::Settings> settings_;
  rvwo::estimator::Rig rig_;
  rvwo::estimator::EstimatorOptions opt_;
  double realtime_ = 0, ticks_per_rev_ = 0, max_gap_ = 1.0;  // max_gap_: s (Rawlog.MaxGap)
  rvwo::apps::OdometryLimits limits_;
  std::optional<rvwo::apps::OdometryGate> gate_;
  std::string odometry_input_, seg_name_ = "none", camera_label_, odometry_label_, labels_label_, plot_path_;
  rvwo::apps::Trajectory gt_;  // --gt, read before the replay
  rvwo::apps::StreamCheck stream_;
  rvwo::apps::Alignment alignment_ = rvwo::apps::Alignment::kSE3;
  bool use_orbslam3_ = false, tty_ = false;
  std::shared_ptr<rvwo::Segmenter> segmenter_;
  std::shared_ptr<rvwo::apps::LabelWriter> label_writer_;  // --labels-out
  bool network_ = false;  // a network segments the keyframes: it is given the images in colour
  std::shared_ptr<rvwo::apps::RawlogLabels> rawlog_labels_;
  std::unique_ptr<rvwo::estimator::Estimator> estimator_;
#ifdef RVWO_WITH_ORBSLAM3
  std::unique_ptr<rvwo::apps::OrbSlam3Backend> orbslam3_;
#endif
  // Replay state.
  std::chrono::steady_clock::time_point t_start_ = std::chrono::steady_clock::now();
  double first_t_ = NAN, last_t_ = NAN, last_progress_ = -1, wall_ = 0;
  double q_left0_ = NAN, q_right0_ = NAN;  // the first encoder ticks: wheel angles count from them
  std::size_t frames_ = 0, odometry_count_ = 0, odometry_used_ = 0, skipped_ = 0, odometry_restarts_ = 0;
  std::string first_skip_, read_error_;
  std::optional<FrameInput> held_;
  // What it produced.
  rvwo::estimator::Report rep_;
  rvwo::apps::Trajectory est_;
  std::vector<bool> on_wheels_;  // per pose of est_: it followed the wheels
};

}  // namespace

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-replay", [&] { return ReplayApp().run(argc, argv); });
}
