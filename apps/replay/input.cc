// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "replay/input.h"

#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "support/output.h"

namespace rvwo::apps {

void RawlogLabels::add(double t, mrpt::img::CImage labels) {
  std::lock_guard<std::mutex> lock(mutex_);
  labels_[t] = std::move(labels);
  while (labels_.size() > 90) labels_.erase(labels_.begin());  // 3 s at 30 Hz: a keyframe asks at once
}

bool RawlogLabels::any() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !labels_.empty();
}

Segmentation RawlogLabels::segment(const cv::Mat&, const FrameInfo& info) {
  std::unique_lock<std::mutex> lock(mutex_);
  auto it = labels_.lower_bound(info.timestamp - 1e-4);
  if (it == labels_.end() || std::fabs(it->first - info.timestamp) > 1e-4)
    throw std::runtime_error("no label image at t = " + std::to_string(info.timestamp));
  const mrpt::img::CImage image = it->second;
  lock.unlock();
  Segmentation s;
  loadImage(image, cv::IMREAD_UNCHANGED).convertTo(s.labels, CV_32S);
  return s;
}

LabelWriter::LabelWriter(std::shared_ptr<Segmenter> inner, std::string folder)
    : inner_(std::move(inner)), folder_(std::move(folder)) {
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  if (ec || !std::filesystem::is_directory(folder_))
    throw std::invalid_argument("--labels-out " + folder_ + ": not a folder that can be made (" +
                                (ec ? ec.message() : std::string("a file of that name exists")) + ")");
}

Segmentation LabelWriter::segment(const cv::Mat& image, const FrameInfo& info) {
  Segmentation s = inner_->segment(image, info);
  cv::Mat ids;
  s.labels.convertTo(ids, inner_->classNames().size() > 256 ? CV_16U : CV_8U);
  char name[64];
  std::snprintf(name, sizeof name, "%.6f", info.timestamp);
  const std::string file = (std::filesystem::path(folder_) / (std::string(name) + ".png")).string();
  writeWhole(file, [&](const std::string& tmp) {
    if (!cv::imwrite(tmp, ids)) throw std::runtime_error("--labels-out: cannot write " + file);
  });
  std::lock_guard<std::mutex> lock(mutex_);
  ++written_;
  return s;
}

std::size_t LabelWriter::written() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return written_;
}

bool RawlogSurvey::has(const std::string& label) const {
  for (const Sensor& s : sensors) {
    if (s.label == label) return true;
  }
  return false;
}

std::string RawlogSurvey::describe() const {
  std::string out;
  for (const Sensor& s : sensors)
    out += (out.empty() ? "" : ", ") + (s.label.empty() ? "(no label)" : s.label) + ": " + s.type + " x " +
           std::to_string(s.count);
  return out.empty() ? "nothing" : out;
}

RawlogSurvey surveyRawlog(const std::string& path, const std::vector<std::string>& labels) {
  RawlogSurvey survey;
  RawlogReader reader(path);
  const auto allSeen = [&] {
    for (const std::string& l : labels) {
      if (!survey.has(l)) return false;
    }
    return true;
  };
  try {
    while (!allSeen()) {
      const std::optional<mrpt::obs::CObservation::Ptr> obs = reader.next();
      if (!obs) {
        survey.whole = true;
        break;
      }
      ++survey.records;
      std::string type = (*obs)->GetRuntimeClass()->className;
      if (type.rfind("mrpt::obs::", 0) == 0) type = type.substr(11);
      auto it = std::find_if(survey.sensors.begin(), survey.sensors.end(), [&](const RawlogSurvey::Sensor& s) {
        return s.label == (*obs)->sensorLabel && s.type == type;
      });
      if (it == survey.sensors.end()) it = survey.sensors.insert(it, {(*obs)->sensorLabel, type, 0});
      ++it->count;
    }
  } catch (const RawlogError&) {
  }
  return survey;
}

