// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-replay end to end on short simulated sequences of the scenario suite (rvwo-sim, fixed
// seeds, --deterministic): every frame gets a pose, and the accuracy relations of the estimator
// issue hold: vw within 0.5 % of the path, vw beats the wheels (by half under a slip, and through
// a blackout without a jump), the adaptive kernel beats Huber among walkers and costs nothing
// where nothing moves. Bad input: one clear line, a non-zero exit, output already estimated kept.
#include <gtest/gtest.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "../common/temp.h"
#include "support/rawlog.h"
#include "support/trajectory.h"

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;

using rvwo::test::slurp;

// A scenario of the suite (or a scenario file, by absolute path), cut to `duration` seconds,
// simulated into a fresh scratch folder.
fs::path simulate(const std::string& scenario, double duration, const std::string& extra = "", int seed = 1) {
  const fs::path dir = rvwo::test::scratch("replay_" + fs::path(scenario).stem().string());
  fs::remove_all(dir);
  const std::string file =
      fs::path(scenario).is_absolute() ? scenario : std::string(RVWO_SOURCE_DIR) + "/scenarios/" + scenario + ".yaml";
  const std::string cmd = std::string(RVWO_SIM) + " --quiet --scenario " + file + " --out " + dir.string() +
                          " --seed " + std::to_string(seed) + " --duration " + std::to_string(duration) + " " + extra +
                          " > /dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return dir;
}

