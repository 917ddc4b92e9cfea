// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rawlog.h"

#include <mrpt/img/CImage.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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
    } else if (!std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object)) {
      throw RawlogError(path_, count_, std::string("not an observation: ") + object->GetRuntimeClass()->className);
    }
    if (pending_.empty()) ++count_;  // an action or an empty frame
  }
  auto obs = pending_.front();
  pending_.pop_front();
  ++count_;
  return obs;
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
    const std::string path = image.getExternalStorageFileAbsolutePath();
    cv::Mat m = cv::imread(path, flags);
    if (m.empty()) throw std::runtime_error("cannot read image " + path);
    return m;
  }
  cv::Mat m = image.asCvMat<cv::Mat>(mrpt::img::SHALLOW_COPY);
  if (flags == cv::IMREAD_GRAYSCALE && m.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);  // CImage keeps colour as OpenCV does, BGR
    return grey;
  }
  return m.clone();
}

}  // namespace rvwo::apps