Prefetcher::Prefetcher(const std::string& path, std::string camera_label, std::string odometry_label,
                       std::string labels_label, bool want_images, bool colour)
    : reader_(path),
      camera_(std::move(camera_label)),
      odometry_(std::move(odometry_label)),
      labels_(std::move(labels_label)),
      want_images_(want_images),
      left_flags_(colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE) {
  thread_ = std::thread([this] { run(); });
}

Prefetcher::~Prefetcher() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

std::optional<ReplayEvent> Prefetcher::next() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [&] { return !queue_.empty() || done_; });
  if (queue_.empty()) return std::nullopt;
  ReplayEvent e = std::move(queue_.front());
  queue_.pop_front();
  cv_.notify_all();
  return e;
}

std::string Prefetcher::error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return error_;
}

void Prefetcher::push(ReplayEvent e) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [&] { return queue_.size() < 64 || stop_; });
  queue_.push_back(std::move(e));
  cv_.notify_all();
}

void Prefetcher::run() {
  try {
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stop_) break;
      }
      auto o = reader_.next();
      if (!o) break;
      const double t = mrpt::Clock::toDouble((*o)->timestamp);
      const std::string where = "record " + std::to_string(reader_.count() - 1) + " (t = " + std::to_string(t) + ")";
      try {
        if (auto e = eventOf(*o, t)) push(std::move(*e));
      } catch (const std::exception& e) {
        push(SkippedRecord{where + ": " + e.what()});
      }
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = e.what();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  done_ = true;
  cv_.notify_all();
}

std::optional<ReplayEvent> Prefetcher::eventOf(const mrpt::obs::CObservation::Ptr& obs, double t) const {
  if (obs->sensorLabel == odometry_) {
    auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(obs);
    if (!od) throw std::runtime_error("sensor " + odometry_ + " is not a CObservationOdometry");
    return OdometryRecord{t,
                          SE2(od->odometry.x(), od->odometry.y(), od->odometry.phi()),
                          od->hasEncodersInfo,
                          od->hasVelocities,
                          double(od->encoderLeftTicks),
                          double(od->encoderRightTicks),
                          od->velocityLocal.vx,
                          od->velocityLocal.omega};
  }
  if (obs->sensorLabel == camera_) return frameOf(obs, t);
  if (obs->sensorLabel == labels_) {
    auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs);
    if (!im) throw std::runtime_error("sensor " + labels_ + " is not a CObservationImage");
    requireImageFile(im->image);
    return LabelsRecord{t, im->image};
  }
  return std::nullopt;
}

estimator::FrameInput Prefetcher::frameOf(const mrpt::obs::CObservation::Ptr& obs, double t) const {
  estimator::FrameInput f;
  f.timestamp = t;
  if (!want_images_) return f;
  if (auto st = std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(obs)) {
    f.image = loadImage(st->imageLeft, left_flags_);
    if (st->hasImageRight) f.right = loadImage(st->imageRight, cv::IMREAD_GRAYSCALE);
  } else if (auto rgbd = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(obs)) {
    if (rgbd->hasIntensityImage) f.image = loadImage(rgbd->intensityImage, left_flags_);
    if (rgbd->hasRangeImage) {
      rgbd->load();  // external range images
      cv::Mat depth(rgbd->rangeImage.rows(), rgbd->rangeImage.cols(), CV_32F);
      for (int r = 0; r < depth.rows; ++r) {
        for (int c = 0; c < depth.cols; ++c) depth.at<float>(r, c) = rgbd->rangeImage(r, c) * rgbd->rangeUnits;
      }
      f.depth = depth;  // metres: the estimator's depth factor is set to 1 for rawlogs
    }
  } else if (auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs)) {
    f.image = loadImage(im->image, left_flags_);
  } else {
    throw std::runtime_error("sensor " + camera_ + " is not a camera observation");
  }
  return f;
}

}  // namespace rvwo::apps
