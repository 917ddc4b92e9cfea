// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-sim: renders a test sequence of a textured room seen by the camera of a wheeled robot, with
// wheel odometry and events, as RVWO's rawlog conventions say (docs/rawlog.md):
//   DIR/sequence.rawlog           camera frames (stereo, RGB-D or mono), ground-truth label images
//                                 ("LABELS"), wheel odometry ("ODOMETRY": pose, encoder ticks, velocity)
//   DIR/sequence_Images/          the images (PNG), referenced from the rawlog
//   DIR/settings.yaml             camera, extrinsics, odometry (ORB-SLAM3 keys)
//   DIR/groundtruth.txt           robot base in the world, TUM format, at every camera frame
//   DIR/groundtruth_camera.txt    the (left) camera, likewise
//   DIR/scenario.yaml             the scenario it ran
// The robot follows a built-in loop or a real trajectory (TUM rows, OpenLORIS blocks, TUM Pioneer
// files with their tilted plane fitted away). The scenario format is in docs/simulator.md.
// Same scenario, same seed: same bytes.
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "sim/odometry.h"
#include "sim/scenario.h"
#include "sim/scene.h"
#include "support/command_line.h"
#include "support/rawlog.h"
#include "support/trajectory.h"

namespace fs = std::filesystem;
using rvwo::SE2;