// The static scenario as a file of its own in the scratch folder (`name`.yaml, the motion file by
// absolute path), with Sequence.Camera and Sequence.Lens when given and `extra` lines appended.
fs::path staticScenario(const std::string& name, const std::string& extra, const std::string& camera = "",
                        const std::string& lens = "") {
  const fs::path scenario = rvwo::test::scratch(name + ".yaml");
  std::ifstream in(std::string(RVWO_SOURCE_DIR) + "/scenarios/static.yaml");
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

struct Outcome {
  int status = -1;
  std::string out, err;
  double ate = 0, path = 0, max_step = 0;  // m
  std::size_t poses = 0;
};

// Replays dir's sequence (with its settings, or another file in dir) with the given switches; ATE
// (se3) against its ground truth.
Outcome replay(const fs::path& dir, const std::string& args, const std::string& name,
               const std::string& settings = "settings.yaml") {
  Outcome r;
  const fs::path traj = dir / (name + ".txt"), out = dir / (name + ".stdout"), err = dir / (name + ".stderr");
  const std::string cmd = std::string(RVWO_REPLAY) + " --quiet --deterministic --settings " +
                          (dir / settings).string() + " --rawlog " + (dir / "sequence.rawlog").string() + " --out " +
                          traj.string() + " --gt " + (dir / "groundtruth.txt").string() + " " + args + " > " +
                          out.string() + " 2> " + err.string();
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
void show(const std::string& what, const Outcome& r) {
  std::printf("[ figures  ] %-28s ATE %.4f m = %.3f %% of %.1f m, largest 1-frame step %.4f m\n", what.c_str(), r.ate,
              r.path > 0 ? 100 * r.ate / r.path : 0.0, r.path, r.max_step);
}

// The wheels' calibration a vw report gives (distance and turn as scales, curvature in rad/m).
struct Calibration {
  double distance = 0, turn = 0, curvature = 0;
};
bool readCalibration(const std::string& report, Calibration* c) {
  const std::size_t at = report.find("wheel calibration (estimated): ");
  return at != std::string::npos &&
         std::sscanf(report.c_str() + at, "wheel calibration (estimated): distance x%lf, turn x%lf, curvature %lf",
                     &c->distance, &c->turn, &c->curvature) == 3;
}

// Whether tracking let vision alone overrule the wheels on some frame (a slip).
bool slipCaught(const std::string& report) {
  return report.find("frames where vision overruled the wheels (a slip): 0;") == std::string::npos;
}

std::size_t lines(const fs::path& p) {
  std::ifstream in(p);
  std::string l;
  std::size_t n = 0;
  while (std::getline(in, l)) n += !l.empty() && l[0] != '#';
  return n;
}

// The full system on dir's sequence: it must run, give every frame a pose, and show its figures.
void replayVw(const fs::path& dir, const std::string& what, Outcome* vw) {
  *vw = replay(dir, "", "vw");
  ASSERT_EQ(vw->status, 0) << vw->err;
  EXPECT_EQ(vw->poses, lines(dir / "groundtruth.txt"));
  show(what, *vw);
}

TEST(Replay, StaticEveryFrameAccurateAndAdaptiveCostsNothing) {
  const fs::path dir = simulate("static", 15);
  const std::size_t frames = lines(dir / "groundtruth.txt");
  const Outcome wheel = replay(dir, "--mode wheel", "wheel");
  const Outcome huber = replay(dir, "--kernel huber", "huber");
  const Outcome adaptive = replay(dir, "--kernel adaptive", "adaptive");
  for (const Outcome* r : {&wheel, &huber, &adaptive}) {
    ASSERT_EQ(r->status, 0) << r->err;
    EXPECT_EQ(r->poses, frames);  // every frame has a pose
  }
  show("static wheel", wheel);
  show("static vw huber", huber);
  show("static vw adaptive", adaptive);
  EXPECT_LE(adaptive.ate, 0.005 * adaptive.path) << adaptive.out;
  EXPECT_LE(adaptive.ate, 1.05 * huber.ate);
  EXPECT_LT(adaptive.ate, wheel.ate);
  // The wheels' calibration, refined by local BA, recovers the simulator's: radii 1 % over and
  // under (a bend of (d_r - d_l) / b = -0.05 rad/m) and a track 2 % wide (turns x 0.98). The turn
  // scale settles 0.5-1 % above the truth (this cut 0.985; the 90 s static scenario 0.988-0.990 with
  // either stereo matcher, and 0.987 without the calibration's prior around 1): a known limit,
  // within half the 2 % it corrects.
  Calibration c;
  ASSERT_TRUE(readCalibration(adaptive.out, &c)) << adaptive.out;
  EXPECT_NEAR(c.curvature, -0.05, 0.005);
  EXPECT_NEAR(c.turn, 0.98, 0.01);
  EXPECT_NEAR(c.distance, 1.0, 0.01);
  // Deterministic mode: the same input gives the same bytes.
  replay(dir, "--kernel adaptive", "adaptive2");
  EXPECT_EQ(slurp(dir / "adaptive.txt"), slurp(dir / "adaptive2.txt"));
  // The report says what a user needs (and a PNG is written beside the trajectory).
  EXPECT_NE(adaptive.out.find("ATE (se3)"), std::string::npos);
  EXPECT_NE(adaptive.out.find("keyframes"), std::string::npos);
  EXPECT_NE(adaptive.out.find("local BA"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "adaptive.png"));
  fs::remove_all(dir);
}

TEST(Replay, DynamicAdaptiveKernelBeatsHuber) {
  // The ratio and bound, summed over the 30 s cuts of seeds 1-3: on a single cut the two
  // kernels' few millimetres are a draw (seed 1: adaptive 0.0042 m, Huber 0.0036; seed 2: 0.0023
  // and 0.0088; seed 3: 0.0023 and 0.0056; summed 0.49). Before keypoints were placed on their
  // content (placeOnTheirContent) the sums were 0.0086 and 0.0115 m: 0.75. (The cuts' hard part:
  // at 8.6 s of seed 1 walkers fill 73 % of the view. Until vision counted only landmarks no
  // label calls dynamic, their freshly mapped points kept tracking 'visual' and pulled the map
  // 0.14 rad before three labels each rejected them: adaptive 1.16 %, Huber 1.80 %; now those
  // frames follow the wheels.)
  double sum_huber = 0, sum_adaptive = 0;
  for (int seed = 1; seed <= 3; ++seed) {
    const fs::path dir = simulate("dynamic", 30, "", seed);
    const Outcome huber = replay(dir, "--kernel huber", "huber");
    const Outcome adaptive = replay(dir, "--kernel adaptive", "adaptive");
    ASSERT_EQ(huber.status, 0) << huber.err;
    ASSERT_EQ(adaptive.status, 0) << adaptive.err;
    EXPECT_EQ(adaptive.poses, lines(dir / "groundtruth.txt"));
    show("dynamic s" + std::to_string(seed) + " vw huber", huber);
    show("dynamic s" + std::to_string(seed) + " vw adaptive", adaptive);
    sum_huber += huber.ate;
    sum_adaptive += adaptive.ate;
    EXPECT_LE(adaptive.ate, 0.005 * adaptive.path) << "seed " << seed;
    // Walkers are no slip: vision alone, pulled by them, must not overrule the wheels (before the
    // slip test asked how vision alone moved, it did so on 56 frames of the 90 s scenario, with
    // steps of up to 35 cm).
    for (const Outcome* r : {&huber, &adaptive}) {
      EXPECT_FALSE(slipCaught(r->out)) << "seed " << seed << "\n" << r->out;
      EXPECT_LE(r->max_step, 0.05) << "seed " << seed;
    }
    if (seed == 1) {
      // Without labels (a network that misses the walkers) only the reprojection errors and the
      // wheels stand against them. Vision alone, pulled by walkers, once overruled the wheels for
      // 21 frames, a walker's step of 4-5 cm each, sideways or back: a 1-frame step of 0.25 m,
      // 1.18 % of the path. Now 0.35 %, the largest step 8.3 cm (local BA bending the map, not a
      // slip); this cut is the one of five where the wheel gate costs (below).
      const Outcome blind = replay(dir, "--kernel adaptive --no-semantics", "no_labels");
      ASSERT_EQ(blind.status, 0) << blind.err;
      show("dynamic s1 vw adaptive, no labels", blind);
      EXPECT_LE(blind.max_step, 0.12);
      EXPECT_LE(blind.ate, 0.008 * blind.path);
    }
    fs::remove_all(dir);
  }
  EXPECT_LE(sum_adaptive, 0.7 * sum_huber) << "adaptive " << sum_adaptive << ", huber " << sum_huber;
}

// Walkers no label marks drag the fused pose off the wheels a few millimetres and milliradians a
// frame, each frame's wheel edge starting where the last one was dragged. The wheel gate
// (Tracking.WheelGate) solves such a frame again from the wheels' prediction, first on the
// landmarks it explains. This cut (seed 3) measured 0.0031 m (0.057 %) with it and 0.0221 m
// (0.404 %) without; over five seeds' cuts 1.61 against 2.11 % summed, one of them worse
// (seed 1, above).
TEST(Replay, WalkersNoLabelMarksLoseToTheWheelGate) {
  const fs::path dir = simulate("dynamic", 30, "", 3);
  {
    std::ofstream off(dir / "no_gate.yaml");
    off << slurp(dir / "settings.yaml") << "\nTracking.WheelGate: 0\n";
  }
  const Outcome gated = replay(dir, "--no-semantics", "gated");
  const Outcome plain = replay(dir, "--no-semantics", "plain", "no_gate.yaml");
  ASSERT_EQ(gated.status, 0) << gated.err;
  ASSERT_EQ(plain.status, 0) << plain.err;
  show("dynamic s3, no labels, gate", gated);
  show("dynamic s3, no labels, none", plain);
  EXPECT_EQ(gated.poses, lines(dir / "groundtruth.txt"));
  EXPECT_LE(gated.ate, 0.5 * plain.ate);
  EXPECT_LE(gated.ate, 0.002 * gated.path);
  const std::string none = "placed by the landmarks the wheels explain: 0\n";
  EXPECT_EQ(gated.out.find(none), std::string::npos) << gated.out;
  EXPECT_NE(plain.out.find(none), std::string::npos) << plain.out;
  fs::remove_all(dir);
}

TEST(Replay, SlipVisionHalvesTheWheelError) {
  const fs::path dir = simulate("slip", 20);  // the wheels spin in place at 15-17 s
  const Outcome wheel = replay(dir, "--mode wheel", "wheel");
  const Outcome vw = replay(dir, "", "vw");
  ASSERT_EQ(vw.status, 0) << vw.err;
  show("slip wheel", wheel);
  show("slip vw", vw);
  // Measured 0.086 % of this cut's 4.2 m path, the wheels 2.8 % (the slip is 2 s of it).
  EXPECT_LE(vw.ate, 0.3 * wheel.ate) << "vw " << vw.ate << ", wheel " << wheel.ate;
  EXPECT_LE(vw.ate, 0.005 * vw.path);
  // Tracking caught the slip (vision overruled the wheels on some frames).
  EXPECT_TRUE(slipCaught(vw.out)) << vw.out;
  fs::remove_all(dir);
}

// The combined scenario's first 40 s: walkers, a blackout, and the wheels spinning while the robot
// stands (20-22 s) in the middle of a turn on the spot, so that the wheels claim a turn and no
// travel. The wheels' calibration, refined by local BA, must not take the slip (nor the walkers)
// for a scale error: before the BA judged slips with the calibration it had before (and kept it
// fixed where the wheels disagree with the window), the turn scale went from 0.98 to 0.61 in a
// sequence without walkers, and this cut ended at 0.80 % of its path (0.054 % after).
TEST(Replay, SpinOnTheSpotSlipAndWalkersLeaveTheCalibration) {
  const fs::path dir = simulate("combined", 40);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "combined 40 s vw", &vw));
  EXPECT_LE(vw.ate, 0.003 * vw.path) << vw.out;
  EXPECT_LE(vw.max_step, 0.05);
  EXPECT_TRUE(slipCaught(vw.out)) << vw.out;
  Calibration c;
  ASSERT_TRUE(readCalibration(vw.out, &c)) << vw.out;
  EXPECT_NEAR(c.turn, 0.98, 0.01);
  EXPECT_NEAR(c.curvature, -0.05, 0.015);
  EXPECT_NEAR(c.distance, 1.0, 0.01);
  fs::remove_all(dir);
}

