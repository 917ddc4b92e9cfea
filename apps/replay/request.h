// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-replay's command line: the options in the order --help lists them (ReplayArgs), the same as
// plain values (ReplayRequest), and --mode and --kernel read into the estimator's options. Included
// by rvwo_replay.cc alone (RVWO_WITH_ORBSLAM3 adds --backend and --vocabulary).
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "rvwo/estimator/estimator.h"
#include "support/command_line.h"

namespace rvwo::apps {

// The command line, in the order --help lists it.
struct ReplayArgs {
  TCLAP::CmdLine cmd{
      "rvwo-replay: replays a rawlog (camera and wheel odometry, docs/rawlog.md) through the RVWO estimator "
      "(visual-wheel odometry on SE(2) with adaptive robust kernels, local bundle adjustment, segmentation of "
      "keyframes) and writes the robot's pose at every frame in TUM format, a report and a PNG plot. "
      "Example: rvwo-sim --scenario scenarios/dynamic.yaml --out seq --duration 20 && rvwo-replay --settings "
      "seq/settings.yaml --rawlog seq/sequence.rawlog --out traj.txt --gt seq/groundtruth.txt",
      ' ', RVWO_VERSION};
  TCLAP::ValueArg<std::string> settings{
      "", "settings", "settings YAML (camera, extrinsic, odometry, ...)", true, "", "S.yaml", cmd};
  TCLAP::ValueArg<std::string> rawlog{"", "rawlog", "the recording", true, "", "R.rawlog", cmd};
  TCLAP::ValueArg<std::string> out{"", "out", "trajectory file to write (TUM format)", true, "", "traj.txt", cmd};
  TCLAP::ValueArg<std::string> gt{
      "", "gt", "ground truth (TUM): the report gives the ATE and the plot shows it", false, "", "gt.txt", cmd};
  TCLAP::ValueArg<std::string> mode{
      "", "mode", "wheel: dead reckoning; vo: vision only; vw: vision and wheels (default)", false, "vw", "wheel|vo|vw",
      cmd};
  TCLAP::ValueArg<std::string> kernel{
      "",
      "kernel",
      "robust kernel on visual residuals: huber, fixed:<alpha> (a Barron shape for all), adaptive (default: each "
      "landmark's shape from its reliability)",
      false,
      "adaptive",
      "huber|fixed:A|adaptive",
      cmd};
  TCLAP::SwitchArg no_semantics{"", "no-semantics", "ignore labels: reliability from reprojection errors only", cmd};
  TCLAP::ValueArg<std::string> segmenter{
      "",
      "segmenter",
      "labels for keyframes: rawlog (the LABELS images in the rawlog, default when present), onnx (the network "
      "RVWO ships: DeepLabV3 MobileNetV2, VOC's 21 classes), onnx:<model.onnx> (another network), or none",
      false,
      "auto",
      "rawlog|onnx|onnx:FILE|none",
      cmd};
  TCLAP::ValueArg<std::string> labels_out{
      "",    "labels-out", "also write each segmented keyframe's labels to this folder: <timestamp>.png, class ids",
      false, "",           "DIR",
      cmd};
  TCLAP::SwitchArg deterministic{"", "deterministic",
                                 "one thread, mapping and segmentation inline: same input, same output", cmd};
  TCLAP::ValueArg<double> realtime{
      "",
      "realtime",
      "feed the records at the pace they were recorded, x times faster (1: as on the robot); 0: as fast as "
      "tracking goes, which leaves local mapping and segmentation (threads of their own) behind it. Default: 0, "
      "and 1 with --backend orbslam3 (as ORB-SLAM3's examples feed it)",
      false,
      0,
      "x",
      cmd};
  TCLAP::ValueArg<std::string> plot{"",         "plot", "PNG to write (default: the --out file with .png)", false, "",
                                    "file.png", cmd};
  TCLAP::ValueArg<std::string> align{
      "", "align", "ATE alignment: se3 (default), sim3, posyaw, none", false, "se3", "se3|...", cmd};
  TCLAP::SwitchArg quiet{"", "quiet", "no progress line", cmd};
#ifdef RVWO_WITH_ORBSLAM3
  TCLAP::ValueArg<std::string> backend{
      "",
      "backend",
      "rvwo (default): RVWO's estimator; orbslam3: the patched ORB-SLAM3 this build was given (--mode vw: with "
      "the wheels; vo: without, as upstream, or with --segmenter given RVWO's labels and --kernel in its 6-DoF "
      "tracking; --kernel adaptive|huber and the keyframes' labels (--segmenter, --no-semantics) apply to its "
      "tracking)",
      false,
      "rvwo",
      "rvwo|orbslam3",
      cmd};
  TCLAP::ValueArg<std::string> vocabulary{
      "",    "vocabulary", "ORB-SLAM3's DBoW2 vocabulary, text (--backend orbslam3; rvwo-orbslam3-vocab makes one)",
      false, "",           "voc.txt",
      cmd};
#endif
};

// What the command line asked for, as plain values.
struct ReplayRequest {
  std::string settings, rawlog, out, gt, mode, kernel, segmenter, labels_out, plot, align, backend = "rvwo", vocabulary;
  bool no_semantics = false, deterministic = false, quiet = false, realtime_set = false;
  double realtime = 0;

  explicit ReplayRequest(ReplayArgs& a)
      : settings(a.settings.getValue()),
        rawlog(a.rawlog.getValue()),
        out(a.out.getValue()),
        gt(a.gt.getValue()),
        mode(a.mode.getValue()),
        kernel(a.kernel.getValue()),
        segmenter(a.segmenter.getValue()),
        labels_out(a.labels_out.getValue()),
        plot(a.plot.getValue()),
        align(a.align.getValue()),
#ifdef RVWO_WITH_ORBSLAM3
        backend(a.backend.getValue()),
        vocabulary(a.vocabulary.getValue()),
#endif
        no_semantics(a.no_semantics.getValue()),
        deterministic(a.deterministic.getValue()),
        quiet(a.quiet.getValue()),
        realtime_set(a.realtime.isSet()),
        realtime(a.realtime.getValue()) {
  }
};

inline rvwo::estimator::Mode parseMode(const std::string& mode) {
  if (mode == "wheel") return rvwo::estimator::Mode::kWheel;
  if (mode == "vo") return rvwo::estimator::Mode::kVo;
  if (mode == "vw") return rvwo::estimator::Mode::kVw;
  throw std::invalid_argument("--mode must be wheel, vo or vw, not '" + mode + "'");
}

// --kernel into opt's kernel choice (and its alpha for fixed:<alpha>).
inline void parseKernel(const std::string& kernel, rvwo::estimator::EstimatorOptions* opt) {
  if (kernel == "huber") {
    opt->kernel = rvwo::estimator::KernelChoice::kHuber;
  } else if (kernel == "adaptive") {
    opt->kernel = rvwo::estimator::KernelChoice::kAdaptive;
  } else if (kernel.rfind("fixed:", 0) == 0) {
    opt->kernel = rvwo::estimator::KernelChoice::kFixed;
    try {
      opt->fixed_alpha = kernel.substr(6) == "-inf" ? -INFINITY : std::stod(kernel.substr(6));
    } catch (const std::exception&) {
      throw std::invalid_argument("--kernel fixed:<alpha>: '" + kernel.substr(6) + "' is not a number");
    }
  } else {
    throw std::invalid_argument("--kernel must be huber, fixed:<alpha> or adaptive, not '" + kernel + "'");
  }
}

}  // namespace rvwo::apps
