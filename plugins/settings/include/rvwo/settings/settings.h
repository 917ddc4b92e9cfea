// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Settings in ORB-SLAM3's style: a cv::FileStorage YAML file ("%YAML:1.0" first) with dotted
// top-level keys (Camera1.fx, Reliability.Ph, Odometry.NoiseX, ...). The readers below fill the
// core's parameter structs: a key that is present overrides the default, a key that is absent
// keeps it, a key of the wrong type or an invalid value is an error naming the file and the key.
//
//   Reliability.*  ReliabilityParams (rvwo/kernels/reliability.h), e.g. Reliability.Ph: 0.9
//   Odometry.*     WheelNoise (rvwo/edges/wheel_preintegration.h), e.g. Odometry.NoiseX: 0.02
//   Semantics.LabelSet: "voc21" | "coco80" | "ade20k150"      (default voc21)
//   Semantics.PriorsFile: "my_priors.txt"   lines "class: prior", relative to the settings file
//   Semantics.Prior.<class>: <prior>         one class's prior, e.g. Semantics.Prior.chair: 0.6
//   Tracking.*     TrackingOptions (rvwo/tracking/options.h), e.g. Tracking.MinInliers: 20
#pragma once

#include <Eigen/Geometry>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rvwo/edges/wheel_preintegration.h"
#include "rvwo/kernels/reliability.h"
#include "rvwo/kernels/semantic_priors.h"
#include "rvwo/tracking/options.h"

namespace rvwo {

// What OpenCV 4.6's YAML parser is not given, since it loops for ever on some damaged files
// (fuzzing found them): a control character YAML does not allow (a NUL, ...), a first key that is
// indented. Throws std::runtime_error "<name>: line N: ..." (Settings::load and fromString call
// it; so must any other reader that hands a file to cv::FileStorage).
void checkYamlText(const std::string& name, const std::string& text);

class Settings {
 public:
  // Throws std::runtime_error "<path>: ..." when the file is missing, is not a FileStorage YAML
  // (a syntax error's line named), or gives a top-level key twice (both lines named).
  static Settings load(const std::string& path);
  // The same from text (for tests and embedded defaults); `name` is used in messages.
  static Settings fromString(const std::string& yaml, const std::string& name = "<settings>");
  ~Settings();
  Settings(Settings&&) noexcept;
  Settings& operator=(Settings&&) noexcept;

  const std::string& path() const { return path_; }
  bool has(const std::string& key) const;
  // Absent: std::nullopt. Present but not a number (or a string): std::invalid_argument naming it.
  std::optional<double> number(const std::string& key) const;
  std::optional<std::string> text(const std::string& key) const;
  // A string naming a file: relative to this settings file's folder unless absolute; made absolute
  // (so that it can be handed on to another program or settings file).
  std::optional<std::string> file(const std::string& key) const;
  // Present and a number, or std::invalid_argument "<path>: missing key <key>".
  double requireNumber(const std::string& key) const;
  // A rows x cols !!opencv-matrix (e.g. Camera.T_b_c, 4x4), row-major; absent: std::nullopt;
  // present but not a matrix of that size: std::invalid_argument naming it.
  std::optional<std::vector<double>> matrix(const std::string& key, int rows, int cols) const;
  // Every top-level key that starts with prefix.
  std::vector<std::string> keysWithPrefix(const std::string& prefix) const;

 private:
  Settings();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string path_;
};

ReliabilityParams readReliability(const Settings& s, ReliabilityParams defaults = {});
WheelNoise readWheelNoise(const Settings& s, WheelNoise defaults = {});
SemanticPriors readSemanticPriors(const Settings& s);
// Segmentation.LabelDilation (px, a whole number 0 to 100) over the default; old_key: a name it was
// read by before (renamedNumber).
int readLabelDilation(const Settings& s, int defaults, const std::string& old_key = "");
// A 4x4 rigid transform (e.g. Camera.T_b_c). Absent: identity, or std::invalid_argument
// "<path>: missing key <key>" when required; not a rotation and translation: std::invalid_argument.
Eigen::Isometry3d readIsometry(const Settings& s, const std::string& key, bool required);
// Odometry.WheelRadiusLeft, Odometry.WheelRadiusRight, Odometry.Track (m), validated.
DiffDriveParams readDiffDrive(const Settings& s, DiffDriveParams defaults = {});
// The number under key, or under old_key (its name before a rename; "" for none) with one line
// to *warnings (std::cerr when null) once per file and key; both given is std::invalid_argument
// naming them.
std::optional<double> renamedNumber(const Settings& s, const std::string& key, const std::string& old_key,
                                    std::ostream* warnings = nullptr);
// Tracking.* over the host's defaults, validated. A key the estimator used to read under another
// name (Estimator.MinInliers, ...) is still read under it, with one line to *warnings (std::cerr
// when null) once per file and key; both names given is std::invalid_argument naming them.
TrackingOptions readTrackingOptions(const Settings& s, TrackingOptions defaults = {}, std::ostream* warnings = nullptr);
// Every Tracking.* key, one a line, as readTrackingOptions reads them back.
void writeTrackingOptions(std::ostream& out, const TrackingOptions& o);

}  // namespace rvwo
