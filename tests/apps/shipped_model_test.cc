// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The network RVWO ships, in the loop of a replay: two real TUM fr3 walking_xyz frames (../shared)
// in a folder laid out as TUM ships it, converted with the fr3 preset (from the folder's name) and
// replayed with --segmenter onnx; the keyframes' labels (--labels-out) against DynaSLAM's person
// masks. From the build tree, and from an installed tree when RVWO_INSTALLED_PREFIX names one (the
// ctest shipped_model_installed, after install_consumer has made it).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>

#include "../common/temp.h"

namespace {

namespace fs = std::filesystem;

const fs::path kFrames = fs::path(RVWO_SHARED_DIR) / "data" / "tum_fr3_walking_xyz";

int run(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// rgbd_dataset_freiburg3_walking_xyz/ with rgb/, depth/, rgb.txt and depth.txt as TUM writes them,
// holding the frame-th of the real frames (each is a replay's first keyframe, so each is segmented).
fs::path tumFolder(const std::string& tag, std::size_t frame) {
  const fs::path dir = rvwo::test::scratch(tag) / "rgbd_dataset_freiburg3_walking_xyz";
  fs::remove_all(dir.parent_path());
  for (const char* sub : {"rgb", "depth"}) {
    fs::create_directories(dir / sub);
    std::ofstream list(dir / (std::string(sub) + ".txt"));
    list << "# " << (sub == std::string("rgb") ? "color" : "depth") << " images\n"
         << "# file: 'rgbd_dataset_freiburg3_walking_xyz.bag'\n# timestamp filename\n";
    const std::set<fs::path> frames(fs::directory_iterator(kFrames / sub), fs::directory_iterator());  // time order
    const fs::path f = *std::next(frames.begin(), static_cast<long>(frame));
    fs::copy_file(f, dir / sub / f.filename());
    list << f.stem().string() << " " << sub << "/" << f.filename().string() << "\n";
  }
  return dir;
}

// Person IoU of every label image the replay wrote against the mask of the same frame.
// Converts and replays the frame-th real frame with the binaries in bin; the person IoU of its
// label image against the mask. model_dir: where the report must say the network came from.
double personIou(const std::string& bin, const std::string& tag, std::size_t frame, const std::string& model_dir) {
  const fs::path dir = tumFolder(tag, frame), out = dir.parent_path() / "out";
  fs::create_directories(out);
  const std::string log = (out / "log.txt").string();
  const std::string rawlog = (out / "sequence.rawlog").string();
  EXPECT_EQ(run(bin + "/rvwo-convert tum --in " + dir.string() + " --out " + rawlog + " > " + log), 0)
      << rvwo::test::slurp(log);
  const std::string converted = rvwo::test::slurp(log);
  EXPECT_NE(converted.find("from preset fr3"), std::string::npos) << converted;
  const fs::path labels = out / "labels";
  EXPECT_EQ(run(bin + "/rvwo-replay --quiet --deterministic --mode vo --segmenter onnx --labels-out " +
                labels.string() + " --settings " + (out / "settings.yaml").string() + " --rawlog " + rawlog +
                " --out " + (out / "traj.txt").string() + " > " + log + " 2>&1"),
            0)
      << rvwo::test::slurp(log);
  const std::string report = rvwo::test::slurp(log);
  EXPECT_NE(report.find("semantics the shipped network " + model_dir), std::string::npos) << report;
  EXPECT_NE(report.find("label images written: 1,"), std::string::npos) << report;
  for (const auto& e : fs::directory_iterator(labels)) {
    const cv::Mat l = cv::imread(e.path().string(), cv::IMREAD_UNCHANGED);
    const cv::Mat mask = cv::imread((kFrames / "mask" / e.path().filename()).string(), cv::IMREAD_UNCHANGED);
    if (mask.empty() || l.size() != mask.size()) {
      ADD_FAILURE() << "no mask of the frame of " << e.path() << ", or not its size";
      return 0;
    }
    const cv::Mat person = l == 15, truth = mask == 0;  // VOC's person; DynaSLAM's masks: 0 = person
    const double iou = double(cv::countNonZero(person & truth)) / cv::countNonZero(person | truth);
    std::printf("%s: person IoU %.3f\n", e.path().filename().c_str(), iou);
    return iou;
  }
  return 0;
}

// Both real frames: one walking and one standing person each.
void expectPeopleLabelled(const std::string& bin, const std::string& tag, const std::string& model_dir = "") {
  if (!fs::exists(kFrames)) GTEST_SKIP() << "../shared is absent: no real TUM frames";
  for (std::size_t frame = 0; frame < 2; ++frame) EXPECT_GE(personIou(bin, tag, frame, model_dir), 0.75) << frame;
}

TEST(ShippedModel, ReplayLabelsThePeopleOfTumWalkingFromTheBuildTree) {
  expectPeopleLabelled(fs::path(RVWO_REPLAY).parent_path().string(), "shipped_build");
}

TEST(ShippedModel, ReplayLabelsThePeopleOfTumWalkingFromAnInstalledTree) {
  const char* prefix = std::getenv("RVWO_INSTALLED_PREFIX");
  if (!prefix || !*prefix) GTEST_SKIP() << "no installed tree given (ctest shipped_model_installed runs it)";
  // The installed model, not the source tree's: the report names the file it ran.
  const fs::path root = fs::canonical(prefix);
  expectPeopleLabelled((root / "bin").string(), "shipped_installed", (root / "share" / "rvwo" / "models").string());
}

}  // namespace
