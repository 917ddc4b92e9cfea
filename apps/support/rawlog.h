// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Rawlog files (MRPT's "observations only" format: one serialized CObservation after another,
// gz-compressed), as docs/rawlog.md lays them out for RVWO. The older action/observation format is
// read too: a sensory frame's observations in turn, and odometry actions as odometry observations.
//
// External images (CImage::setExternalStorage) are looked for in "<rawlog without .rawlog>_Images/"
// beside the file, MRPT's convention; the reader sets that folder itself
// (CRawlog::detectImagesDirectory is broken in MRPT 2.5.8).
#pragma once

#include <mrpt/img/CImage.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation.h>
#include <mrpt/poses/CPose2D.h>

#include <deque>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>

namespace rvwo::apps {

// A record that cannot be read; index is the 0-based number of the record.
class RawlogError : public std::runtime_error {
 public:
  RawlogError(const std::string& path, std::size_t index, const std::string& what)
      : std::runtime_error(path + ": record " + std::to_string(index) + ": " + what), index_(index) {}
  std::size_t index() const { return index_; }

 private:
  std::size_t index_;
};

class RawlogWriter {
 public:
  // Throws std::runtime_error when the file cannot be created. compression: 0 (none) to 9.
  explicit RawlogWriter(const std::string& path, int compression = 1);
  void write(const mrpt::obs::CObservation& observation);
  std::size_t count() const { return count_; }
  // The folder external images of this rawlog belong in (created on demand by the caller).
  static std::string imagesFolder(const std::string& rawlog_path);

 private:
  std::string path_;
  mrpt::io::CFileGZOutputStream out_;
  std::size_t count_ = 0;
};

class RawlogReader {
 public:
  // Throws std::runtime_error when the file cannot be opened.
  explicit RawlogReader(const std::string& path);
  // The next observation, or std::nullopt at the end. A truncated or corrupt record throws
  // RawlogError naming its index; what was returned before stays valid. (zlib inflates in
  // chunks: records in the same chunk as damaged bytes are lost with them.)
  std::optional<mrpt::obs::CObservation::Ptr> next();
  std::size_t count() const { return count_; }  // records read so far

 private:
  std::string path_;
  mrpt::io::CFileGZInputStream in_;
  std::size_t count_ = 0;
  std::deque<mrpt::obs::CObservation::Ptr> pending_;  // from a sensory frame, flattened

  // MRPT's odometry action (an increment) as the odometry observation it would be: sensor label
  // ODOMETRY, the increments summed into a pose (and encoder ticks), the action's timestamp.
  mrpt::obs::CObservation::Ptr odometryOf(const mrpt::obs::CActionRobotMovement2D& move);
  mrpt::poses::CPose2D action_pose_;
  std::int64_t action_ticks_left_ = 0, action_ticks_right_ = 0;
};

// The whole gz stream of a rawlog read once before its records are used: zlib checks its CRC
// only at the end, so a damaged byte could otherwise decode into a wrong value that is delivered
// before the error shows. An uncompressed rawlog carries no check.
struct StreamCheck {
  enum class Result { kIntact, kUncompressed, kTruncated, kDamaged } result = Result::kIntact;
  std::string error;      // zlib's words, for kTruncated and kDamaged
  std::size_t bytes = 0;  // decompressed
  double seconds = 0.0;   // the check's wall time
};
StreamCheck checkRawlogStream(const std::string& path);

// A rawlog image as OpenCV reads it: an external file decoded with cv::imread flags (throws
// std::runtime_error "cannot read image <path>" when it cannot be), an image stored in the rawlog
// copied; cv::IMREAD_GRAYSCALE gives one channel either way.
cv::Mat loadImage(const mrpt::img::CImage& image, int flags);

// Throws std::runtime_error "cannot read image <path>: <why>" when an externally stored image's
// file is missing (naming the images folder when that is what is missing).
void requireImageFile(const mrpt::img::CImage& image);

// The cause in an MRPT exception's what(): its innermost "Message:" line, without the banner,
// location and stack trace around it (what's first line when it has none).
std::string mrptMessage(const std::string& what);

}  // namespace rvwo::apps
