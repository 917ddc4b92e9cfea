// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rawlog.h"

#include <mrpt/img/CImage.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>
#include <zlib.h>

#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "rvwo/semantics/image_file.h"

namespace rvwo::apps {

std::string RawlogWriter::imagesFolder(const std::string& rawlog_path) {
  std::filesystem::path p(rawlog_path);
  return (p.parent_path() / (p.stem().string() + "_Images")).string();
}

RawlogWriter::RawlogWriter(const std::string& path, int compression) : path_(path) {
  if (!out_.open(path, compression)) throw std::runtime_error(path + ": cannot be created");
}

void RawlogWriter::write(const mrpt::obs::CObservation& observation) {
  try {
    auto arch = mrpt::serialization::archiveFrom(out_);
    arch << observation;
  } catch (const std::exception& e) {
    throw std::runtime_error(path_ + ": writing record " + std::to_string(count_) + " failed: " + e.what());
  }
  ++count_;
}

RawlogReader::RawlogReader(const std::string& path) : path_(path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error(path + ": rawlog not found");
  if (!in_.open(path)) throw std::runtime_error(path + ": cannot be opened");
  mrpt::img::CImage::setImagesPathBase(RawlogWriter::imagesFolder(path));
}

std::optional<mrpt::obs::CObservation::Ptr> RawlogReader::next() {
  while (pending_.empty()) {
    const uint64_t before = in_.getPosition();
    mrpt::serialization::CSerializable::Ptr object;
    try {
      auto arch = mrpt::serialization::archiveFrom(in_);
      arch >> object;
    } catch (const std::exception& e) {
      // No byte read and at the end of the file: it ends at a record boundary. Anything else (a
      // record cut short, or bytes zlib or the deserializer reject) is a broken record.
      if (in_.getPosition() == before && in_.checkEOF()) return std::nullopt;
      throw RawlogError(path_, count_,
                        (count_ == 0 ? "not a rawlog, or corrupt from its start (" : "truncated or corrupt (") +
                            mrptMessage(e.what()) + ")");
    }
    if (auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(object)) {
      pending_.push_back(obs);
    } else if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(object)) {
      for (const auto& o : *sf) pending_.push_back(o);  // MRPT's (action, frame) format: flattened
    } else if (auto actions = std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object)) {
      for (const auto& a : *actions) {
        if (auto move = std::dynamic_pointer_cast<mrpt::obs::CActionRobotMovement2D>(a.get_ptr()))
          pending_.push_back(odometryOf(*move));
      }
    } else {
      throw RawlogError(path_, count_, std::string("not an observation: ") + object->GetRuntimeClass()->className);
    }
    if (pending_.empty()) ++count_;  // an action or an empty frame
  }
  auto obs = pending_.front();
  pending_.pop_front();
  ++count_;
  return obs;
}

mrpt::obs::CObservation::Ptr RawlogReader::odometryOf(const mrpt::obs::CActionRobotMovement2D& move) {
  action_pose_ = action_pose_ + move.rawOdometryIncrementReading;
  auto o = std::make_shared<mrpt::obs::CObservationOdometry>();
  o->sensorLabel = "ODOMETRY";
  o->timestamp = move.timestamp;
  o->odometry = action_pose_;
  if (move.hasEncodersInfo) {  // increments in the action, cumulative in an observation
    action_ticks_left_ += move.encoderLeftTicks;
    action_ticks_right_ += move.encoderRightTicks;
    o->hasEncodersInfo = true;
    o->encoderLeftTicks = static_cast<int32_t>(action_ticks_left_);
    o->encoderRightTicks = static_cast<int32_t>(action_ticks_right_);
  }
  o->hasVelocities = move.hasVelocities;
  o->velocityLocal = move.velocityLocal;
  return o;
}

std::string mrptMessage(const std::string& what) {
  // "==== MRPT exception ====\nMessage:  <text>\nLocation: ...\nCall stack backtrace: ...", nested
  // with "Original exception:": the innermost message is the cause.
  const std::string key = "Message:";
  const std::size_t at = what.rfind(key);
  std::string line = what.substr(at == std::string::npos ? 0 : at + key.size());
  line = line.substr(0, line.find('\n'));
  const std::size_t first = line.find_first_not_of(' ');
  return first == std::string::npos ? what.substr(0, what.find('\n')) : line.substr(first);
}

void requireImageFile(const mrpt::img::CImage& image) {
  if (!image.isExternallyStored()) return;
  const std::string path = image.getExternalStorageFileAbsolutePath();
  if (std::filesystem::exists(path)) return;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (!std::filesystem::is_directory(folder))
    throw std::runtime_error("cannot read image " + path + ": no folder " + folder.string() +
                             " (a rawlog's images are kept in <name>_Images beside it)");
  throw std::runtime_error("cannot read image " + path + ": no such file");
}

cv::Mat loadImage(const mrpt::img::CImage& image, int flags) {
  if (image.isExternallyStored()) {
    requireImageFile(image);  // (first: OpenCV would print a warning of its own for a missing file)
    return readImageFile(image.getExternalStorageFileAbsolutePath(), flags);
  }
  cv::Mat m = image.asCvMat<cv::Mat>(mrpt::img::SHALLOW_COPY);
  if (flags == cv::IMREAD_GRAYSCALE && m.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);  // CImage keeps colour as OpenCV does, BGR
    return grey;
  }
  return m.clone();
}

StreamCheck checkRawlogStream(const std::string& path) {
  StreamCheck c;
  const auto t0 = std::chrono::steady_clock::now();
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error(path + ": cannot be opened");
  std::vector<char> buffer(1 << 20);
  int n = 0;
  while ((n = gzread(f, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0)
    c.bytes += static_cast<std::size_t>(n);
  int code = Z_OK;
  const char* what = gzerror(f, &code);
  if (gzdirect(f)) {
    c.result = StreamCheck::Result::kUncompressed;
  } else if (n < 0 || code != Z_OK) {
    c.error = what ? what : "unknown zlib error";
    if (c.error.rfind(path + ": ", 0) == 0) c.error = c.error.substr(path.size() + 2);  // zlib names the file
    // zlib says "unexpected end of file" for a stream cut short; anything else is damage.
    c.result = code == Z_BUF_ERROR ? StreamCheck::Result::kTruncated : StreamCheck::Result::kDamaged;
  }
  gzclose(f);
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

}  // namespace rvwo::apps