// The combined scenario cut to 24 s is another sequence (the simulator fits the motion file to the
// duration): there the wheels spin through a turn on the spot at 20-22 s while a walker passes
// close in front, covering up to 92 % of the view for a second. Blind right after a slip, the
// pose holds still and no keyframe is made of what is in view; when the walker has
// gone, the map is still there to track (or to relocalise against). Following the spinning
// wheels there left 0.4-0.6 rad of yaw error (0.74 % of the path). The wheel edges across the
// hold sit out local BA's first round: kept under Huber, they dragged the two keyframes made in
// the slip 0.58 m along the spinning wheels, and the frames on them (2.4 %, once keypoints were
// placed on their content).
TEST(Replay, SlipWhileAWalkerCoversTheView) {
  const fs::path dir = simulate("combined", 24);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "combined 24 s vw", &vw));
  EXPECT_LE(vw.ate, 0.003 * vw.path) << vw.out;  // measured 0.085 %
  EXPECT_LE(vw.max_step, 0.05);
  EXPECT_TRUE(slipCaught(vw.out)) << vw.out;
  fs::remove_all(dir);
}

// How far the estimate moved between t0 and t1 (m, in the plane): a slip's wheels claim travel
// the robot does not make.
double travel(const fs::path& traj, double t0, double t1) {
  const Trajectory est = readTum(traj.string());
  const StampedPose* a = nullptr;
  const StampedPose* b = nullptr;
  for (const StampedPose& p : est) {
    if (!a && p.t >= t0) a = &p;
    if (p.t <= t1) b = &p;
  }
  if (!a || !b) return 1e9;
  return (b->T.translation() - a->T.translation()).head<2>().norm();
}

// The whole combined scenario with an RGB-D camera. At 60-62.5 s the wheels spin while the robot
// stands, with walkers close in front: their new, close features asked for a keyframe every
// frame, local BA's window of 8 keyframes spanned a quarter second, and the slip's wheel edges
// dragged it along: 0.77 m of travel where there was none, 0.835 % of the path. No keyframe is
// made for close, new features during a slip: 0.02 m, 0.22 %.
TEST(Replay, SlipAmongCloseWalkersRgbdLeavesTheMapWhereItIs) {
  const fs::path dir = simulate("combined", 120, "--camera rgbd");
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "combined RGB-D vw", &vw));
  EXPECT_LE(vw.ate, 0.005 * vw.path) << vw.out;
  EXPECT_LE(travel(dir / "vw.txt", 60.1, 62.5), 0.05);
  fs::remove_all(dir);
}

// The whole combined scenario with an RGB-D camera, seed 3: the same slip at 60-62.5 s behind
// escorts, who leave 15-50 static landmarks. The fused pose followed the wheels' 1.4 cm a frame,
// vision straining their edge, and the close rule made a keyframe on every frame at that pose:
// the map moved with the wheels, vision alone then saw the robot drive as they claimed, and 0.98
// m of travel where there was none stayed in the trajectory (1.81 % of the path). No keyframe is
// made for close, new features while vision strains the wheel edge: 0.13 m, 0.16 %.
TEST(Replay, SlipBehindEscortsRgbdMakesNoKeyframesOnTheWheelsWay) {
  const fs::path dir = simulate("combined", 120, "--camera rgbd", 3);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "combined RGB-D seed 3 vw", &vw));
  EXPECT_LE(vw.ate, 0.005 * vw.path) << vw.out;
  EXPECT_LE(travel(dir / "vw.txt", 60.1, 62.5), 0.25);
  fs::remove_all(dir);
}