namespace {

// The simulated camera rig: a ZED2-like stereo pair (or one camera) 0.25 m ahead of the base,
// 0.4 m up, looking forward, pitched down by 5 degrees.
struct Rig {
  int width = 640, height = 480;
  double fx = 400, fy = 400, cx = 319.5, cy = 239.5, baseline = 0.12;
  double k[4] = {0.0, 0.0, 0.0, 0.0};  // Kannala-Brandt, fisheye only
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_c1_c2 = Eigen::Isometry3d::Identity();  // the right camera in the left's frame
  Rig(bool fisheye) {
    T_c1_c2.translation().x() = baseline;
    Eigen::Matrix3d R_b_c;
    R_b_c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    T_b_c.linear() = Eigen::AngleAxisd(5.0 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() * R_b_c;
    T_b_c.translation() << 0.25, 0.0, 0.4;
    if (fisheye) {  // a T265-like lens: 848x800, ~160 degrees
      width = 848;
      height = 800;
      fx = fy = 286;
      cx = 423.5;
      cy = 399.5;
      k[0] = -0.0105;
      k[1] = 0.0463;
      k[2] = -0.0431;
      k[3] = 0.0079;
      // Raw fisheye pairs are not rectified: the right camera is turned a little, as real ones
      // are (rvwo-replay rectifies them).
      T_c1_c2.linear() = (Eigen::AngleAxisd(0.4 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                          Eigen::AngleAxisd(-0.3 * M_PI / 180, Eigen::Vector3d::UnitX()))
                             .toRotationMatrix();
    }
  }
};

Eigen::Isometry3d pose3(const SE2& T, double z = 0, double roll = 0, double pitch = 0) {
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() = (Eigen::AngleAxisd(T.angle(), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  P.translation() << T.translation().x(), T.translation().y(), z;
  return P;
}

bool inAny(const std::vector<rvwo::sim::Interval>& v, double t, double* value = nullptr) {
  for (const auto& i : v) {
    if (i.contains(t)) {
      if (value) *value = i.value;
      return true;
    }
  }
  return false;
}

std::string matrix(const Eigen::Isometry3d& T) {
  std::ostringstream o;
  o << std::setprecision(12) << "!!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) o << T.matrix()(r, c) << (r == 3 && c == 3 ? "]" : ", ");
  }
  return o.str();
}

}  // namespace

int main(int argc, char** argv) {
  try {
    TCLAP::CmdLine cmd(
        "rvwo-sim: renders a test sequence (textured room, wheeled robot, stereo / RGB-D / mono camera, wheel "
        "odometry, walkers, slip, blackouts, low texture, illumination changes, floor bumps) into an MRPT rawlog with "
        "settings and ground truth. The scenario format is in docs/simulator.md.",
        ' ', "0.1");
    TCLAP::ValueArg<std::string> scenario_arg("", "scenario", "the scenario YAML", true, "", "S.yaml", cmd);
    TCLAP::ValueArg<std::string> out_arg("", "out", "output folder (created; existing outputs are replaced)", true, "",
                                         "DIR", cmd);
    TCLAP::ValueArg<unsigned> seed_arg("", "seed", "random seed: textures, walkers, noise (default 1)", false, 1, "N",
                                       cmd);
    TCLAP::ValueArg<std::string> camera_arg("", "camera", "override the scenario's camera: stereo, rgbd or mono", false,
                                            "", "kind", cmd);
    TCLAP::ValueArg<double> duration_arg("", "duration", "override the scenario's duration, s (e.g. a short test)",
                                         false, 0, "s", cmd);
    TCLAP::SwitchArg quiet("", "quiet", "no progress line", cmd);
    if (const auto status = rvwo::apps::parseCommandLine(cmd, argc, argv)) return *status;
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);

    const auto t_start = std::chrono::steady_clock::now();
    const bool tty = isatty(fileno(stderr));
    rvwo::sim::Scenario sc = rvwo::sim::loadScenario(scenario_arg.getValue());
    if (!camera_arg.getValue().empty()) {
      sc.camera = camera_arg.getValue();
      sc.text += "# rvwo-sim --camera " + sc.camera + "\n";
    }
    if (duration_arg.isSet()) {
      sc.duration = duration_arg.getValue();
      sc.text += "# rvwo-sim --duration " + std::to_string(sc.duration) + "\n";
    }
    // The overrides pass the scenario's own checks (e.g. --camera stereo on a fisheye scenario).
    rvwo::sim::validateScenario(sc, scenario_arg.getValue() + " with the command-line overrides");
    const rvwo::sim::Motion motion(sc);
    const unsigned seed = seed_arg.getValue();
    const double duration = std::min(sc.duration, motion.duration());
    const bool stereo = sc.camera == "stereo", rgbd = sc.camera == "rgbd";
    const Rig rig(sc.lens == "fisheye");

    // Room: as the scenario says, enlarged so that the path stays 1.5 m from the walls.
    const Eigen::Vector2d extent = motion.max() - motion.min(), centre = 0.5 * (motion.max() + motion.min());
    const double room_x = std::max(sc.room_x, extent.x() + 3), room_y = std::max(sc.room_y, extent.y() + 3);
    rvwo::sim::Scene scene(room_x, room_y, sc.room_h, seed, sc.furniture);
    const SE2 T_room_path(-centre, 0.0);  // the path centred in the room
    std::mt19937_64 rng(seed * 31u + 7u);
    std::uniform_real_distribution<double> u(0, 1);
    const Eigen::Vector2d inner(room_x / 2 - 0.5, room_y / 2 - 0.5);  // 0.5 m from the walls
    auto insideRoom = [&](const Eigen::Vector2d& p) -> Eigen::Vector2d { return p.cwiseMax(-inner).cwiseMin(inner); };
    for (int i = 0; i < sc.walkers; ++i) {
      // Walkers cross the room along random segments through its middle part.
      rvwo::sim::Walker w;
      const double a = 2 * M_PI * u(rng);
      const Eigen::Vector2d c((u(rng) - 0.5) * room_x * 0.5, (u(rng) - 0.5) * room_y * 0.5);
      const Eigen::Vector2d dir(std::cos(a), std::sin(a));
      const double half = 0.5 * std::min(room_x, room_y) - 1.0;
      w.a = insideRoom(c - half * dir);
      w.b = insideRoom(c + half * dir);
      w.speed = sc.walker_speed * (0.7 + 0.6 * u(rng));
      w.phase = 10 * u(rng);
      scene.addWalker(w);
    }

    for (int i = 0; i < sc.escorts; ++i) {
      rvwo::sim::Walker w;
      w.escort = true;
      w.ahead = 1.8 + 1.5 * u(rng);
      w.sweep = 1.0 + 1.0 * u(rng);
      w.period = 6 + 6 * u(rng);
      w.phase = 2 * M_PI * u(rng);
      scene.addWalker(w);
    }

    // Output folder.
    const fs::path dir(out_arg.getValue());
    fs::create_directories(dir);
    const std::string rawlog_path = (dir / "sequence.rawlog").string();
    const fs::path images = rvwo::apps::RawlogWriter::imagesFolder(rawlog_path);
    fs::remove_all(images);
    fs::create_directories(images);
    std::ofstream(dir / "scenario.yaml") << sc.text;

    std::unique_ptr<rvwo::CameraModel> cam;
    if (sc.lens == "fisheye") {
      cam = std::make_unique<rvwo::KannalaBrandtCamera>(rig.fx, rig.fy, rig.cx, rig.cy, rig.k[0], rig.k[1], rig.k[2],
                                                        rig.k[3]);
    } else {
      cam = std::make_unique<rvwo::PinholeCamera>(rig.fx, rig.fy, rig.cx, rig.cy);
    }
    const cv::Mat rays = rvwo::sim::Scene::rayTable(*cam, rig.width, rig.height);
    mrpt::img::TCamera tcam;
    tcam.ncols = rig.width;
    tcam.nrows = rig.height;
    tcam.setIntrinsicParamsFromValues(rig.fx, rig.fy, rig.cx, rig.cy);

    const double radius = rvwo::sim::OdometrySimulator::kRadius, track = rvwo::sim::OdometrySimulator::kTrack;

    rvwo::apps::RawlogWriter rawlog(rawlog_path);
    rvwo::apps::Trajectory gt_base, gt_cam;
    auto bodyAt = [&](double t, Eigen::Isometry3d* T_w_b) {
      const SE2 planar = T_room_path * motion.at(rvwo::sim::motionTime(sc, t));
      double amp = 0, z = 0, roll = 0, pitch = 0;
      if (inAny(sc.bumps, t, &amp)) {  // floor bumps: small height, roll and pitch oscillations
        z = amp * std::sin(2 * M_PI * 3.1 * t);
        roll = 2 * amp * std::sin(2 * M_PI * 2.3 * t + 1);
        pitch = 2 * amp * std::sin(2 * M_PI * 1.7 * t + 2);
      }
      *T_w_b = pose3(planar, z, roll, pitch);
      return planar;
    };

    rvwo::sim::OdometrySimulator wheels(sc, motion, seed);
    const double odo_dt = 1.0 / sc.odometry_rate, frame_dt = 1.0 / sc.fps;
    const long n_odo = static_cast<long>(std::floor(duration / odo_dt + 1e-9));
    const long n_frames = static_cast<long>(std::floor(duration / frame_dt + 1e-9));
    long next_odo = 0, next_frame = 0, frames_written = 0;
    std::size_t image_bytes = 0;
    double render_s = 0, encode_s = 0;  // time spent rendering (and filling observations), writing images
    while (next_odo <= n_odo || next_frame <= n_frames) {
      const double t_odo = next_odo * odo_dt, t_frame = next_frame * frame_dt;
      if (next_odo <= n_odo && (next_frame > n_frames || t_odo <= t_frame)) {
        // ---- odometry reading at t_odo ----
        const rvwo::sim::OdometryReading reading = next_odo > 0 ? wheels.step(t_odo) : rvwo::sim::OdometryReading();
        mrpt::obs::CObservationOdometry o;
        o.sensorLabel = "ODOMETRY";
        o.timestamp = mrpt::Clock::fromDouble(t_odo);
        o.odometry =
            mrpt::poses::CPose2D(reading.pose.translation().x(), reading.pose.translation().y(), reading.pose.angle());
        o.hasEncodersInfo = true;
        o.encoderLeftTicks = static_cast<int32_t>(reading.ticks_left);
        o.encoderRightTicks = static_cast<int32_t>(reading.ticks_right);
        o.hasVelocities = true;
        o.velocityLocal = mrpt::math::TTwist2D(reading.v, 0, reading.omega);
        rawlog.write(o);
        ++next_odo;
        continue;
      }
      // ---- camera frame at t_frame ----
      Eigen::Isometry3d T_w_b;
      const SE2 planar = bodyAt(t_frame, &T_w_b);
      const Eigen::Vector3d robot = planar.vector();
      const Eigen::Isometry3d T_w_c = T_w_b * rig.T_b_c;
      rvwo::sim::RenderOptions ro;
      ro.blackout = inAny(sc.blackout, t_frame);
      double contrast = 1;
      if (inAny(sc.low_texture, t_frame, &contrast)) ro.contrast = contrast;
      for (const auto& i : sc.illumination) {
        if (t_frame >= i.t0) ro.gain = i.value;
      }
      ro.noise_seed = seed * 1000003u + static_cast<unsigned>(next_frame) * 2u;
      ro.noise = sc.pixel_noise;
      auto t_render = std::chrono::steady_clock::now();
      const rvwo::sim::Render left = scene.render(T_w_c, rays, t_frame, ro, robot);
      char name[64];
      std::snprintf(name, sizeof name, "L_%06ld.png", next_frame);
      std::vector<std::pair<cv::Mat, std::string>> to_write;  // encoded in parallel at the frame's end
      auto save = [&](const cv::Mat& img, const char* file) { to_write.emplace_back(img, (images / file).string()); };
      save(left.image, name);
      const mrpt::Clock::time_point stamp = mrpt::Clock::fromDouble(t_frame);
      if (stereo) {
        const Eigen::Isometry3d& T_c_r = rig.T_c1_c2;
        ro.noise_seed += 1;
        const rvwo::sim::Render right = scene.render(T_w_c * T_c_r, rays, t_frame, ro, robot);
        char rname[64];
        std::snprintf(rname, sizeof rname, "R_%06ld.png", next_frame);
        save(right.image, rname);
        mrpt::obs::CObservationStereoImages o;
        o.sensorLabel = "CAMERA";
        o.timestamp = stamp;
        o.imageLeft.setExternalStorage(name);
        o.imageRight.setExternalStorage(rname);
        o.hasImageRight = true;
        o.leftCamera = o.rightCamera = tcam;
        const Eigen::Quaterniond q_c_r(T_c_r.linear());
        o.rightCameraPose =
            mrpt::poses::CPose3DQuat(T_c_r.translation().x(), T_c_r.translation().y(), T_c_r.translation().z(),
                                     mrpt::math::CQuaternionDouble(q_c_r.w(), q_c_r.x(), q_c_r.y(), q_c_r.z()));
        rawlog.write(o);
      } else if (rgbd) {
        mrpt::obs::CObservation3DRangeScan o;
        o.sensorLabel = "RGBD";
        o.timestamp = stamp;
        o.hasIntensityImage = true;
        o.intensityImage.setExternalStorage(name);
        o.hasRangeImage = true;
        o.range_is_depth = true;
        o.rangeUnits = 1e-3f;
        o.rangeImage_setSize(rig.height, rig.width);
        for (int r = 0; r < rig.height; ++r) {
          for (int c = 0; c < rig.width; ++c) {
            const float d = left.depth.at<float>(r, c);
            o.rangeImage(r, c) = static_cast<uint16_t>(d > 0 && d < 10 ? std::lround(d * 1000) : 0);  // 10 m range
          }
        }
        o.cameraParams = o.cameraParamsIntensity = tcam;
        rawlog.write(o);
      } else {
        mrpt::obs::CObservationImage o;
        o.sensorLabel = "CAMERA";
        o.timestamp = stamp;
        o.image.setExternalStorage(name);
        o.cameraParams = tcam;
        rawlog.write(o);
      }
      // Ground-truth labels of the (left) image.
      std::snprintf(name, sizeof name, "S_%06ld.png", next_frame);
      save(left.labels, name);
      mrpt::obs::CObservationImage labels;
      labels.sensorLabel = "LABELS";
      labels.timestamp = stamp;
      labels.image.setExternalStorage(name);
      rawlog.write(labels);
      const auto t_encode = std::chrono::steady_clock::now();
      render_s += std::chrono::duration<double>(t_encode - t_render).count();
      // The frame's images are encoded in parallel (overlapping them with the next frame's rendering
      // was slower on two cores: the renderer's own split then waits on its slower half).
      std::vector<char> ok(to_write.size(), 0);
      cv::parallel_for_(cv::Range(0, static_cast<int>(to_write.size())), [&](const cv::Range& r) {
        for (int i = r.start; i < r.end; ++i) {
          // No compression level: OpenCV then filters every row by SUB at zlib's fastest level.
          // Files 6 % larger than with libpng's adaptive filters (Paeth on most rows here), but a
          // replay decodes them 18 % faster (2.2 ms instead of 2.7 for a 640x480 grey image) and
          // they are written in half the time.
          ok[i] = cv::imwrite(to_write[i].second, to_write[i].first,
                              {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY});
        }
      });
      for (std::size_t i = 0; i < to_write.size(); ++i) {
        if (!ok[i]) throw std::runtime_error("cannot write " + to_write[i].second);
        image_bytes += fs::file_size(to_write[i].second);
      }
      encode_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_encode).count();
      gt_base.push_back({t_frame, T_w_b});
      gt_cam.push_back({t_frame, T_w_c});
      ++frames_written;
      ++next_frame;
      const long every = static_cast<long>(tty ? sc.fps : 10 * sc.fps);  // a line every 10 s when logged
      if (!quiet.getValue() && (next_frame % every == 0 || next_frame > n_frames)) {
        const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
        std::fprintf(stderr, "%srvwo-sim: %.1f / %.1f s simulated, %ld frames, %.1f frames/s%s", tty ? "\r" : "",
                     t_frame, duration, frames_written, frames_written / el, tty ? "   " : "\n");
      }
    }
    if (!quiet.getValue() && tty) std::fprintf(stderr, "\n");
    rvwo::apps::writeTum((dir / "groundtruth.txt").string(), gt_base);
    rvwo::apps::writeTum((dir / "groundtruth_camera.txt").string(), gt_cam);

