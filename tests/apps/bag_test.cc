// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// rvwo-bag on bags written by the same library (rosbags): a simulated sequence goes into a ROS 1,
// a ROS 2 sqlite3 and a ROS 2 mcap bag (tests/apps/write_bag.py) as a robot's driver would publish
// it, comes back through rvwo-bag, and replays to the trajectory of the simulator's own rawlog;
// the settings it writes carry the simulator's camera and camera-to-base transform. Then bags that
// lack what is needed, or hold it wrongly, get one line and exit 1 with nothing left behind.
#include <gtest/gtest.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>

#include <algorithm>
#include <cstdint>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "replay_common.h"
#include "support/rawlog.h"

namespace rvwo::apps::test {
namespace {

const std::string kPython = RVWO_PYTHON, kBag = RVWO_BAG;

int run(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// An image as a NumPy .npy file (version 1.0): 8-bit grey or BGR, or 16-bit depth.
void writeNpy(const fs::path& file, const cv::Mat& m) {
  std::string dict = std::string("{'descr': '") + (m.depth() == CV_16U ? "<u2" : "|u1") +
                     "', 'fortran_order': False, 'shape': (" + std::to_string(m.rows) + ", " + std::to_string(m.cols) +
                     (m.channels() > 1 ? ", " + std::to_string(m.channels()) : std::string()) + "), }";
  dict.append(63 - (10 + dict.size()) % 64, ' ');
  dict += '\n';
  std::ofstream out(file, std::ios::binary);
  const std::uint16_t len = static_cast<std::uint16_t>(dict.size());
  out << "\x93NUMPY" << char(1) << char(0) << char(len & 0xff) << char(len >> 8) << dict;
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  out.write(reinterpret_cast<const char*>(c.data), static_cast<std::streamsize>(c.total() * c.elemSize()));
}

std::int64_t nanoseconds(const mrpt::obs::CObservation& o) {
  return std::llround(mrpt::Clock::toDouble(o.timestamp) * 1e9);
}

// The simulated sequence in seq, as write_bag.py reads it (see its docstring), into src.
void dump(const fs::path& seq, const fs::path& src) {
  fs::create_directories(src);
  std::ofstream frames(src / "frames.csv"), odometry(src / "odometry.csv");
  RawlogReader reader((seq / "sequence.rawlog").string());
  cv::FileStorage settings((seq / "settings.yaml").string(), cv::FileStorage::READ);
  const double tpr = settings["Odometry.TicksPerRevolution"];
  int n = 0;
  while (auto o = reader.next()) {
    const auto& obs = **o;
    const std::string t = std::to_string(nanoseconds(obs)), name = std::to_string(n++);
    if (auto s = dynamic_cast<const mrpt::obs::CObservationStereoImages*>(&obs)) {
      writeNpy(src / (name + "l.npy"), loadImage(s->imageLeft, cv::IMREAD_UNCHANGED));
      writeNpy(src / (name + "r.npy"), loadImage(s->imageRight, cv::IMREAD_UNCHANGED));
      frames << t << "," << name << "l.npy," << name << "r.npy\n";
    } else if (auto d = dynamic_cast<const mrpt::obs::CObservation3DRangeScan*>(&obs)) {
      ASSERT_FLOAT_EQ(d->rangeUnits, 1e-3f);  // millimetres, as 16UC1 depth
      cv::Mat depth(d->rangeImage.rows(), d->rangeImage.cols(), CV_16U);
      for (int r = 0; r < depth.rows; ++r)
        for (int c = 0; c < depth.cols; ++c) depth.at<std::uint16_t>(r, c) = d->rangeImage(r, c);
      writeNpy(src / (name + "l.npy"), loadImage(d->intensityImage, cv::IMREAD_UNCHANGED));
      writeNpy(src / (name + "d.npy"), depth);
      frames << t << "," << name << "l.npy," << name << "d.npy\n";
    } else if (auto m = dynamic_cast<const mrpt::obs::CObservationImage*>(&obs); m && obs.sensorLabel == "CAMERA") {
      writeNpy(src / (name + "l.npy"), loadImage(m->image, cv::IMREAD_UNCHANGED));
      frames << t << "," << name << "l.npy\n";
    } else if (auto w = dynamic_cast<const mrpt::obs::CObservationOdometry*>(&obs)) {
      char row[512];
      std::snprintf(row, sizeof row, "%s,%.17g,%.17g,%.17g,%d,%d,%.17g,%.17g,%.17g\n", t.c_str(), w->odometry.x(),
                    w->odometry.y(), w->odometry.phi(), w->encoderLeftTicks, w->encoderRightTicks, tpr,
                    w->velocityLocal.vx, w->velocityLocal.omega);
      odometry << row;
    }
  }
  std::ofstream(src / "camera.txt") << std::setprecision(17) << double(settings["Camera1.fx"]) << " "
                                    << double(settings["Camera1.fy"]) << " " << double(settings["Camera1.cx"]) << " "
                                    << double(settings["Camera1.cy"]) << " " << int(settings["Camera.width"]) << " "
                                    << int(settings["Camera.height"]) << " "
                                    << (settings["Stereo.b"].empty() ? 0.0 : double(settings["Stereo.b"])) << "\n";
  cv::Mat T_b_c;
  settings["Camera.T_b_c"] >> T_b_c;
  std::ofstream tbc(src / "T_b_c.txt");
  tbc << std::setprecision(17);
  for (int i = 0; i < 16; ++i) tbc << T_b_c.at<double>(i / 4, i % 4) << " ";
}

// A scratch folder `name` holding the simulated sequence `seq` dumped for write_bag.py in src/.
fs::path dumpedTo(const fs::path& seq, const std::string& name) {
  const fs::path work = rvwo::test::scratch(name);
  fs::remove_all(work);
  dump(seq, work / "src");
  return work;
}

// The simulator's settings with Odometry.Input set (and the ticks a wheel turn, when given).
void settingsWith(const fs::path& from, const fs::path& to, const std::string& input, const std::string& ticks = "") {
  std::ifstream in(from);
  std::ofstream out(to);
  for (std::string l; std::getline(in, l);) {
    if (!ticks.empty() && l.rfind("Odometry.TicksPerRevolution:", 0) == 0) l = "Odometry.TicksPerRevolution: " + ticks;
    out << l << "\n";
  }
  out << "Odometry.Input: \"" << input << "\"\n";
}

struct Case {
  std::string camera, storage, odometry, input, flags;
};

// One camera, one storage, one odometry message: the bag's replay against the rawlog's.
void roundTrip(const Case& c) {
  SCOPED_TRACE(c.camera + " " + c.storage + " " + c.odometry);
  const fs::path seq = simulate("static", 3.0, "--camera " + c.camera);
  const fs::path work = dumpedTo(seq, "bag_" + c.camera + "_" + c.storage + "_" + c.odometry);
  const std::string bag = (work / (c.storage == "ros1" ? "run.bag" : "run")).string();
  const bool compressed = c.camera == "mono";  // CompressedImage (png) for mono, Image for the others
  ASSERT_EQ(run(kPython + " " + RVWO_SOURCE_DIR + "/tests/apps/write_bag.py " + (work / "src").string() + " " + bag +
                " --storage " + c.storage + " --odometry " + c.odometry + (compressed ? " --compressed" : "")),
            0);
  const fs::path out = work / "converted";
  const std::string flags = c.camera == "stereo" ? " --right /camera/right/image_raw"
                            : c.camera == "rgbd" ? " --depth /camera/depth/image_raw"
                                                 : "";
  const std::string log = (work / "bag.log").string();
  ASSERT_EQ(run(kBag + " --in " + bag + " --out " + out.string() + " --image /camera/left/image_raw" +
                (compressed ? "/compressed" : "") + flags + c.flags + " > " + log + " 2>&1"),
            0)
      << rvwo::test::slurp(log);
  const std::string said = rvwo::test::slurp(log);
  if (c.flags.empty()) {
    EXPECT_NE(said.find("still to supply in settings.yaml: Odometry.WheelRadiusLeft"), std::string::npos) << said;
  }
  // Its settings: the simulator's camera and camera-to-base transform, the odometry's kind.
  cv::FileStorage mine((out / "settings.yaml").string(), cv::FileStorage::READ),
      sim((seq / "settings.yaml").string(), cv::FileStorage::READ);
  for (const char* key : {"Camera1.fx", "Camera1.fy", "Camera1.cx", "Camera1.cy", "Camera.width", "Camera.height"})
    EXPECT_DOUBLE_EQ(double(mine[key]), double(sim[key])) << key;
  EXPECT_NEAR(double(mine["Camera.fps"]), double(sim["Camera.fps"]), 1e-6);
  if (c.camera == "stereo") {
    EXPECT_NEAR(double(mine["Stereo.b"]), double(sim["Stereo.b"]), 1e-12);
  }
  cv::Mat a, b;
  mine["Camera.T_b_c"] >> a;
  sim["Camera.T_b_c"] >> b;
  ASSERT_FALSE(a.empty());
  EXPECT_LT(cv::norm(a - b, cv::NORM_INF), 1e-12);
  EXPECT_EQ(std::string(mine["Odometry.Input"]), c.input);
  if (!c.flags.empty()) {
    for (const char* key : {"Odometry.WheelRadiusLeft", "Odometry.WheelRadiusRight", "Odometry.Track"})
      EXPECT_DOUBLE_EQ(double(mine[key]), double(sim[key])) << key;
  }
  // The replays: the rawlog's, with the same odometry input, and the bag's.
  const std::string ticks = c.input == "encoders" ? "65536" : "";
  settingsWith(seq / "settings.yaml", seq / "as_bag.yaml", c.input);
  settingsWith(seq / "settings.yaml", out / "replay.yaml", c.input, ticks);
  fs::copy_file(seq / "groundtruth.txt", out / "groundtruth.txt");
  const Outcome direct = replay(seq, "", "direct", "as_bag.yaml"), via_bag = replay(out, "", "bag", "replay.yaml");
  ASSERT_EQ(direct.status, 0) << direct.err;
  ASSERT_EQ(via_bag.status, 0) << via_bag.err;
  EXPECT_EQ(via_bag.poses, direct.poses);
  EXPECT_GT(direct.poses, 80u);
  EXPECT_NEAR(via_bag.ate, direct.ate, 1e-6);
  const Trajectory p = readTum((seq / "direct.txt").string()), q = readTum((out / "bag.txt").string());
  ASSERT_EQ(p.size(), q.size());
  double worst = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(p[i].t, q[i].t, 1e-6);
    worst = std::max(worst, (p[i].T.translation() - q[i].T.translation()).norm());
  }
  EXPECT_LT(worst, 1e-6);
  std::printf("[ figures  ] %s %s %s: %zu poses, ATE %.6f m (rawlog) %.6f m (bag), largest difference %.2e m\n",
              c.camera.c_str(), c.storage.c_str(), c.odometry.c_str(), p.size(), direct.ate, via_bag.ate, worst);
}

// A bag written from the stereo sequence, spoiled by write_bag.py's `spoil` options.
std::string spoiltBag(const fs::path& src, const std::string& name, const std::string& storage,
                      const std::string& spoil) {
  const std::string bag = (src.parent_path() / name).string();
  EXPECT_EQ(run(kPython + " " + RVWO_SOURCE_DIR + "/tests/apps/write_bag.py " + src.string() + " " + bag +
                " --storage " + storage + " --odometry odometry " + spoil),
            0);
  return bag;
}

// rvwo-bag on a bad bag: exit 1, the one line it wrote to stderr, and nothing left in its folder.
std::string failure(const std::string& bag, const std::string& flags) {
  const fs::path out = fs::path(bag).parent_path() / "out";
  const fs::path err = fs::path(bag).parent_path() / "err.txt";
  const int rc =
      run(kBag + " --in " + bag + " --out " + out.string() + " " + flags + " > /dev/null 2> " + err.string());
  EXPECT_EQ(rc, 1) << bag;
  EXPECT_FALSE(fs::exists(out)) << bag;
  EXPECT_FALSE(fs::exists(fs::path(bag).parent_path() / ".out.partial")) << bag;
  const std::string said = rvwo::test::slurp(err);
  EXPECT_EQ(std::count(said.begin(), said.end(), '\n'), 1) << said;
  return said;
}

TEST(Bag, BadBagsGetOneLineAndLeaveNothing) {
  const fs::path seq = simulate("static", 1.0, "--camera stereo");
  const fs::path work = dumpedTo(seq, "bag_bad");
  const std::string left = " --image /camera/left/image_raw";
  std::string bag = spoiltBag(work / "src", "no_odometry.bag", "ros1", "--drop /odom");
  EXPECT_EQ(failure(bag, left), "rvwo-bag: error: " + bag +
                                    ": no odometry topic (nav_msgs/Odometry, sensor_msgs/JointState, "
                                    "geometry_msgs/TwistStamped): name one with --odometry, or give --no-odometry "
                                    "for --mode vo\n");
  bag = spoiltBag(work / "src", "no_camera", "sqlite3", "--drop /camera/left/image_raw");
  EXPECT_EQ(failure(bag, left),
            "rvwo-bag: error: " + bag + ": no topic /camera/left/image_raw (--image); --list shows the bag's topics\n");
  bag = spoiltBag(work / "src", "good", "mcap", "");
  const std::string listed = (work / "list.txt").string();
  ASSERT_EQ(run(kBag + " --in " + bag + " --list > " + listed), 0);
  const std::string topics = rvwo::test::slurp(listed);
  for (const char* row :
       {"/camera/left/image_raw                   sensor_msgs/msg/Image                      30   30.0 Hz",
        "/tf_static                               tf2_msgs/msg/TFMessage                      1         -"})
    EXPECT_NE(topics.find(row), std::string::npos) << topics;
  EXPECT_EQ(failure(bag, left + " --odometry /camera/left/camera_info"),
            "rvwo-bag: error: " + bag +
                ": topic /camera/left/camera_info is sensor_msgs/msg/CameraInfo, not nav_msgs/Odometry, "
                "sensor_msgs/JointState or geometry_msgs/TwistStamped (--odometry)\n");
  EXPECT_EQ(failure(bag, ""), "rvwo-bag: error: " + bag +
                                  ": 2 image topics (/camera/left/image_raw, /camera/right/image_raw): choose the "
                                  "camera with --image (and --right or --depth)\n");
  bag = spoiltBag(work / "src", "yuv.bag", "ros1", "--encoding yuv422");
  EXPECT_EQ(failure(bag, left),
            "rvwo-bag: error: /camera/left/image_raw message 1: image encoding 'yuv422' is not "
            "one RVWO reads (mono8, rgb8, bgr8, rgba8, bgra8, mono16, 16UC1; 32FC1 for depth)\n");
  bag = spoiltBag(work / "src", "speeds.bag", "ros1", "--odometry speeds");
  EXPECT_EQ(failure(bag, left),
            "rvwo-bag: error: /joint_states: the JointState gives wheel speeds only: give "
            "--wheel-radius and --track, which turn them into the robot's speed and turn rate\n");
  EXPECT_EQ(failure(bag, left + " --track -1"), "rvwo-bag: error: --track must be a length > 0 in metres, not -1.0\n");
  bag = spoiltBag(work / "src", "swapped.bag", "ros1", "--swap 10");
  const std::string swapped = failure(bag, left);
  EXPECT_EQ(swapped.rfind("rvwo-bag: error: /camera/left/image_raw message 12: its stamp ", 0), 0u) << swapped;
  EXPECT_NE(swapped.find("is not after the one before"), std::string::npos) << swapped;
  // Cut short: a ROS 1 bag and an mcap file, to 60 % of their bytes.
  for (const std::string& whole : {(work / "good.bag").string(), (work / "good" / "good.mcap").string()}) {
    if (whole.size() > 4 && whole.substr(whole.size() - 4) == ".bag") {
      ASSERT_EQ(run(kPython + " " + RVWO_SOURCE_DIR + "/tests/apps/write_bag.py " + (work / "src").string() + " " +
                    whole + " --storage ros1 --odometry odometry"),
                0);
    }
    ASSERT_TRUE(fs::exists(whole)) << whole;
    fs::resize_file(whole, fs::file_size(whole) * 6 / 10);
    const std::string cut = whole.substr(whole.size() - 4) == ".bag" ? whole : (work / "good").string();
    const std::string said = failure(cut, left);
    EXPECT_EQ(said.rfind("rvwo-bag: error: " + cut + ": ", 0), 0u) << said;
    EXPECT_NE(said.find("cut short or damaged"), std::string::npos) << said;
  }
}

TEST(Bag, StereoRos1WithOdometryReplaysAsTheRawlog) { roundTrip({"stereo", "ros1", "odometry", "pose", ""}); }
TEST(Bag, RgbdRos2SqliteWithWheelAnglesReplaysAsTheRawlog) { roundTrip({"rgbd", "sqlite3", "joints", "encoders", ""}); }
TEST(Bag, MonoRos2McapCompressedWithTwistReplaysAsTheRawlog) { roundTrip({"mono", "mcap", "twist", "velocities", ""}); }
TEST(Bag, MonoRos1WithWheelAnglesReplaysAsTheRawlog) { roundTrip({"mono", "ros1", "joints", "encoders", ""}); }
TEST(Bag, RgbdRos2McapWithOdometryReplaysAsTheRawlog) { roundTrip({"rgbd", "mcap", "odometry", "pose", ""}); }
TEST(Bag, RgbdRos2SqliteWithWheelSpeedsReplaysAsTheRawlog) {
  roundTrip({"rgbd", "sqlite3", "speeds", "velocities", " --wheel-radius 0.08 --track 0.4"});
}
// Wheel speeds alone: the robot's speed and turn rate through the wheels given on the command line.
TEST(Bag, StereoRos2McapWithWheelSpeedsReplaysAsTheRawlog) {
  roundTrip({"stereo", "mcap", "speeds", "velocities", " --wheel-radius 0.08 --track 0.4"});
}

// Each observation of a kind in a rawlog, in order.
template <class T>
std::vector<T> observations(const fs::path& rawlog) {
  std::vector<T> out;
  RawlogReader reader(rawlog.string());
  while (auto o = reader.next()) {
    if (auto x = dynamic_cast<const T*>(o->get())) out.push_back(*x);
  }
  return out;
}

// A bag laid out as TUM RGB-D ships its fr2 Pioneer sequences (write_bag.py --layout tum) and
// rvwo-bag --preset fr2: TUM's topics found by name, the published calibration in place of the
// bag's default camera_info, depth in metres back to millimetres, the Pioneer's /pose as the
// odometry. The moving /tf transforms join nothing: the preset's Camera.T_b_c, and a line asking
// for the real mount. A bag without /pose (fr1, fr3) converts for --mode vo and replays.
TEST(Bag, TumPioneerBagWithItsPresetConvertsWithThePublishedCamera) {
  const fs::path seq = simulate("static", 2.0, "--camera rgbd");
  const fs::path work = dumpedTo(seq, "bag_tum");
  const std::string bag = (work / "rgbd_dataset_freiburg2_pioneer_360.bag").string();
  const std::string write =
      kPython + " " + RVWO_SOURCE_DIR + "/tests/apps/write_bag.py " + (work / "src").string() + " ";
  ASSERT_EQ(run(write + bag + " --storage ros1 --odometry odometry --layout tum"), 0);
  const fs::path out = work / "pioneer";
  const std::string log = (work / "bag.log").string();
  ASSERT_EQ(run(kBag + " --in " + bag + " --out " + out.string() + " --preset fr2 > " + log + " 2>&1"), 0)
      << rvwo::test::slurp(log);
  cv::FileStorage s((out / "settings.yaml").string(), cv::FileStorage::READ);
  EXPECT_EQ(std::string(s["Sensor"]), "rgbd");
  // TUM's fr2 figures ("Intrinsic Camera Calibration of the Kinect"), not the bag's 525 / 319.5 / 239.5.
  const std::pair<const char*, double> published[] = {
      {"Camera1.fx", 520.9},        {"Camera1.fy", 521.0},   {"Camera1.cx", 325.1},   {"Camera1.cy", 249.7},
      {"Camera1.k1", 0.2312},       {"Camera1.k2", -0.7849}, {"Camera1.p1", -0.0033}, {"Camera1.p2", -0.0001},
      {"Camera1.k3", 0.9172},       {"Camera.width", 640},   {"Camera.height", 480},  {"Camera.fps", 30},
      {"RGBD.DepthMapFactor", 1000}};
  for (const auto& [key, value] : published) EXPECT_DOUBLE_EQ(double(s[key]), value) << key;
  EXPECT_EQ(std::string(s["Odometry.Input"]), "pose");
  // No transform joins the Pioneer to the Kinect: the preset's (the base at the camera, x forward), and a line.
  cv::Mat T_b_c;
  s["Camera.T_b_c"] >> T_b_c;
  ASSERT_EQ(T_b_c.size(), cv::Size(4, 4));
  EXPECT_EQ(cv::norm(T_b_c - cv::Mat(cv::Matx44d(0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0, 1)), cv::NORM_INF), 0);
  const std::string said = rvwo::test::slurp(log);
  EXPECT_NE(said.find("Camera.T_b_c: the Kinect on the robot's base (TUM published none"), std::string::npos) << said;
  EXPECT_EQ(said.find("intrinsics"), std::string::npos) << said;
  // Every frame, with the simulator's pixels and millimetres, and every odometry reading.
  const auto mine = observations<mrpt::obs::CObservation3DRangeScan>(out / "sequence.rawlog"),
             sim = observations<mrpt::obs::CObservation3DRangeScan>(seq / "sequence.rawlog");
  ASSERT_EQ(mine.size(), sim.size());
  ASSERT_GT(mine.size(), 50u);
  for (std::size_t i = 0; i < mine.size(); i += 17) {
    EXPECT_FLOAT_EQ(mine[i].rangeUnits, 1e-3f);
    EXPECT_TRUE(mine[i].rangeImage == sim[i].rangeImage) << "frame " << i;
    EXPECT_EQ(cv::norm(loadImage(mine[i].intensityImage, cv::IMREAD_GRAYSCALE),
                       loadImage(sim[i].intensityImage, cv::IMREAD_GRAYSCALE), cv::NORM_INF),
              0.0)
        << "frame " << i;
  }
  EXPECT_EQ(observations<mrpt::obs::CObservationOdometry>(out / "sequence.rawlog").size(),
            observations<mrpt::obs::CObservationOdometry>(seq / "sequence.rawlog").size());
  // A bag without /pose (fr1 and fr3, hand-held): no odometry, and the line says to replay vo.
  const std::string hand_held = (work / "rgbd_dataset_freiburg1_xyz.bag").string();
  ASSERT_EQ(run(write + hand_held + " --storage ros1 --odometry odometry --layout tum --drop /pose"), 0);
  ASSERT_EQ(run(kBag + " --in " + hand_held + " --out " + (work / "xyz").string() + " --preset fr1 > " + log + " 2>&1"),
            0)
      << rvwo::test::slurp(log);
  cv::FileStorage fr1((work / "xyz" / "settings.yaml").string(), cv::FileStorage::READ);
  EXPECT_DOUBLE_EQ(double(fr1["Camera1.fx"]), 517.3);
  EXPECT_TRUE(fr1["Odometry.Input"].empty());
  const std::string fr1_said = rvwo::test::slurp(log);
  EXPECT_NE(fr1_said.find("still to supply in settings.yaml: wheel odometry: this bag has no /pose (of TUM's, only "
                          "the fr2 pioneer_* sequences do): replay with --mode vo\n"),
            std::string::npos)
      << fr1_said;
  // One command from the bag to a replay (the ground truth, as a TUM folder has it, from the simulator).
  fs::copy_file(seq / "groundtruth.txt", work / "xyz" / "groundtruth.txt");
  const Outcome vo = replay(work / "xyz", "--mode vo", "vo");
  EXPECT_EQ(vo.status, 0) << vo.err;
  EXPECT_GT(vo.poses, 0u);
}

}  // namespace
}  // namespace rvwo::apps::test