// The whole combined scenario, stereo, seed 3. At 60-62.5 s the wheels spin while the robot
// stands, and tracking, on hundreds of trusted landmarks, catches the slip. Local BA's wheel edge
// across it, under Huber from the first round, still dragged each new keyframe along the wheels'
// claim where vision sees little (forward, on far points): 16 cm and 13 mrad at 60.3 s, again at
// 60.7 s, and the frames after them with them (0.85 % of the path). The first round now goes
// without an edge across a spin (the robot stood while the wheels went on), and the second has it
// only if the keyframes agree with it: 0.10 %.
TEST(Replay, SlipCaughtLeavesTheNewKeyframesWhereVisionPutThem) {
  const fs::path dir = simulate("combined", 120, "", 3);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "combined seed 3 vw", &vw));
  EXPECT_TRUE(slipCaught(vw.out)) << vw.out;
  EXPECT_LE(travel(dir / "vw.txt", 60.1, 62.4), 0.05);
  EXPECT_LE(vw.ate, 0.003 * vw.path) << vw.out;
  fs::remove_all(dir);
}

TEST(Replay, BlackoutWheelsCarryThePoseWithoutAJump) {
  const fs::path dir = simulate("blackout", 27);  // lens covered at 20-24 s
  const Outcome wheel = replay(dir, "--mode wheel", "wheel");
  show("blackout wheel", wheel);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "blackout vw", &vw));
  EXPECT_LE(vw.ate, wheel.ate);
  EXPECT_LE(vw.ate, 0.005 * vw.path);  // the bound; measured 0.04 % of this cut's 4.8 m path (4 s blind)
  EXPECT_LE(vw.max_step, 0.05) << "a pose jump when vision returned";
  // The report names the stretch on wheels only (the blackout, 20-24 s).
  EXPECT_NE(vw.out.find("frames on wheels only: "), std::string::npos);
  EXPECT_NE(vw.out.find("(20."), std::string::npos) << vw.out;
  fs::remove_all(dir);
}

// The other cameras, on a 20 s cut of the static scenario. Mono: points triangulated between
// keyframes that the wheels place, so the map has the wheels' scale (vision alone has none and is
// refused in one line), pinhole and Kannala-Brandt fisheye. Fisheye stereo (a raw pair, the right
// camera turned a little): rectified on input.
TEST(Replay, CamerasMonoAndFisheye) {
  struct Case {
    std::string camera, lens;
    double bound;  // share of the path: the 1 % for mono, 0.5 % for stereo
  };
  for (const Case& c :
       {Case{"mono", "pinhole", 0.01}, Case{"mono", "fisheye", 0.01}, Case{"stereo", "fisheye", 0.005}}) {
    SCOPED_TRACE(c.camera + " " + c.lens);
    const fs::path scenario = staticScenario(c.camera + "_" + c.lens, "", c.camera, c.lens);
    const fs::path dir = simulate(scenario.string(), 20);
    const Outcome wheel = replay(dir, "--mode wheel", "wheel");
    const Outcome vw = replay(dir, "", "vw");
    ASSERT_EQ(vw.status, 0) << vw.err;
    EXPECT_EQ(vw.poses, lines(dir / "groundtruth.txt"));
    show(c.camera + " " + c.lens + " wheel", wheel);
    show(c.camera + " " + c.lens + " vw", vw);
    // Measured: mono 0.13 % (pinhole) and 0.05 % (fisheye), fisheye stereo 0.08 %; wheels 0.58 %.
    EXPECT_LE(vw.ate, c.bound * vw.path) << vw.out;
    EXPECT_LT(vw.ate, wheel.ate) << "vw " << vw.ate << ", wheel " << wheel.ate;
    if (c.camera == "mono") {
      // Mono has no metric but the wheels': their distance scale is not re-estimated (with it
      // free, map and scale drifted together, to 0.976-0.994 over the 90 s mono suite), while
      // the turn scale, an angle vision sees, is.
      Calibration cal;
      ASSERT_TRUE(readCalibration(vw.out, &cal)) << vw.out;
      EXPECT_EQ(cal.distance, 1.0);
      EXPECT_NE(cal.turn, 1.0);
      const Outcome vo = replay(dir, "--mode vo", "vo");
      EXPECT_EQ(vo.status, 1);
      EXPECT_NE(vo.err.find("needs the wheels for its scale"), std::string::npos) << vo.err;
    }
    fs::remove_all(dir);
  }
}

// Lens covered while the wheels spin (20-22 s, in a turn on the spot): the wheels carry the pose
// 0.7 rad round while the robot stands. When vision returns the prediction is too far off for the
// projection search; the frame is relocalised against the map in memory (descriptor matches, a
// two-point SE(2) RANSAC) and the blind stretch bends onto it. Without relocalisation the map was
// started anew 0.69 rad off: 0.77 % of the path (0.093 % with it).
TEST(Replay, RelocalisesWhenTheWheelsSpunWhileBlind) {
  const fs::path scenario = staticScenario("blind_slip", "Events.Blackout: [20.0, 22.0]\nEvents.Slip: [20.0, 22.0]\n");
  const fs::path dir = simulate(scenario.string(), 24);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "blind slip vw", &vw));
  EXPECT_LE(vw.ate, 0.003 * vw.path) << vw.out;
  EXPECT_LE(vw.max_step, 0.05);
  EXPECT_EQ(vw.out.find("relocalised: 0"), std::string::npos) << vw.out;
  fs::remove_all(dir);
}

// A slip (8-9 s: the wheels spin, the robot stands), vision drives on for a second, then goes
// dark (10-11.5 s) while the robot drives at 0.26 m/s. The slip is over: the wheels carry the pose
// through the blackout. (Holding it where vision left it, as a blackout that starts in a slip
// does, held it for the second left of Tracking.SlipHold, some 0.26 m behind the robot: 0.54 %
// of the path once relocalisation had bent the stretch.)
TEST(Replay, BlackoutAfterASlipEndedFollowsTheWheels) {
  const fs::path scenario =
      staticScenario("slip_then_blind", "Events.Slip: [8.0, 9.0]\nEvents.Blackout: [10.0, 11.5]\n");
  const fs::path dir = simulate(scenario.string(), 14);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "slip, then blind vw", &vw));
  EXPECT_TRUE(slipCaught(vw.out)) << vw.out;
  // Measured 0.125 %, largest step 2.5 cm (the slip's first frames, before vision could tell).
  EXPECT_LE(vw.ate, 0.0025 * vw.path) << vw.out;
  EXPECT_LE(vw.max_step, 0.04);
  fs::remove_all(dir);
}

