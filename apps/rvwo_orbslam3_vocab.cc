// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE): links ORB-SLAM3.
//
// rvwo-orbslam3-vocab: builds a DBoW2 vocabulary for ORB-SLAM3 from the camera images of rawlogs.
//
//   rvwo-orbslam3-vocab --rawlog a.rawlog [--rawlog b.rawlog ...] --out voc.txt [--every 10] [--k 10 --levels 4]
//
// ORB-SLAM3 needs a bag-of-words vocabulary for relocalisation, loop closing and tracking against
// a reference keyframe; upstream's ORBvoc.txt (1M words from indoor and outdoor images) is large
// and not always at hand. This one is trained on your own images with ORB-SLAM3's own feature
// extractor: build it from recordings other than those you evaluate on. k^levels words at most
// (k = 10, levels = 4: 10 000; a few minutes for a few hundred images).
// Built only in a build given ORB_SLAM3_ROOT (with rvwo-replay's --backend orbslam3).
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationStereoImages.h>

#include <chrono>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "rvwo/orbslam3/runner.h"
#include "support/command_line.h"
#include "support/rawlog.h"

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-orbslam3-vocab", [&] {
    TCLAP::CmdLine cmd(
        "rvwo-orbslam3-vocab: builds a DBoW2 vocabulary (text, for ORB-SLAM3 and rvwo-replay --backend orbslam3) "
        "from the camera images of rawlogs, with ORB-SLAM3's own ORB extractor. Train it on recordings other than "
        "those you evaluate on. Example: rvwo-sim --scenario scenarios/static.yaml --seed 2 --out train && "
        "rvwo-orbslam3-vocab --rawlog train/sequence.rawlog --out voc.txt",
        ' ', RVWO_VERSION);
    TCLAP::MultiArg<std::string> rawlogs("", "rawlog", "a recording (several may be given)", true, "R.rawlog", cmd);
    TCLAP::ValueArg<std::string> out("", "out", "vocabulary file to write (text)", true, "", "voc.txt", cmd);
    TCLAP::ValueArg<std::string> label("", "camera-label", "sensor label of the camera (default: CAMERA, RGBD)", false,
                                       "", "LABEL", cmd);
    TCLAP::ValueArg<int> every("", "every", "use one image in this many (default 10)", false, 10, "N", cmd);
    TCLAP::ValueArg<int> k("", "k", "branching factor (default 10)", false, 10, "K", cmd);
    TCLAP::ValueArg<int> levels("", "levels", "depth of the tree (default 4: at most k^4 words)", false, 4, "L", cmd);
    TCLAP::ValueArg<int> features("", "features", "ORB features per image (default 1200)", false, 1200, "N", cmd);
    if (const auto status = rvwo::apps::parseCommandLine(cmd, argc, argv)) return *status;
    if (every.getValue() < 1 || k.getValue() < 2 || levels.getValue() < 1 || features.getValue() < 100)
      throw std::invalid_argument("--every >= 1, --k >= 2, --levels >= 1, --features >= 100");

    std::vector<cv::Mat> images;
    for (const std::string& path : rawlogs.getValue()) {
      rvwo::apps::RawlogReader reader(path);
      std::size_t seen = 0;
      while (auto o = reader.next()) {
        const auto& obs = *o;
        if (!label.getValue().empty() ? obs->sensorLabel != label.getValue()
                                      : obs->sensorLabel != "CAMERA" && obs->sensorLabel != "RGBD")
          continue;
        if (seen++ % every.getValue() != 0) continue;
        if (auto st = std::dynamic_pointer_cast<mrpt::obs::CObservationStereoImages>(obs)) {
          images.push_back(rvwo::apps::loadImage(st->imageLeft, cv::IMREAD_GRAYSCALE));
        } else if (auto rgbd = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(obs)) {
          if (rgbd->hasIntensityImage)
            images.push_back(rvwo::apps::loadImage(rgbd->intensityImage, cv::IMREAD_GRAYSCALE));
        } else if (auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs)) {
          images.push_back(rvwo::apps::loadImage(im->image, cv::IMREAD_GRAYSCALE));
        }
      }
      std::fprintf(stderr, "rvwo-orbslam3-vocab: %s: %zu camera frames, %zu images so far\n", path.c_str(), seen,
                   images.size());
    }
    if (images.empty()) throw std::runtime_error("no camera images in the rawlogs (see --camera-label)");
    const auto t0 = std::chrono::steady_clock::now();
    rvwo::orbslam3::OrbSlam3Features f;
    f.features = features.getValue();
    const std::size_t words =
        rvwo::orbslam3::buildVocabulary(images, f, k.getValue(), levels.getValue(), out.getValue());
    std::printf("rvwo-orbslam3-vocab: %zu words from %zu images in %.1f s: %s\n", words, images.size(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), out.getValue().c_str());
    return 0;
  });
}
