// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-replay's input: a rawlog's records, read and decoded ahead of the estimator in a thread of
// its own (Prefetcher), and the label images it carries served as a segmenter (RawlogLabels).
// Record conventions: docs/rawlog.md.
#pragma once

#include <mrpt/img/CImage.h>

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <variant>
#include <vector>

#include "rvwo/edges/se2.h"
#include "rvwo/estimator/estimator.h"
#include "rvwo/semantics/segmenter.h"
#include "support/rawlog.h"

namespace rvwo::apps {

// Label images that came in the rawlog (sensor LABELS), served by timestamp: the simulator's
// ground truth or a dataset's masks, through the same Segmenter interface as a network. Decoded
// only when a keyframe asks (one frame in ten or so: decoding every one cost a fifth of a replay's
// time).
class RawlogLabels final : public Segmenter {
 public:
  explicit RawlogLabels(std::vector<std::string> classes) : classes_(std::move(classes)) {}
  // The label image of time t (the last 3 s of them are kept: a keyframe asks at once).
  void add(double t, mrpt::img::CImage labels);
  bool any() const;
  Segmentation segment(const cv::Mat&, const FrameInfo& info) override;
  const std::vector<std::string>& classNames() const override { return classes_; }

 private:
  std::vector<std::string> classes_;
  mutable std::mutex mutex_;
  std::map<double, mrpt::img::CImage> labels_;
};

// Passes frames to another segmenter and writes each label image it returns to a folder, as
// <timestamp>.png of class ids (8-bit; 16-bit beyond 255 classes): what the keyframes were labelled
// with (--labels-out). Each file appears whole (support/output.h).
class LabelWriter final : public Segmenter {
 public:
  // Throws std::invalid_argument when the folder cannot be made.
  LabelWriter(std::shared_ptr<Segmenter> inner, std::string folder);
  Segmentation segment(const cv::Mat& image, const FrameInfo& info) override;
  const std::vector<std::string>& classNames() const override { return inner_->classNames(); }
  std::size_t written() const;
  const std::string& folder() const { return folder_; }

 private:
  std::shared_ptr<Segmenter> inner_;
  std::string folder_;
  mutable std::mutex mutex_;
  std::size_t written_ = 0;
};

// What the reader thread hands over, in rawlog order.
struct OdometryRecord {
  double t;
  SE2 pose;
  bool has_encoders, has_velocities;
  double ticks_left, ticks_right, v, omega;
};
struct LabelsRecord {
  double t;
  mrpt::img::CImage image;  // not decoded yet (a path, when stored outside the rawlog)
};
struct SkippedRecord {
  std::string why;
};
using ReplayEvent = std::variant<estimator::FrameInput, OdometryRecord, LabelsRecord, SkippedRecord>;

// What a rawlog holds, read before the replay: its records until every sensor label asked for has
// been seen (the whole file when one is missing), by label and class.
struct RawlogSurvey {
  struct Sensor {
    std::string label, type;
    std::size_t count = 0;
  };
  std::vector<Sensor> sensors;  // in order of first appearance
  std::size_t records = 0;      // read
  bool whole = false;           // the whole file was read without an error
  bool has(const std::string& label) const;
  // "CAMERA: CObservationStereoImages x 90, ODOMETRY: CObservationOdometry x 300" (or "nothing").
  std::string describe() const;
};
// Stops early at a damaged record (the replay reports it where it comes).
RawlogSurvey surveyRawlog(const std::string& path, const std::vector<std::string>& labels);

// Reads and decodes ahead of the estimator in a thread of its own (bounded: a few frames).
class Prefetcher {
 public:
  // Records of camera_label, odometry_label and labels_label ("": none) become events; the
  // camera's images are decoded only when want_images, the (left) one in colour when colour (a
  // network segments it; features are found on grey either way).
  Prefetcher(const std::string& path, std::string camera_label, std::string odometry_label, std::string labels_label,
             bool want_images, bool colour = false);
  ~Prefetcher();
  // The next event, or nullopt at the end (error() then says whether the file ended badly).
  std::optional<ReplayEvent> next();
  std::string error() const;

 private:
  void push(ReplayEvent e);
  void run();
  // The event of one record (throws on a record of a known sensor that cannot be used).
  std::optional<ReplayEvent> eventOf(const mrpt::obs::CObservation::Ptr& obs, double t) const;
  estimator::FrameInput frameOf(const mrpt::obs::CObservation::Ptr& obs, double t) const;

  RawlogReader reader_;
  const std::string camera_, odometry_, labels_;
  const bool want_images_;
  const int left_flags_;  // cv::imread's flags for the (left) image
  std::thread thread_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<ReplayEvent> queue_;
  bool stop_ = false, done_ = false;
  std::string error_;
};

}  // namespace rvwo::apps