// Mono, a 1 s slip (8-9 s) under a static scene: mono's vision weighs little along its optical
// axis against the wheel edge, so the fused pose drives on with the wheels, and one frame's counts
// cannot tell (vision alone and the fused pose explained 305 and 294 landmarks). Vision alone's own
// track, over 0.2 s five frames in a row (wheelsStall), saw the robot stand. Before it, 3 of the
// slip's 30 frames were caught, the first 0.6 s in with the pose 15 cm ahead: 0.69 % of the path
// (1.96 % with seed 3, now 0.32 %).
TEST(Replay, MonoSlipCaughtByVisionAlonesTrack) {
  const fs::path scenario = staticScenario("mono_slip", "Events.Slip: [8.0, 9.0]\n", "mono", "pinhole");
  const fs::path dir = simulate(scenario.string(), 14);
  Outcome vw;
  ASSERT_NO_FATAL_FAILURE(replayVw(dir, "mono slip vw", &vw));
  const std::size_t at = vw.out.find("(a slip): ");
  ASSERT_NE(at, std::string::npos) << vw.out;
  // Measured: 23 slip frames, 0.419 % of the path, largest step 9.7 cm (vision taking over, 0.43 s in).
  EXPECT_GE(std::stoi(vw.out.substr(at + 10)), 20) << vw.out;
  EXPECT_LE(vw.ate, 0.005 * vw.path) << vw.out;
  fs::remove_all(dir);
}

// --realtime x feeds the records no sooner than the robot lived them, sped up x times: the report's
// speed stays at or below x (sleeping guarantees a lower bound on the time, on any machine), the
// trajectory is whole; 0 feeds them as fast as they go (the default, said outright), which the
// single-thread mode also takes. A pace below 0, or one asked of the single-thread mode (whose
// output does not depend on time), is refused in one line.
TEST(Replay, RealtimePacesTheRecordsAndRefusesWhatMeansNothing) {
  const fs::path dir = simulate("static", 3);
  const std::string base = std::string(RVWO_REPLAY) + " --quiet --settings " + (dir / "settings.yaml").string() +
                           " --rawlog " + (dir / "sequence.rawlog").string() + " --out " + (dir / "rt.txt").string();
  ASSERT_EQ(std::system((base + " --realtime 1.5 > " + (dir / "rt.stdout").string()).c_str()), 0);
  const std::string report = slurp(dir / "rt.stdout");
  double data = 0, wall = 0, x = 0;
  const std::size_t at = report.find("speed: ");
  ASSERT_NE(at, std::string::npos) << report;
  ASSERT_EQ(std::sscanf(report.c_str() + at, "speed: %lf s of data in %lf s: %lfx real time", &data, &wall, &x), 3)
      << report;
  EXPECT_GT(data, 2.9);
  EXPECT_GE(wall, data / 1.5 - 0.05) << report;  // the first record's wait is none: a frame's period of slack
  EXPECT_EQ(lines(dir / "rt.txt"), lines(dir / "groundtruth.txt"));
  for (const char* flat_out : {"--realtime 0", "--realtime 0 --deterministic"}) {
    fs::remove(dir / "rt.txt");
    EXPECT_EQ(std::system((base + " " + flat_out + " > " + (dir / "rt0.stdout").string()).c_str()), 0) << flat_out;
    EXPECT_EQ(lines(dir / "rt.txt"), lines(dir / "groundtruth.txt")) << flat_out;
  }
  for (const auto& [args, line] : std::vector<std::pair<std::string, std::string>>{
           {"--realtime -2",
            "rvwo-replay: error: --realtime must be a speed-up above 0 (1: as recorded) or 0 (as fast as it goes)\n"},
           {"--realtime 1 --deterministic",
            "rvwo-replay: error: --realtime paces the threads; --deterministic has none (its output does not depend "
            "on time): give one of the two\n"}}) {
    EXPECT_NE(std::system((base + " " + args + " 2> " + (dir / "e.txt").string()).c_str()), 0) << args;
    EXPECT_EQ(slurp(dir / "e.txt"), line) << args;
  }
  fs::remove_all(dir);
}