    // Settings, ORB-SLAM3 keys (docs/rawlog.md).
    std::ofstream st(dir / "settings.yaml");
    st << std::setprecision(12) << "%YAML:1.0\n# written by rvwo-sim for scenario '" << sc.name << "', seed " << seed
       << "\n"
       << "Camera.type: \"" << (sc.lens == "fisheye" ? "KannalaBrandt8" : "PinHole") << "\"\n"
       << "Camera1.fx: " << rig.fx << "\nCamera1.fy: " << rig.fy << "\nCamera1.cx: " << rig.cx
       << "\nCamera1.cy: " << rig.cy << "\n";
    if (sc.lens == "fisheye") {
      for (int i = 0; i < 4; ++i) st << "Camera1.k" << i + 1 << ": " << rig.k[i] << "\n";
      if (stereo) {  // ORB-SLAM3's KannalaBrandt8 stereo: the second camera and where it is
        st << "Camera2.fx: " << rig.fx << "\nCamera2.fy: " << rig.fy << "\nCamera2.cx: " << rig.cx
           << "\nCamera2.cy: " << rig.cy << "\n";
        for (int i = 0; i < 4; ++i) st << "Camera2.k" << i + 1 << ": " << rig.k[i] << "\n";
        st << "Stereo.T_c1_c2: " << matrix(rig.T_c1_c2) << "\n";
      }
    }
    st << "Camera.width: " << rig.width << "\nCamera.height: " << rig.height << "\nCamera.fps: " << sc.fps << "\n"
       << "Sensor: \"" << sc.camera << "\"\n";
    if (stereo && sc.lens == "pinhole") st << "Stereo.b: " << rig.baseline << "\n";
    if (rgbd) st << "RGBD.DepthMapFactor: 1000.0\n";
    st << "Camera.T_b_c: " << matrix(rig.T_b_c) << "\n"
       << "Odometry.T_b_o: " << matrix(Eigen::Isometry3d::Identity()) << "\n"
       << "Odometry.WheelRadiusLeft: " << radius << "\nOdometry.WheelRadiusRight: " << radius
       << "\nOdometry.Track: " << track << "\nOdometry.TicksPerRevolution: " << sc.ticks_per_revolution
       << "\nOdometry.NoiseWheel: " << std::max(sc.wheel_noise, 1e-3) << "\n"
       << "Semantics.LabelSet: \"voc21\"\n";
    // The simulated robot never moves sideways (a real path is re-integrated from its forward
    // motion and turn): no skid. At the default (0.01 m/sqrt(m), for a robot whose skid is
    // unknown), the ORB-SLAM3 plugin's mono local BA let vision turn the map 4 deg too far in the
    // suite's hairpin (static: 0.27-0.42 % of the path; 0.04-0.08 % told the truth). The noise
    // floors keep the wheel edges finite.
    st << "Odometry.NoiseY: 0\n";
    if (!st) throw std::runtime_error("cannot write " + (dir / "settings.yaml").string());

    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf(
        "rvwo-sim: %s: %ld %s frames (%.0f s at %.0f Hz), %ld odometry readings at %.0f Hz, %d walkers; "
        "%.1f frames/s; %.1f MB in %s\n",
        sc.name.c_str(), frames_written, sc.camera.c_str(), duration, sc.fps, n_odo + 1, sc.odometry_rate,
        sc.walkers + sc.escorts, frames_written / el, (image_bytes + fs::file_size(rawlog_path)) / 1e6,
        dir.string().c_str());
    std::printf("rvwo-sim: per frame %.1f ms rendering, %.1f ms writing images, %.1f ms the rest\n",
                1e3 * render_s / frames_written, 1e3 * encode_s / frames_written,
                1e3 * (el - render_s - encode_s) / frames_written);
    return 0;
  } catch (const TCLAP::ArgException& e) {
    std::fprintf(stderr, "rvwo-sim: %s (%s)\n", e.error().c_str(), e.argId().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rvwo-sim: error: %s\n", e.what());
  }
  return 1;
}
