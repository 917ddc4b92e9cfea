// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// rvwo-replay end to end on short simulated sequences (rvwo-sim, fixed seeds, --deterministic): the
// helpers the replay tests share, for a target that defines RVWO_SIM and RVWO_REPLAY.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "../common/temp.h"
#include "support/trajectory.h"

namespace rvwo::apps::test {

namespace fs = std::filesystem;

using rvwo::test::slurp;

// rvwo-sim with the given switches, cut to `duration` seconds, into a fresh scratch folder.
inline fs::path runSim(const std::string& name, const std::string& args, double duration, int seed) {
  const fs::path dir = rvwo::test::scratch("replay_" + name);
  fs::remove_all(dir);
  const std::string cmd = std::string(RVWO_SIM) + " --quiet " + args + " --out " + dir.string() + " --seed " +
                          std::to_string(seed) + " --duration " + std::to_string(duration) + " > /dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return dir;
}

// A scenario of the suite (or a scenario file, by absolute path), simulated (runSim).
inline fs::path simulate(const std::string& scenario, double duration, const std::string& extra = "", int seed = 1) {
  const std::string file =
      fs::path(scenario).is_absolute() ? scenario : std::string(RVWO_SOURCE_DIR) + "/scenarios/" + scenario + ".yaml";
  return runSim(fs::path(scenario).stem().string(), "--scenario " + file + " " + extra, duration, seed);
}

// Scenario lines that give the perfect camera of rvwo-sim's first versions: every camera effect
// off (docs/simulator.md), for a test of the estimator's logic that the effects would blur.
inline const char* kPerfectCamera =
    "Camera.Exposure: 0\nCamera.Vignetting: 0\nCamera.AutoExposure: 0\nCamera.ShotNoise: 0\n"
    "Depth.Noise: 0\nDepth.MaxIncidence: 90\nDepth.MinAlbedo: 0\nDepth.Misregistration: [0, 0]\n";

// A scenario of the suite (`base`) as a file of its own in the scratch folder (`name`.yaml, the
// motion file by absolute path), with Sequence.Camera and Sequence.Lens when given and `extra`
// lines appended.
inline fs::path suiteScenario(const std::string& base, const std::string& name, const std::string& extra,
                              const std::string& camera = "", const std::string& lens = "") {
  const fs::path scenario = rvwo::test::scratch(name + ".yaml");
  std::ifstream in(std::string(RVWO_SOURCE_DIR) + "/scenarios/" + base + ".yaml");
  std::ofstream out(scenario);
  for (std::string l; std::getline(in, l);) {
    if (l.rfind("Sequence.Camera:", 0) == 0 && !camera.empty())
      l = "Sequence.Camera: \"" + camera + "\"\nSequence.Lens: \"" + lens + "\"";
    if (l.rfind("Sequence.MotionFile:", 0) == 0)
      l = "Sequence.MotionFile: \"" + std::string(RVWO_SOURCE_DIR) + "/scenarios/motion/openloris_home1_seq1.txt\"";
    out << l << "\n";
  }
  out << extra;
  return scenario;
}

// The static scenario so (suiteScenario).
inline fs::path staticScenario(const std::string& name, const std::string& extra, const std::string& camera = "",
                               const std::string& lens = "") {
  return suiteScenario("static", name, extra, camera, lens);
}

struct Outcome {
  int status = -1;
  std::string out, err;
  double ate = 0, path = 0, max_step = 0;  // m
  std::size_t poses = 0;
};

// Replays dir's sequence (with its settings, or another file in dir) with the given switches, in
// one thread unless threaded; ATE (se3) against its ground truth.
inline Outcome replay(const fs::path& dir, const std::string& args, const std::string& name,
                      const std::string& settings = "settings.yaml", bool threaded = false) {
  Outcome r;
  const fs::path traj = dir / (name + ".txt"), out = dir / (name + ".stdout"), err = dir / (name + ".stderr");
  const std::string cmd =
      std::string(RVWO_REPLAY) + (threaded ? " --quiet" : " --quiet --deterministic") + " --settings " +
      (dir / settings).string() + " --rawlog " + (dir / "sequence.rawlog").string() + " --out " + traj.string() +
      " --gt " + (dir / "groundtruth.txt").string() + " " + args + " > " + out.string() + " 2> " + err.string();
  const int rc = std::system(cmd.c_str());
  r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  if (r.status != 0 || !fs::exists(traj)) return r;
  const Trajectory gt = readTum((dir / "groundtruth.txt").string());
  const Trajectory est = readTum(traj.string());
  r.poses = est.size();
  const auto pairs = associate(gt, est, 0.005);
  r.ate = ate(gt, est, pairs, Alignment::kSE3).stats.rmse;
  r.path = pathLength(gt, pairs);
  r.max_step = rpe(gt, est, pairs, 1, false).stats.max;
  return r;
}

// The figures a run measured, on the test's output (for the notes).
inline void show(const std::string& what, const Outcome& r) {
  std::printf("[ figures  ] %-28s ATE %.4f m = %.3f %% of %.1f m, largest 1-frame step %.4f m\n", what.c_str(), r.ate,
              r.path > 0 ? 100 * r.ate / r.path : 0.0, r.path, r.max_step);
}

// The wheels' calibration a vw report gives (distance and turn as scales, curvature in rad/m).
struct Calibration {
  double distance = 0, turn = 0, curvature = 0;
};
inline bool readCalibration(const std::string& report, Calibration* c) {
  const std::size_t at = report.find("wheel calibration (estimated): ");
  return at != std::string::npos &&
         std::sscanf(report.c_str() + at, "wheel calibration (estimated): distance x%lf, turn x%lf, curvature %lf",
                     &c->distance, &c->turn, &c->curvature) == 3;
}

// Whether tracking let vision alone overrule the wheels on some frame (a slip).
inline bool slipCaught(const std::string& report) {
  return report.find("frames where vision overruled the wheels (a slip): 0;") == std::string::npos;
}

inline std::size_t lines(const fs::path& p) {
  std::ifstream in(p);
  std::string l;
  std::size_t n = 0;
  while (std::getline(in, l)) n += !l.empty() && l[0] != '#';
  return n;
}

// The full system on dir's sequence: it must run, give every frame a pose, and show its figures.
inline void replayVw(const fs::path& dir, const std::string& what, Outcome* vw) {
  *vw = replay(dir, "", "vw");
  ASSERT_EQ(vw->status, 0) << vw->err;
  EXPECT_EQ(vw->poses, lines(dir / "groundtruth.txt"));
  show(what, *vw);
}

}  // namespace rvwo::apps::test