// Runs rvwo-replay on dir's sequence with dir's settings file `settings` and `args`; returns the
// exit status, stdout and stderr in out and err (--rawlog: dir's sequence unless args give one).
// prefix goes before the command (a timeout).
int replayRaw(const fs::path& dir, const std::string& settings, const std::string& args, std::string* out,
              std::string* err, const std::string& prefix = "") {
  const std::string rawlog =
      args.find("--rawlog") == std::string::npos ? " --rawlog " + (dir / "sequence.rawlog").string() : "";
  const std::string cmd = prefix + std::string(RVWO_REPLAY) + " --quiet --settings " + (dir / settings).string() +
                          rawlog + " " + args + " > " + (dir / "raw.stdout").string() + " 2> " +
                          (dir / "raw.stderr").string();
  const int rc = std::system(cmd.c_str());
  *out = slurp(dir / "raw.stdout");
  *err = slurp(dir / "raw.stderr");
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// An output that is an input (by its path, a symbolic link or a hard link), in a folder that is
// not there, or a folder itself, and a --gt that cannot be read: one line before any work (nothing
// on stdout), no input changed, nothing written.
TEST(Replay, OutputsAreCheckedBeforeTheReplayAndAreNeverAnInput) {
  const fs::path dir = simulate("static", 2);
  const std::string rawlog = (dir / "sequence.rawlog").string(), settings = (dir / "settings.yaml").string(),
                    gt = (dir / "groundtruth.txt").string();
  const std::string rawlog_bytes = slurp(rawlog), settings_bytes = slurp(settings), gt_bytes = slurp(gt);
  fs::create_symlink(dir / "settings.yaml", dir / "link.yaml");
  fs::create_hard_link(dir / "groundtruth.txt", dir / "hard.txt");
  const std::string e = "rvwo-replay: error: ";
  for (const auto& [args, line] : std::vector<std::pair<std::string, std::string>>{
           {"--out " + rawlog, e + "--out " + rawlog + " is the --rawlog input: give the output another path\n"},
           {"--out " + settings, e + "--out " + settings + " is the --settings input: give the output another path\n"},
           {"--out " + (dir / "link.yaml").string(),
            e + "--out " + (dir / "link.yaml").string() + " is the --settings input: give the output another path\n"},
           {"--out " + (dir / "t.txt").string() + " --gt " + gt + " --plot " + (dir / "hard.txt").string(),
            e + "--plot " + (dir / "hard.txt").string() + " is the --gt input: give the output another path\n"},
           {"--out " + (dir / "t.txt").string() + " --plot " + (dir / "t.txt").string(),
            e + "--plot " + (dir / "t.txt").string() + " is the --out file: give the plot another path\n"},
           {"--out " + (dir / "no" / "t.txt").string(), e + "--out " + (dir / "no" / "t.txt").string() +
                                                            ": no folder " + (dir / "no").string() +
                                                            " (make it, or give another path)\n"},
           {"--out " + (dir / "sequence_Images").string(),
            e + "--out " + (dir / "sequence_Images").string() + " is a folder: give a file name\n"},
           {"--out " + (dir / "t.txt").string() + " --gt " + (dir / "none.txt").string(),
            e + (dir / "none.txt").string() + ": cannot be read\n"}}) {
    std::string out, err;
    EXPECT_EQ(replayRaw(dir, "settings.yaml", "--deterministic " + args, &out, &err), 1) << args;
    EXPECT_EQ(err, line) << args;
    EXPECT_EQ(out, "") << args;
  }
  EXPECT_EQ(slurp(rawlog), rawlog_bytes);
  EXPECT_EQ(slurp(settings), settings_bytes);
  EXPECT_EQ(slurp(gt), gt_bytes);
  EXPECT_FALSE(fs::exists(dir / "t.txt"));
  EXPECT_FALSE(fs::exists(dir / "t.png"));
  fs::remove_all(dir);
}

// A camera or odometry label the rawlog does not have: one line before any work, listing what the
// file has and naming the setting; --mode vo needs no odometry.
TEST(Replay, MissingSensorsAreNamedWithWhatTheFileHas) {
  const fs::path dir = simulate("static", 2);
  const std::string settings = slurp(dir / "settings.yaml");
  std::ofstream(dir / "nocam.yaml") << settings << "Rawlog.CameraLabel: \"FRONT\"\n";
  std::ofstream(dir / "noodo.yaml") << settings << "Rawlog.OdometryLabel: \"WHEELS\"\n";
  const std::string has = "the file has ODOMETRY: CObservationOdometry x ";
  const std::string out_arg = " --deterministic --out " + (dir / "t.txt").string();
  std::string out, err;
  EXPECT_EQ(replayRaw(dir, "nocam.yaml", out_arg, &out, &err), 1);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err.rfind("rvwo-replay: error: " + (dir / "sequence.rawlog").string() +
                          ": no camera frames (sensor label 'FRONT'; " + has,
                      0),
            0u)
      << err;
  EXPECT_NE(err.find("CAMERA: CObservationStereoImages x 6"), std::string::npos) << err;  // 2 s at 30 Hz
  EXPECT_NE(err.find("): set Rawlog.CameraLabel in " + (dir / "nocam.yaml").string() + "\n"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_EQ(replayRaw(dir, "noodo.yaml", out_arg, &out, &err), 1);
  EXPECT_EQ(out, "");
  EXPECT_NE(err.find(": no odometry (sensor label 'WHEELS'; " + has), std::string::npos) << err;
  EXPECT_NE(err.find("): set Rawlog.OdometryLabel in " + (dir / "noodo.yaml").string() + ", or run --mode vo\n"),
            std::string::npos)
      << err;
  EXPECT_EQ(replayRaw(dir, "noodo.yaml", out_arg + " --mode vo", &out, &err), 0) << err;
  EXPECT_EQ(lines(dir / "t.txt"), lines(dir / "groundtruth.txt"));
  fs::remove_all(dir);
}

// --mode vw with odometry none of which can be used (encoder ticks asked of a rawlog whose
// readings carry none) is an error, not a vision-only run.
TEST(Replay, VwWithoutUsableOdometryIsAnError) {
  const fs::path dir = simulate("static", 2);
  {
    RawlogReader in((dir / "sequence.rawlog").string());
    RawlogWriter out((dir / "noticks.rawlog").string());
    while (auto o = in.next()) {
      if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(*o)) od->hasEncodersInfo = false;
      out.write(**o);
    }
  }
  fs::create_directory_symlink(dir / "sequence_Images", dir / "noticks_Images");
  const std::string rawlog = (dir / "noticks.rawlog").string();
  std::string out, err;
  const int rc = replayRaw(dir, "settings.yaml",
                           "--deterministic --rawlog " + rawlog + " --out " + (dir / "t.txt").string(), &out, &err);
  EXPECT_EQ(rc, 1);
  const std::string last = err.substr(err.rfind('\n', err.size() - 2) + 1);
  EXPECT_EQ(last.rfind("rvwo-replay: error: " + rawlog + ": none of the ", 0), 0u) << err;
  EXPECT_NE(last.find(" odometry records could be used (see the lines above): fix them, or run --mode vo\n"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("no encoder ticks (Odometry.Input is encoders)"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "t.txt"));
  fs::remove_all(dir);
}

// SIGINT, SIGTERM or SIGHUP stop the replay at the frame it is on: the trajectory and the report
// of what it has are written (a stale file at --out replaced), one line says so, and the exit
// status is 128 + the signal's number. No partial file is left.
TEST(Replay, InterruptedWritesWhatItHasAndExitsWithTheSignal) {
  const fs::path dir = simulate("static", 8);
  const std::size_t all = lines(dir / "groundtruth.txt");
  for (const auto& [name, status] :
       std::vector<std::pair<std::string, int>>{{"INT", 130}, {"TERM", 143}, {"HUP", 129}}) {
    std::ofstream(dir / "t.txt") << "stale\n";
    std::string out, err;
    // As recorded (8 s), stopped after 5 s.
    const int rc = replayRaw(dir, "settings.yaml", "--realtime 1 --out " + (dir / "t.txt").string(), &out, &err,
                             "timeout --preserve-status -s " + name + " 5 ");
    EXPECT_EQ(rc, status) << name << ": " << err;
    const std::string line = "rvwo-replay: interrupted (SIG" + name + ") at t = ";
    EXPECT_EQ(err.rfind(line, 0), 0u) << err;
    EXPECT_NE(err.find(" frames before it are written to " + (dir / "t.txt").string() + "\n"), std::string::npos)
        << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    const Trajectory t = readTum((dir / "t.txt").string());
    EXPECT_GT(t.size(), 10u) << name;
    EXPECT_LT(t.size(), all) << name;
    std::size_t frames = 0;
    ASSERT_EQ(std::sscanf(err.c_str() + err.find(" s: the ") + 8, "%zu", &frames), 1) << err;
    EXPECT_EQ(frames, t.size()) << name;
    EXPECT_NE(out.find("  trajectory: " + (dir / "t.txt").string()), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / ".t.partial.txt"));
    EXPECT_FALSE(fs::exists(dir / ".t.partial.png"));
  }
  fs::remove_all(dir);
}

// The faults, each in one record: a camera time corrupted to 1.8e12 s, odometry 1000 m
// off (read as poses), encoder ticks that jump by 1e6 or back by 5000 (read as ticks). Each is
// skipped with a line naming it; every other frame keeps its pose, within 1 cm of the truth.
TEST(Replay, FaultyRecordsAreSkippedNotBelieved) {
  const fs::path dir = simulate("static", 4);
  {
    RawlogReader in((dir / "sequence.rawlog").string());
    RawlogWriter out((dir / "faulty.rawlog").string());
    int frames = 0, odometry = 0;
    while (auto o = in.next()) {
      if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(*o)) {
        ++odometry;
        if (odometry == 100) od->odometry.x(od->odometry.x() + 1000.0);
        if (odometry == 150) od->encoderLeftTicks += 1000000;
        if (odometry == 200) od->encoderRightTicks -= 5000;
      } else if ((*o)->sensorLabel == "CAMERA" && ++frames == 40) {
        (*o)->timestamp = mrpt::Clock::fromDouble(1.8e12);
      }
      out.write(**o);
    }
  }
  fs::create_directory_symlink(dir / "sequence_Images", dir / "faulty_Images");
  std::ofstream(dir / "poses.yaml") << slurp(dir / "settings.yaml") << "Odometry.Input: \"pose\"\n";
  const Trajectory gt = readTum((dir / "groundtruth.txt").string());
  for (const std::string settings : {"settings.yaml", "poses.yaml"}) {
    std::string out, err;
    const int rc =
        replayRaw(dir, settings,
                  "--deterministic --rawlog " + (dir / "faulty.rawlog").string() + " --out " + (dir / "t.txt").string(),
                  &out, &err);
    ASSERT_EQ(rc, 0) << settings << ": " << err;
    EXPECT_NE(err.find("skipped frame at t = 1800000000000.000000: its time jumps "), std::string::npos) << err;
    if (settings == "poses.yaml") {
      EXPECT_NE(err.find(": a speed of 1e+05 m/s over "), std::string::npos) << err;
      EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 2) << err;
    } else {
      EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 3) << err;
      EXPECT_EQ(err.find("m/s over ") != std::string::npos, true) << err;
    }
    const Trajectory est = readTum((dir / "t.txt").string());
    EXPECT_EQ(est.size(), gt.size() - 1) << settings;
    const auto pairs = associate(gt, est, 0.005);
    EXPECT_EQ(pairs.size(), gt.size() - 1);
    EXPECT_LT(ate(gt, est, pairs, Alignment::kSE3).stats.max, 0.01) << settings;
  }
  fs::remove_all(dir);
}

