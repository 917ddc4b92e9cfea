// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The simulator: rendered corners where the ground-truth landmarks project (within 0.5 px), wheel
// odometry statistics against the configured error model (Monte Carlo), slip, a real trajectory
// with its tilted plane fitted away, scenario errors, and same seed, same bytes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <set>

#include "../common/temp.h"
#include "rvwo/settings/settings.h"
#include "sim/odometry.h"
#include "sim/people.h"
#include "sim/randomise.h"
#include "sim/scenario.h"
#include "sim/scene.h"

namespace rvwo::sim {
namespace {

namespace fs = std::filesystem;

Scenario scenarioFrom(const std::string& yaml, const std::string& name = "s") {
  const fs::path p = rvwo::test::scratch("rvwo_sim_" + name + ".yaml");
  std::ofstream(p) << "%YAML:1.0\n" << yaml;
  return loadScenario(p.string());
}

TEST(Simulator, LandmarksProjectOntoRenderedCorners) {
  const Scene scene(10, 8, 2.6, 3, 6);
  const PinholeCamera cam(400, 400, 319.5, 239.5);
  const cv::Mat rays = Scene::rayTable(cam, 640, 480);
  const RenderOptions o;
  int checked = 0;
  double worst = 0;
  std::vector<double> dists;
  Eigen::Vector2d mean_offset = Eigen::Vector2d::Zero();  // a pixel-centre slip would show here
  for (int view = 0; view < 4; ++view) {
    Eigen::Matrix3d R_w_c;  // looking at one wall after the other, level
    const double yaw = view * M_PI / 2;
    R_w_c << -std::sin(yaw), 0, std::cos(yaw), std::cos(yaw), 0, std::sin(yaw), 0, -1, 0;
    Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
    T_w_c.linear() = R_w_c;
    T_w_c.translation() << 0.3, -0.2, 1.2;
    const Render r = scene.render(T_w_c, rays, 0.0, o);
    cv::Mat grey, img;  // a perfect camera's image: the light quantised, no noise
    r.radiance.convertTo(grey, CV_8U);
    grey.convertTo(img, CV_32F);
    std::vector<Eigen::Vector2d> all;  // every landmark in front of the camera, projected
    for (const Eigen::Vector3d& L : scene.landmarks()) {
      const Eigen::Vector3d P = T_w_c.inverse() * L;
      if (P.z() > 0.1) all.push_back(cam.project(P));
    }
    for (std::size_t i = 0; i < scene.landmarks().size(); ++i) {
      const Eigen::Vector3d& L = scene.landmarks()[i];
      const Eigen::Vector3d P = T_w_c.inverse() * L;
      if (P.z() < 1.0 || P.z() > 4.0) continue;
      // Seen within 45 degrees of head-on: no texture minification (the renderer has no mipmaps),
      // so the imaged corner is sharp.
      const Eigen::Vector3d view = (L - T_w_c.translation()).normalized();
      if (scene.landmarkNormals()[i].dot(view) > -0.7) continue;
      const Eigen::Vector2d uv = cam.project(P);
      if (uv.x() < 10 || uv.y() < 10 || uv.x() > 629 || uv.y() > 469) continue;
      // Visible, and the refinement window lies on its surface alone (not across a box's edge or
      // an occluding border): depth continuous over it.
      const cv::Rect around(cvRound(uv.x()) - 5, cvRound(uv.y()) - 5, 11, 11);
      double dmin, dmax;
      cv::minMaxLoc(r.depth(around), &dmin, &dmax);
      if (dmin < P.z() - 0.15 || dmax > P.z() + 0.15) continue;
      // An isolated corner: no other landmark within 10 px, so the refinement window holds one.
      int near = 0;
      for (const Eigen::Vector2d& q : all) near += (q - uv).norm() < 10.0;
      if (near > 1) continue;
      // A clean L-corner: probes at the window's four diagonals read three of one shade and one of
      // the other (>= 40 apart), and the window holds nothing but those two shades beyond the
      // blurred edges (no neighbouring rectangle or room edge to pull the refinement away).
      const int cx = cvRound(uv.x()), cy = cvRound(uv.y());
      int probe[4] = {grey.at<uint8_t>(cy - 4, cx - 4), grey.at<uint8_t>(cy - 4, cx + 4),
                      grey.at<uint8_t>(cy + 4, cx - 4), grey.at<uint8_t>(cy + 4, cx + 4)};
      std::sort(probe, probe + 4);
      const bool three_low = probe[2] - probe[0] <= 6 && probe[3] - probe[2] >= 40;
      const bool three_high = probe[3] - probe[1] <= 6 && probe[1] - probe[0] >= 40;
      if (!three_low && !three_high) continue;
      const int lo = probe[0], hi = probe[3];
      int other = 0;
      const cv::Mat win = grey(cv::Rect(cx - 5, cy - 5, 11, 11));
      for (int yy = 0; yy < win.rows; ++yy) {
        for (int xx = 0; xx < win.cols; ++xx) {
          const int g = win.at<uint8_t>(yy, xx);
          other += std::abs(g - lo) > 6 && std::abs(g - hi) > 6;
        }
      }
      if (other > 24) continue;  // more than the two blurred edge lines
      std::vector<cv::Point2f> c = {cv::Point2f(static_cast<float>(uv.x() + 0.7), static_cast<float>(uv.y() - 0.6))};
      cv::cornerSubPix(img, c, cv::Size(3, 3), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
      const double d = std::hypot(c[0].x - uv.x(), c[0].y - uv.y());
      mean_offset += Eigen::Vector2d(c[0].x - uv.x(), c[0].y - uv.y());
      worst = std::max(worst, d);
      ++checked;
      dists.push_back(d);
      if (d > 0.5 && std::getenv("RVWO_DEBUG_CORNERS")) {
        std::cout << "outlier view " << view << " uv " << uv.transpose() << " z " << P.z() << " refined " << c[0]
                  << " n " << scene.landmarkNormals()[i].transpose() << "\n"
                  << grey(cv::Rect(cvRound(uv.x()) - 4, cvRound(uv.y()) - 4, 9, 9)) << "\n";
      }
    }
  }
  std::sort(dists.begin(), dists.end());
  std::cout << "median " << dists[dists.size() / 2] << " p90 " << dists[dists.size() * 9 / 10] << " p99 "
            << dists[dists.size() * 99 / 100] << "\n";
  mean_offset /= checked;
  std::cout << "mean offset " << mean_offset.transpose() << " px\n";
  EXPECT_LT(mean_offset.norm(), 0.1);
  EXPECT_GT(checked, 200);
  EXPECT_LT(worst, 0.5) << "over " << checked << " corners";
  std::cout << checked << " corners, worst distance from the projected landmark " << worst << " px\n";
}

// A walker wearing a real person: upright on the floor, at the size they were photographed, their
// silhouette (the cut-out's alpha) labelled; the odd looks mirrored.
TEST(Simulator, PeopleStandOnTheFloorAtTheirPhotographedSize) {
  const PinholeCamera cam(400, 400, 319.5, 239.5);
  const cv::Mat rays = Scene::rayTable(cam, 640, 480);
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();  // level, looking along +x from 1.2 m up
  T_w_c.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T_w_c.translation() << -2.0, 0.0, 1.2;
  const double distance = 3.0;
  ASSERT_GE(peopleLooks(), 4);
  std::vector<cv::Mat> labels;
  for (int look = 0; look < 2; ++look) {
    Scene scene(10, 8, 2.6, 3, 0);
    Walker w;
    w.a = w.b = Eigen::Vector2d(-2.0 + distance, 0.0);
    w.look = look;
    scene.addWalker(w);
    labels.push_back(scene.render(T_w_c, rays, 0.0, RenderOptions()).labels == 15);
  }
  const Person& p = people()[0];
  const cv::Rect box = cv::boundingRect(labels[0]);
  const double scale = 400 * p.metres / distance / p.alpha.rows;  // image pixels per cut-out pixel
  EXPECT_NEAR(box.height, p.alpha.rows * scale, 2.0);
  EXPECT_NEAR(box.y + box.height, 239.5 + 400 * 1.2 / distance, 1.5);  // the feet on the floor
  EXPECT_NEAR(box.x + 0.5 * box.width, 319.5, 0.5 * scale * p.alpha.cols + 1);
  EXPECT_NEAR(cv::countNonZero(labels[0]) / (scale * scale * cv::countNonZero(p.alpha)), 1.0, 0.03);
  cv::Mat flipped;
  cv::flip(labels[1], flipped, 1);
  const cv::Rect fbox = cv::boundingRect(flipped);
  EXPECT_NEAR(fbox.x, box.x, 1);
  EXPECT_NEAR(cv::countNonZero(flipped & labels[0]) / static_cast<double>(cv::countNonZero(labels[0])), 1.0, 0.05);
}

TEST(Simulator, OdometryErrorStatisticsMatchTheModel) {
  // A straight 10 m run at 0.5 m/s, 50 Hz encoders; 400 runs.
  const Scenario s = scenarioFrom(
      "Sequence.Duration: 20.0\nSequence.Motion: \"loop\"\nSequence.LoopSpeed: 0.5\nRoom.SizeX: 40\nRoom.SizeY: 8\n"
      "Odometry.RadiusError: 0.01\nOdometry.TrackError: 0.0\nOdometry.NoiseWheel: 0.01\nOdometry.TicksPerRevolution: "
      "100000\n",
      "straight");
  const Motion m(s);  // the loop's first straight is 40 - 4 - 2 = 34 m: 20 s stay on it
  const double D = 10.0, e = 0.01, r = OdometrySimulator::kRadius, b = OdometrySimulator::kTrack;
  std::vector<double> heading, dist;
  for (unsigned seed = 1; seed <= 400; ++seed) {
    OdometrySimulator odo(s, m, seed);
    OdometryReading last;
    for (int k = 1; k <= 1000; ++k) last = odo.step(0.02 * k);
    heading.push_back(last.pose.angle());
    dist.push_back(last.pose.log().head<2>().norm());
  }
  auto meanStd = [](const std::vector<double>& v) {
    double m = 0, s2 = 0;
    for (double x : v) m += x / v.size();
    for (double x : v) s2 += (x - m) * (x - m) / (v.size() - 1);
    return std::make_pair(m, std::sqrt(s2));
  };
  const auto [mh, sh] = meanStd(heading);
  const auto [md, sd] = meanStd(dist);
  // Closed forms (sim/odometry.h): wheel angles Q_l = D / (r (1 + e)), Q_r = D / (r (1 - e)).
  const double ql = D / (r * (1 + e)), qr = D / (r * (1 - e));
  const double want_heading = 2 * e * D / ((1 - e * e) * b);
  const double want_sh = r * 0.01 * std::sqrt(ql + qr) / b;
  EXPECT_NEAR(mh, want_heading, 4 * want_sh / std::sqrt(400.0)) << "systematic heading drift from unequal radii";
  EXPECT_NEAR(sh / want_sh, 1.0, 0.1) << "heading spread from the wheel noise density";
  EXPECT_NEAR(md, D / (1 - e * e), 0.02);
  EXPECT_GT(sd, 0.0);
}

TEST(Simulator, SlipTurnsTheWheelsWhileTheRobotStays) {
  const Scenario s =
      scenarioFrom("Sequence.Duration: 10.0\nEvents.Slip: [2.0, 4.0]\nOdometry.NoiseWheel: 0.0\n", "slip");
  const Motion m(s);
  EXPECT_EQ(motionTime(s, 3.0), 2.0);
  EXPECT_EQ(motionTime(s, 6.0), 4.0);
  OdometrySimulator odo(s, m, 1);
  OdometryReading a, b;
  for (int k = 1; k <= 200; ++k) a = odo.step(0.01 * k);    // to t = 2
  for (int k = 201; k <= 400; ++k) b = odo.step(0.01 * k);  // slipping until t = 4
  const double moved = (b.pose.translation() - a.pose.translation()).norm();
  EXPECT_NEAR(moved, 2.0 * s.loop_speed, 0.02) << "the wheels report the commanded motion";
  EXPECT_LT((m.at(motionTime(s, 4.0)).translation() - m.at(motionTime(s, 2.0)).translation()).norm(), 1e-12);
}

TEST(Simulator, RealTrajectoryWithTiltedPlaneFitted) {
  const std::string file = std::string(RVWO_SHARED_DIR) + "/data/trajectories/tum_fr2_pioneer_360.txt";
  if (!fs::exists(file)) GTEST_SKIP() << "../shared is absent: no real trajectory";
  const Scenario s = scenarioFrom(
      "Sequence.Duration: 60.0\nSequence.Motion: \"file\"\nSequence.MotionFile: \"" + file + "\"\n", "pioneer");
  const Motion m(s);
  EXPECT_GT(m.duration(), 50.0);
  // The planar path keeps the length of the 3-D one (the plane is fitted, not projected away).
  double planar = 0;
  for (double t = 0.1; t <= m.duration(); t += 0.1)
    planar += (m.at(t).translation() - m.at(t - 0.1).translation()).norm();
  EXPECT_GT(planar, 1.0);
  const Eigen::Vector2d extent = m.max() - m.min();
  EXPECT_LT(extent.maxCoeff(), 20.0);
}

TEST(Simulator, RealMotionIsOneWheelsCanDrive) {
  // The bundled OpenLORIS rows move sideways (ground-truth noise); the simulated robot must not,
  // or wheels without error would drift from the ground truth (0.2 m in these 30 s before).
  const Scenario s = scenarioFrom("Sequence.Duration: 30.0\nSequence.Motion: \"file\"\nSequence.MotionFile: \"" +
                                      std::string(RVWO_SOURCE_DIR) +
                                      "/scenarios/motion/openloris_home1_seq1.txt\"\n"
                                      "Odometry.RadiusError: 0.0\nOdometry.TrackError: 0.0\nOdometry.NoiseWheel: 0.0\n"
                                      "Odometry.TicksPerRevolution: 1000000\n",
                                  "openloris");
  const Motion m(s);
  OdometrySimulator odo(s, m, 1);
  double travelled = 0, worst = 0;
  for (int k = 1; k <= 3000; ++k) {
    const double t = 0.01 * k;
    const OdometryReading r = odo.step(t);
    const SE2 truth = m.at(0.0).between(m.at(t));
    travelled += (m.at(t).translation() - m.at(t - 0.01).translation()).norm();
    worst = std::max(worst, (r.pose.translation() - truth.translation()).norm());
    EXPECT_NEAR(wrapAngle(r.pose.angle() - truth.angle()), 0.0, 1e-4) << "t = " << t;
  }
  EXPECT_GT(travelled, 5.0);
  EXPECT_LT(worst, 2e-3) << "wheels without error drift from the ground truth";
}

TEST(Simulator, ScenarioErrorsNameFileAndKey) {
  const auto expectError = [](const std::string& yaml, const std::string& fragment) {
    try {
      scenarioFrom(yaml, "bad");
      FAIL() << "accepted: " << yaml;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("rvwo_sim_bad.yaml: " + fragment), std::string::npos) << e.what();
    }
  };
  expectError("Sequence.Camera: \"thermal\"\n", "Sequence.Camera: stereo, rgbd or mono");
  expectError("Sequence.Duration: \"long\"\n", "Sequence.Duration: expected a number");
  expectError("Events.Slip: [3.0, 2.0]\n", "Events.Slip: an interval ends before it starts");
  expectError("Events.Bumps: [1.0, 2.0]\n", "Events.Bumps: expected groups of 3");
  expectError("Sequence.Motion: \"file\"\n", "Sequence.MotionFile: needed");
  expectError("Camera.Exposure: 0.05\n", "Camera.Exposure: must be in [0, 1 / Sequence.Fps] s");
  expectError("Camera.Vignetting: 1.0\n", "Camera.Vignetting: must be in [0, 1)");
  expectError("Camera.JpegQuality: 101\n", "Camera.JpegQuality: must be in [0, 100]");
  expectError("Camera.ShotNoise: \"some\"\n", "Camera.ShotNoise: expected a number");
  expectError("Depth.Misregistration: [1.0]\n", "Depth.Misregistration: expected [x, y] in pixels");
  expectError("Depth.MaxIncidence: 0\n", "Depth.MaxIncidence: must be in (0, 90] degrees");
  expectError("Walkers.Look: \"robots\"\n", "Walkers.Look: people or cylinders");
  expectError("Camera.Fx: 50\n", "Camera.Fx: must be 0 (the lens's own) or in [100, 2000] px");
  expectError("Camera.Baseline: 0\n", "Camera.Baseline: must be in [0.02, 1] m");
  expectError("Sequence.MotionSpeed: 10\n", "Sequence.MotionSpeed: must be in [0.25, 4]");
  Scenario fisheye = scenarioFrom("Sequence.Camera: \"mono\"\nSequence.Lens: \"fisheye\"\n", "fisheye");
  fisheye.camera = "rgbd";  // as rvwo-sim --camera rgbd would (fisheye is mono and stereo only)
  EXPECT_THROW(validateScenario(fisheye, "overrides"), std::runtime_error);
  EXPECT_THROW(loadScenario(rvwo::test::scratch("rvwo_no_such_folder/scenario.yaml").string()), std::runtime_error);
}

using rvwo::test::slurp;

// Every drawn scenario is one the scenario checks accept, its events inside it; the same seed
// draws the same text, and over 20 seeds a camera meets every bundled motion and, but for RGB-D,
// both lenses.
TEST(Simulator, RandomisedScenariosCoverTheMotionsAndLenses) {
  const std::string folder = motionFolder();
  std::size_t motions = 0;
  for (const auto& e : fs::directory_iterator(folder)) motions += e.path().extension() == ".txt";
  ASSERT_GE(motions, 6u);
  for (const std::string camera : {"stereo", "rgbd", "mono"}) {
    std::set<std::string> files, lenses, texts;
    for (unsigned seed = 1; seed <= 20; ++seed) {
      const std::string text = randomScenario(seed, camera, "", 60, folder);
      EXPECT_EQ(text, randomScenario(seed, camera, "", 60, folder));
      texts.insert(text);
      const Scenario s = parseScenario(text, "drawn", ".");
      SCOPED_TRACE(text);
      EXPECT_EQ(s.camera, camera);
      EXPECT_LE(s.duration, 60.0);
      EXPECT_GE(s.duration, 20.0);
      files.insert(s.motion_file);
      lenses.insert(s.lens);
      for (const auto* events : {&s.slip, &s.blackout, &s.low_texture, &s.bumps})
        for (const Interval& i : *events) EXPECT_TRUE(i.t0 >= 2 && i.t1 <= s.duration - 2) << i.t0 << " " << i.t1;
    }
    EXPECT_EQ(texts.size(), 20u);
    EXPECT_EQ(files.size(), motions) << camera;
    EXPECT_EQ(lenses.size(), camera == "rgbd" ? 1u : 2u) << camera;
  }
  EXPECT_NE(randomScenario(1, "stereo", "pinhole", 60, folder).find("Sequence.Lens: \"pinhole\""), std::string::npos);
}

// rvwo-sim --randomise writes the scenario it drew; --scenario on that file renders the same
// sequence, with the drawn focal length and baseline in the settings.
TEST(Simulator, RandomisedScenarioRendersAgainFromItsFile) {
  const fs::path dir = rvwo::test::scratch("rvwo_sim_randomised");
  fs::remove_all(dir);
  const std::string sim = std::string(RVWO_SIM) + " --quiet --seed 4 --duration 0.5 --camera stereo --lens pinhole";
  ASSERT_EQ(std::system((sim + " --randomise --out " + (dir / "a").string() + " > /dev/null").c_str()), 0);
  ASSERT_EQ(std::system((sim + " --scenario " + (dir / "a" / "scenario.yaml").string() + " --out " +
                         (dir / "b").string() + " > /dev/null")
                            .c_str()),
            0);
  for (const char* file : {"sequence.rawlog", "groundtruth.txt", "sequence_Images/L_000010.png"})
    EXPECT_EQ(slurp(dir / "a" / file), slurp(dir / "b" / file)) << file;
  const Scenario drawn = loadScenario((dir / "a" / "scenario.yaml").string());
  const Settings settings = Settings::load((dir / "a" / "settings.yaml").string());
  EXPECT_NEAR(settings.requireNumber("Camera1.fx"), drawn.focal, 1e-9);
  EXPECT_NEAR(settings.requireNumber("Stereo.b"), drawn.baseline, 1e-9);
  EXPECT_NE(drawn.focal, 400.0);
}

TEST(Simulator, SameSeedSameBytes) {
  const fs::path dir = rvwo::test::scratch("rvwo_sim_determinism");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "tiny.yaml")
      << "%YAML:1.0\nSequence.Duration: 1.0\nSequence.Camera: \"stereo\"\nWalkers.Count: 2\n"
         "Walkers.Escorts: 1\nEvents.Slip: [0.3, 0.6]\nEvents.Bumps: [0.0, 1.0, 0.01]\n";
  auto run = [&](const std::string& out, unsigned seed) {
    const std::string cmd = std::string(RVWO_SIM) + " --quiet --scenario " + (dir / "tiny.yaml").string() + " --out " +
                            (dir / out).string() + " --seed " + std::to_string(seed) + " > /dev/null";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
  };
  run("a", 5);
  run("b", 5);
  run("c", 6);
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "a")) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), dir / "a");
    EXPECT_EQ(slurp(e.path()), slurp(dir / "b" / rel)) << rel;
    ++files;
  }
  EXPECT_GT(files, 60u);  // 31 frames x 3 images, rawlog, settings, ground truth, scenario
  // The settings give the wheels' noise as simulated, read as the estimators read it: the angle
  // noise, and no skid (the robot never moves sideways: RealMotionIsOneWheelsCanDrive; absent,
  // the key would leave the default's 0.01 m/sqrt(m)).
  const WheelNoise noise = readWheelNoise(Settings::load((dir / "a" / "settings.yaml").string()));
  ASSERT_NE(WheelNoise().sigma_y, 0.0);
  EXPECT_EQ(noise.sigma_y, 0.0);
  EXPECT_EQ(noise.sigma_wheel, 0.005);
  EXPECT_NE(slurp(dir / "a" / "sequence.rawlog"), slurp(dir / "c" / "sequence.rawlog"));
  EXPECT_NE(slurp(dir / "a" / "sequence_Images" / "L_000010.png"),
            slurp(dir / "c" / "sequence_Images" / "L_000010.png"));
}

}  // namespace
}  // namespace rvwo::sim
