// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-replay's behaviour as a program on short simulated sequences (rvwo-sim, fixed seeds): its
// pace, its outputs, its sensors; bad input gets one clear line, a non-zero exit, and the output
// already estimated is kept. The accuracy tests are in replay_accuracy_test.cc.
#include <gtest/gtest.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "replay_common.h"
#include "support/rawlog.h"
#include "support/trajectory.h"

namespace rvwo::apps::test {
namespace {

// The simulated sequence in dir rewritten as <name>.rawlog, each record through edit first (it
// may change the record), its images linked as <name>_Images unless link_images is false.
fs::path rewritten(const fs::path& dir, const std::string& name,
                   const std::function<void(mrpt::obs::CObservation::Ptr&)>& edit, bool link_images = true) {
  const fs::path rawlog = dir / (name + ".rawlog");
  {
    RawlogReader in((dir / "sequence.rawlog").string());
    RawlogWriter out(rawlog.string());
    while (auto o = in.next()) {
      edit(*o);
      out.write(**o);
    }
  }
  if (link_images) fs::create_directory_symlink(dir / "sequence_Images", dir / (name + "_Images"));
  return rawlog;
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
  // The report's map line: what memory holds at the end (Estimator.KeepKeyFrames, 14, at most),
  // and every keyframe made either there or retired.
  const std::string flat = slurp(dir / "rt0.stdout");
  std::size_t made = 0, kfs = 0, points = 0, retired = 0;
  ASSERT_EQ(std::sscanf(flat.c_str() + flat.find("keyframes "), "keyframes %zu", &made), 1) << flat;
  ASSERT_EQ(std::sscanf(flat.c_str() + flat.find("map at the end: "),
                        "map at the end: %zu keyframes and %zu points in memory, %zu keyframes retired", &kfs, &points,
                        &retired),
            3)
      << flat;
  EXPECT_EQ(kfs, std::min<std::size_t>(made, 14)) << flat;
  EXPECT_EQ(kfs + retired, made) << flat;
  EXPECT_GT(points, 500u) << flat;
  EXPECT_NE(flat.find("timings [ms]     mean     p50     p95     max   count\n"), std::string::npos) << flat;
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

// A sensor under a label the settings do not name is taken when it is the file's only one of its
// class, and the replay says so: odometry relabelled WHEELS here; a real RGB-D frame written by
// MRPT's own grabber (label OPENNI2, ../shared) below. Named in the settings, a label is as given
// (the test above).
TEST(Replay, TheOnlySensorOfItsClassIsTakenUnderItsOwnLabel) {
  const fs::path dir = simulate("static", 2);
  rewritten(dir, "wheels", [](mrpt::obs::CObservation::Ptr& o) {
    if (o->sensorLabel == "ODOMETRY") o->sensorLabel = "WHEELS";
  });
  std::string out, err;
  const std::string rawlog = (dir / "wheels.rawlog").string();
  ASSERT_EQ(replayRaw(dir, "settings.yaml", "--deterministic --rawlog " + rawlog + " --out " + (dir / "t.txt").string(),
                      &out, &err),
            0)
      << err;
  EXPECT_EQ(out.rfind("rvwo-replay: " + rawlog +
                          ": sensor label 'WHEELS' (the file's only CObservationOdometry; Rawlog.OdometryLabel is "
                          "'ODOMETRY' by default)\n",
                      0),
            0u)
      << out;
  EXPECT_EQ(out.find("odometry records used"), std::string::npos) << "every reading used";
  EXPECT_EQ(lines(dir / "t.txt"), lines(dir / "groundtruth.txt"));
  fs::remove_all(dir);

  const std::string mrpt = std::string(RVWO_SHARED_DIR) + "/data/mrpt_rawlogs/rgbd_one_frame.rawlog";
  if (!fs::exists(mrpt)) GTEST_SKIP() << "../shared is absent: no rawlog of MRPT's RGB-D grabber";
  const fs::path d = rvwo::test::scratch("replay_openni2");
  fs::create_directories(d);
  std::ofstream(d / "rgbd.yaml") << "%YAML:1.0\nSensor: \"rgbd\"\nCamera1.fx: 525.0\nCamera1.fy: 525.0\n"
                                    "Camera1.cx: 319.5\nCamera1.cy: 239.5\nCamera.width: 640\nCamera.height: 480\n"
                                    "Camera.fps: 30\nRGBD.DepthMapFactor: 1000\nCamera.T_b_c: !!opencv-matrix\n"
                                    "   rows: 4\n   cols: 4\n   dt: d\n"
                                    "   data: [0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0, 1]\n";
  ASSERT_EQ(replayRaw(d, "rgbd.yaml", "--mode vo --rawlog " + mrpt + " --out " + (d / "t.txt").string(), &out, &err), 0)
      << err;
  EXPECT_EQ(out.rfind("rvwo-replay: " + mrpt +
                          ": sensor label 'OPENNI2' (the file's only CObservation3DRangeScan; Rawlog.CameraLabel is "
                          "'RGBD' by default)\n",
                      0),
            0u)
      << out;
  EXPECT_EQ(lines(d / "t.txt"), 1u);
  unsigned points = 0;
  ASSERT_EQ(std::sscanf(out.c_str() + out.find("map points made "), "map points made %u", &points), 1) << out;
  EXPECT_GT(points, 300u) << "the real frame's depth gives points";
  fs::remove_all(d);
}

// --mode vw with odometry none of which can be used (encoder ticks asked of a rawlog whose
// readings carry none) is an error, not a vision-only run.
TEST(Replay, VwWithoutUsableOdometryIsAnError) {
  const fs::path dir = simulate("static", 2);
  rewritten(dir, "noticks", [](mrpt::obs::CObservation::Ptr& o) {
    if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o)) od->hasEncodersInfo = false;
  });
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
  // Ticks without the wheels' size: refused before any work, not replayed at a default size.
  std::ifstream full(dir / "settings.yaml");
  std::ofstream cut(dir / "no_radius.yaml");
  for (std::string l; std::getline(full, l);)
    if (l.rfind("Odometry.WheelRadiusRight:", 0) != 0) cut << l << "\n";
  cut.close();
  EXPECT_EQ(replayRaw(dir, "no_radius.yaml", "--deterministic --out " + (dir / "t.txt").string(), &out, &err), 1);
  EXPECT_EQ(err, "rvwo-replay: error: " + (dir / "no_radius.yaml").string() +
                     ": missing key Odometry.WheelRadiusRight (m: Odometry.Input encoders becomes distance through "
                     "the wheels' size)\n");
  EXPECT_EQ(replayRaw(dir, "no_radius.yaml", "--deterministic --mode vo --out " + (dir / "t.txt").string(), &out, &err),
            0)
      << err;
  fs::remove_all(dir);
}

// SIGINT, SIGTERM or SIGHUP stop the replay at the frame it is on: the trajectory and the report
// of what it has are written (a stale file at --out replaced), one line says so, and the exit
// status is 128 + the signal's number. No partial file is left. The same signal again within a
// second is the same request: `timeout` sends it to the replay and then to its process group, and
// the last case sends it twice, 0.1 s apart (before, one such run in five died with no output).
TEST(Replay, InterruptedWritesWhatItHasAndExitsWithTheSignal) {
  const fs::path dir = simulate("static", 8);
  const std::size_t all = lines(dir / "groundtruth.txt");
  std::ofstream(dir / "twice.sh") << "\"$@\" & p=$!; sleep 5; kill -INT $p; sleep 0.1; kill -INT $p; wait $p\n";
  const auto timeout = [](const std::string& name) { return "timeout --preserve-status -s " + name + " 5 "; };
  for (const auto& [name, status, prefix] : std::vector<std::tuple<std::string, int, std::string>>{
           {"INT", 130, timeout("INT")},
           {"TERM", 143, timeout("TERM")},
           {"HUP", 129, timeout("HUP")},
           {"INT", 130, "sh " + (dir / "twice.sh").string() + " "}}) {
    std::ofstream(dir / "t.txt") << "stale\n";
    std::string out, err;
    // As recorded (8 s), stopped after 5 s.
    const int rc =
        replayRaw(dir, "settings.yaml", "--realtime 1 --out " + (dir / "t.txt").string(), &out, &err, prefix);
    EXPECT_EQ(rc, status) << prefix << ": " << err;
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
  int frames = 0, odometry = 0;
  rewritten(dir, "faulty", [&](mrpt::obs::CObservation::Ptr& o) {
    if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o)) {
      ++odometry;
      if (odometry == 100) od->odometry.x(od->odometry.x() + 1000.0);
      if (odometry == 150) od->encoderLeftTicks += 1000000;
      if (odometry == 200) od->encoderRightTicks -= 5000;
    } else if (o->sensorLabel == "CAMERA" && ++frames == 40) {
      o->timestamp = mrpt::Clock::fromDouble(1.8e12);
    }
  });
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

// An odometry counter that jumps and goes on from there (the pose 1000 m off, the encoder ticks
// +1e6 and -5e5 from the 150th reading on): the readings of the run before it agrees are skipped,
// then it is taken as a new origin, said in one line and in the report; every frame stays right.
TEST(Replay, AnOdometryJumpThatPersistsIsTakenAsANewOrigin) {
  const fs::path dir = simulate("static", 4);
  int odometry = 0;
  rewritten(dir, "restarted", [&](mrpt::obs::CObservation::Ptr& o) {
    if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o); od && ++odometry >= 150) {
      od->odometry.x(od->odometry.x() + 1000.0);
      od->encoderLeftTicks += 1000000;
      od->encoderRightTicks -= 500000;
    }
  });
  std::ofstream(dir / "poses.yaml") << slurp(dir / "settings.yaml") << "Odometry.Input: \"pose\"\n";
  const Trajectory gt = readTum((dir / "groundtruth.txt").string());
  for (const std::string settings : {"settings.yaml", "poses.yaml"}) {
    std::string out, err;
    const int rc = replayRaw(
        dir, settings,
        "--deterministic --rawlog " + (dir / "restarted.rawlog").string() + " --out " + (dir / "t.txt").string(), &out,
        &err);
    ASSERT_EQ(rc, 0) << settings << ": " << err;
    // OdometryGate::kRestartReadings - 1 readings skipped, then the restart.
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 5) << err;
    EXPECT_NE(err.find("rvwo-replay: odometry restarted at t = "), std::string::npos) << err;
    EXPECT_NE(out.find("  odometry restarts taken as a new origin: 1 (see stderr)\n"), std::string::npos) << out;
    const Trajectory est = readTum((dir / "t.txt").string());
    const auto pairs = associate(gt, est, 0.005);
    EXPECT_EQ(pairs.size(), gt.size()) << settings;
    EXPECT_LT(ate(gt, est, pairs, Alignment::kSE3).stats.max, 0.01) << settings;
  }
  fs::remove_all(dir);
}

// Label images of another size than the camera's are not looked up: each such keyframe is
// counted and named; when none could use its labels the run is an error (its trajectory written).
TEST(Replay, LabelImagesOfAnotherSizeAreNotUsed) {
  const fs::path dir = simulate("static", 3);
  for (const std::string name : {"small", "some_small"}) {
    int labels = 0;
    rewritten(dir, name, [&](mrpt::obs::CObservation::Ptr& o) {
      auto im = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(o);
      if (im && im->sensorLabel == "LABELS" && (name == "small" || ++labels % 2 == 0)) {
        cv::Mat half;
        cv::resize(loadImage(im->image, cv::IMREAD_UNCHANGED), half, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
        im->image = mrpt::img::CImage(half, mrpt::img::DEEP_COPY);
      }
    });
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
  int odometry = 0;
  rewritten(
      dir, "bad_odometry",
      [&](mrpt::obs::CObservation::Ptr& o) {
        if (std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(o) && ++odometry == 50)
          o->timestamp = mrpt::Clock::fromDouble(0.1);  // backwards
      },
      false);
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
}  // namespace rvwo::apps::test