// Label images of another size than the camera's are not looked up: each such keyframe is
// counted and named; when none could use its labels the run is an error (its trajectory written).
TEST(Replay, LabelImagesOfAnotherSizeAreNotUsed) {
  const fs::path dir = simulate("static", 3);
  for (const std::string name : {"small", "some_small"}) {
    RawlogReader in((dir / "sequence.rawlog").string());
    RawlogWriter out((dir / (name + ".rawlog")).string());
    int labels = 0;
    while (auto o = in.next()) {
      auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(*o);
      if (im && im->sensorLabel == "LABELS" && (name == "small" || ++labels % 2 == 0)) {
        cv::Mat half;
        cv::resize(loadImage(im->image, cv::IMREAD_UNCHANGED), half, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
        im->image = mrpt::img::CImage(half, mrpt::img::DEEP_COPY);
      }
      out.write(**o);
    }
    fs::create_directory_symlink(dir / "sequence_Images", dir / (name + "_Images"));
  }
  std::string out, err;
  const std::string traj = (dir / "t.txt").string();
  EXPECT_EQ(replayRaw(dir, "settings.yaml",
                      "--deterministic --rawlog " + (dir / "small.rawlog").string() + " --out " + traj, &out, &err),
            1);
  EXPECT_EQ(err.rfind("rvwo-replay: error: no keyframe could use its labels (", 0), 0u) << err;
  EXPECT_NE(err.find(": label image 320x240 for a camera image 640x480): the run went without semantics (its "
                     "trajectory is written to " +
                     traj + ")\n"),
            std::string::npos)
      << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(out.find("keyframes whose labels could not be used: "), std::string::npos) << out;
  EXPECT_EQ(lines(traj), lines(dir / "groundtruth.txt"));
  EXPECT_EQ(
      replayRaw(dir, "settings.yaml",
                "--deterministic --rawlog " + (dir / "some_small.rawlog").string() + " --out " + traj, &out, &err),
      0)
      << err;
  EXPECT_EQ(err.rfind("rvwo-replay: warning: ", 0), 0u) << err;
  EXPECT_NE(err.find(" keyframes could not use their labels (the first: keyframe at t = "), std::string::npos) << err;
  fs::remove_all(dir);
}

TEST(Replay, BadInputGetsOneClearLine) {
  const fs::path dir = simulate("static", 3);
  // A missing settings key.
  {
    std::string s = slurp(dir / "settings.yaml");
    std::ofstream(dir / "no_fx.yaml") << s.replace(s.find("Camera1.fx"), 10, "Camera1.fz");
    const std::string cmd = std::string(RVWO_REPLAY) + " --settings " + (dir / "no_fx.yaml").string() + " --rawlog " +
                            (dir / "sequence.rawlog").string() + " --out " + (dir / "x.txt").string() + " 2> " +
                            (dir / "e.txt").string();
    EXPECT_NE(std::system(cmd.c_str()), 0);
    EXPECT_EQ(slurp(dir / "e.txt"),
              "rvwo-replay: error: " + (dir / "no_fx.yaml").string() + ": missing key Camera1.fx\n");
  }
  // Odometry going backwards (NaN: tests/plugins/estimator_test.cc): the record are skipped with a line each, the rest
  // runs.
  {
    RawlogReader in((dir / "sequence.rawlog").string());
    RawlogWriter out((dir / "bad_odometry.rawlog").string());
    int odometry = 0;
    while (auto o = in.next()) {
      if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(*o)) {
        ++odometry;
        if (odometry == 50) od->timestamp = mrpt::Clock::fromDouble(0.1);  // backwards
      }
      out.write(**o);
    }
  }
  fs::copy(dir / "sequence_Images", dir / "bad_odometry_Images", fs::copy_options::recursive);
  const std::string base = std::string(RVWO_REPLAY) + " --quiet --settings " + (dir / "settings.yaml").string() +
                           " --deterministic --out " + (dir / "y.txt").string() + " --rawlog ";
  EXPECT_EQ(
      std::system(
          (base + (dir / "bad_odometry.rawlog").string() + " > /dev/null 2> " + (dir / "e2.txt").string()).c_str()),
      0);
  EXPECT_NE(slurp(dir / "e2.txt").find("skipped odometry at t = 0.100000"), std::string::npos) << slurp(dir / "e2.txt");
  EXPECT_EQ(lines(dir / "y.txt"), lines(dir / "groundtruth.txt"));
  // A bit flipped inside the gz stream: refused before any record, nothing written.
  {
    std::string bytes = slurp(dir / "sequence.rawlog");
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x04);
    std::ofstream(dir / "flipped.rawlog", std::ios::binary) << bytes;
    fs::create_directory_symlink(dir / "sequence_Images", dir / "flipped_Images");
    fs::remove(dir / "f.txt");
    const std::string f = std::string(RVWO_REPLAY) + " --quiet --settings " + (dir / "settings.yaml").string() +
                          " --deterministic --out " + (dir / "f.txt").string() + " --rawlog " +
                          (dir / "flipped.rawlog").string() + " > " + (dir / "f.stdout").string() + " 2> " +
                          (dir / "f.stderr").string();
    EXPECT_EQ(WEXITSTATUS(std::system(f.c_str())), 1);
    const std::string e = slurp(dir / "f.stderr");
    EXPECT_EQ(e.rfind("rvwo-replay: error: " + (dir / "flipped.rawlog").string() + ": damaged (zlib: ", 0), 0u) << e;
    EXPECT_NE(e.find("): no record of it can be trusted; nothing replayed (copy it again from its source)\n"),
              std::string::npos)
        << e;
    EXPECT_EQ(slurp(dir / "f.stdout"), "");
    EXPECT_FALSE(fs::exists(dir / "f.txt"));
  }
  // A truncated rawlog: the error names the record, the frames before it are written, exit 1.
  {
    const std::string bytes = slurp(dir / "sequence.rawlog");
    std::ofstream(dir / "cut.rawlog", std::ios::binary) << bytes.substr(0, bytes.size() * 2 / 3);
    fs::create_directory_symlink(dir / "sequence_Images", dir / "cut_Images");
  }
  const int rc =
      std::system((base + (dir / "cut.rawlog").string() + " > /dev/null 2> " + (dir / "e3.txt").string()).c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 1);
  const std::string e3 = slurp(dir / "e3.txt");
  EXPECT_NE(e3.find("rvwo-replay: error: "), std::string::npos) << e3;
  EXPECT_NE(e3.find(": record "), std::string::npos) << e3;
  EXPECT_GT(lines(dir / "y.txt"), 20u);
  EXPECT_LT(lines(dir / "y.txt"), lines(dir / "groundtruth.txt"));
  // A rawlog copied without its images folder: ten skips shown, and an error naming the folder
  // (OpenCV's own warning for each missing file stays silent).
  fs::copy_file(dir / "sequence.rawlog", dir / "moved.rawlog");
  const int rc4 =
      std::system((base + (dir / "moved.rawlog").string() + " > /dev/null 2> " + (dir / "e4.txt").string()).c_str());
  EXPECT_EQ(WEXITSTATUS(rc4), 1);
  const std::string e4 = slurp(dir / "e4.txt");
  EXPECT_LE(lines(dir / "e4.txt"), 12u) << e4;
  EXPECT_NE(e4.find("rvwo-replay: error: " + (dir / "moved.rawlog").string() + ": no camera frame could be used ("),
            std::string::npos)
      << e4;
  EXPECT_NE(e4.find("no folder " + (dir / "moved_Images").string()), std::string::npos) << e4;
  // An empty one.
  std::ofstream(dir / "empty.rawlog").close();
  std::system((base + (dir / "empty.rawlog").string() + " > /dev/null 2> " + (dir / "e5.txt").string()).c_str());
  EXPECT_EQ(slurp(dir / "e5.txt"),
            "rvwo-replay: error: " + (dir / "empty.rawlog").string() + ": no records (an empty rawlog)\n");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rvwo::apps
