// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The estimator's parts that can be checked in isolation: stereo depth from a pair with a known
// disparity, RGB-D depth lookup, settings, bad frames. (End to end on simulated sequences:
// tests/apps/replay_test.cc.)
#include "rvwo/estimator/estimator.h"

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "rvwo/estimator/features.h"

namespace {

using namespace rvwo::estimator;

// A texture of grey rectangles on a grey background, like the simulator's walls.
cv::Mat texture(unsigned seed, int w = 640, int h = 480) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, w - 1), y(0, h - 1), size(6, 30), grey(0, 255);
  cv::Mat img(h, w, CV_8U, cv::Scalar(128));
  for (int i = 0; i < 700; ++i) {
    // Drawn as gcc did (tests/common/draw.h): a call's arguments last first.
    const int py = y(rng), px = x(rng), shade = grey(rng), height = size(rng), width = size(rng);
    const cv::Point p(px, py);
    cv::rectangle(img, p, p + cv::Point(width, height), cv::Scalar(shade), cv::FILLED);
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  return img;
}

TEST(Features, SpreadOverTheGridAndWithinBudget) {
  const cv::Mat img = texture(1);
  FeatureParams p;
  p.features = 600;
  const Features f = FeatureExtractor(p).extract(img);
  EXPECT_LE(f.size(), 600u);
  EXPECT_GE(f.size(), 500u);
  EXPECT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  // Every cell of a 4x3 grid gets a share.
  int cells[12] = {0};
  for (const auto& k : f.keypoints) ++cells[std::min(2, int(k.pt.y / 160)) * 4 + std::min(3, int(k.pt.x / 160))];
  for (int c : cells) EXPECT_GT(c, 20);
  // near() finds exactly the keypoints within the radius.
  const auto near = f.near(320, 240, 40);
  std::size_t brute = 0;
  for (const auto& k : f.keypoints) brute += std::hypot(k.pt.x - 320, k.pt.y - 240) <= 40;
  EXPECT_EQ(near.size(), brute);
}

// cv::ORB's pyramid as OpenCV 4 builds it (orb.cpp: each level resized from the one before with
// INTER_LINEAR_EXACT to cvRound(W / 1.2^n)), on ramps whose value is the level-0 coordinate: a
// keypoint on level n's pixel p, as cv::ORB reports it (p 1.2^n), is moved to the value there.
TEST(Features, KeypointsArePlacedOnTheirContent) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(752, 480)}) {
    cv::Mat ramp_x(size, CV_32F), ramp_y(size, CV_32F);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        ramp_x.at<float>(y, x) = static_cast<float>(x);
        ramp_y.at<float>(y, x) = static_cast<float>(y);
      }
    }
    cv::Mat level_x = ramp_x, level_y = ramp_y;
    for (int n = 1; n < 6; ++n) {
      const float s = static_cast<float>(std::pow(static_cast<double>(1.2f), n));
      const cv::Size sz(cvRound(size.width / s), cvRound(size.height / s));
      cv::resize(level_x, level_x, sz, 0, 0, cv::INTER_LINEAR_EXACT);
      cv::resize(level_y, level_y, sz, 0, 0, cv::INTER_LINEAR_EXACT);
      std::vector<cv::KeyPoint> kps;
      std::vector<cv::Point> at;  // away from the clamped first and last rows and columns
      for (int y = 1; y < sz.height - 1; y += 7) {
        for (int x = 1; x < sz.width - 1; x += 5) {
          kps.emplace_back(cv::Point2f(x * s, y * s), 31.f * s, -1.f, 0.f, n);
          at.emplace_back(x, y);
        }
      }
      const std::vector<cv::KeyPoint> reported = kps;
      placeOnTheirContent(size, 1.2, &kps);
      double worst = 0, worst_reported = 0;
      for (std::size_t i = 0; i < kps.size(); ++i) {
        const cv::Point2f truth(level_x.at<float>(at[i]), level_y.at<float>(at[i]));
        worst = std::max(worst, cv::norm(kps[i].pt - truth));
        worst_reported = std::max(worst_reported, cv::norm(reported[i].pt - truth));
        EXPECT_EQ(kps[i].octave, n);
      }
      EXPECT_LT(worst, 1e-3) << size << " level " << n;
      EXPECT_GT(worst_reported, 0.2) << size << " level " << n;  // what is mended is there to mend
    }
  }
  // Level 0 stays where it is.
  std::vector<cv::KeyPoint> kps{cv::KeyPoint(cv::Point2f(100.25f, 50.5f), 31.f, -1.f, 0.f, 0)};
  placeOnTheirContent(cv::Size(640, 480), 1.2, &kps);
  EXPECT_EQ(kps[0].pt, cv::Point2f(100.25f, 50.5f));
}

// End to end through cv::ORB: white squares on black, each seen on a level by its four corners'
// keypoints, whose mean is the square's centre whatever FAST's bias at a corner (the four
// biases cancel). Placed, those means sit on the centres; as cv::ORB reports them, up to 1.5 px
// off, up and to the left.
TEST(Features, CvOrbKeypointsPlacedOnTheirContent) {
  constexpr int kSide = 29, kStep = 43;  // px: 54 to 115 squares a level
  cv::Mat img(480, 640, CV_8U, cv::Scalar(0));
  std::vector<cv::Point2d> centres;
  for (int y = 30; y + kSide < 470; y += kStep) {
    for (int x = 30; x + kSide < 630; x += kStep) {
      img(cv::Rect(x, y, kSide, kSide)).setTo(255);
      centres.emplace_back(x + (kSide - 1) / 2.0, y + (kSide - 1) / 2.0);
    }
  }
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(5000, 1.2f, 6, 19, 0, 2, cv::ORB::FAST_SCORE, 31, 20);
  std::vector<cv::KeyPoint> reported;
  orb->detect(img, reported);
  std::vector<cv::KeyPoint> placed = reported;
  placeOnTheirContent(img.size(), 1.2, &placed);
  for (int level = 1; level < 6; ++level) {
    cv::Point2d sum_placed(0, 0), sum_reported(0, 0);
    int squares = 0;
    for (const cv::Point2d& c : centres) {
      // The keypoints of this level around this square's corners, one per corner.
      std::vector<std::size_t> at;
      for (std::size_t i = 0; i < reported.size(); ++i) {
        const cv::Point2f& p = reported[i].pt;
        if (reported[i].octave == level && std::abs(p.x - c.x) < kSide * 0.75 && std::abs(p.y - c.y) < kSide * 0.75)
          at.push_back(i);
      }
      int quadrants = 0;
      for (std::size_t i : at) quadrants |= 1 << ((reported[i].pt.x > c.x) + 2 * (reported[i].pt.y > c.y));
      if (at.size() != 4 || quadrants != 15) continue;
      cv::Point2d mean_placed(0, 0), mean_reported(0, 0);
      for (std::size_t i : at) {
        mean_placed += cv::Point2d(placed[i].pt) / 4.0;
        mean_reported += cv::Point2d(reported[i].pt) / 4.0;
      }
      sum_placed += mean_placed - c;
      sum_reported += mean_reported - c;
      ++squares;
    }
    ASSERT_GE(squares, 10) << "level " << level;
    const cv::Point2d off_placed = sum_placed / squares, off_reported = sum_reported / squares;
    // (Measured with OpenCV 4.6: reported 0.40-1.20 px off, placed 0.02-0.15: what is left is
    // FAST's corners on a level's pixel grid, averaged over the squares.)
    EXPECT_LT(cv::norm(off_placed), 0.2) << "level " << level << ": " << off_placed;
    EXPECT_GT(cv::norm(off_reported), 0.35) << "level " << level << ": " << off_reported;
    std::printf("[ figures  ] level %d: squares %d, mean offset reported (%.2f, %.2f) px, placed (%.2f, %.2f)\n", level,
                squares, off_reported.x, off_reported.y, off_placed.x, off_placed.y);
  }
}

// The SIMD sums (16 columns a block, the last block overlapping, 32-bit flushes for large patches)
// equal plain sums: worst-case contrast (0 against 255, so a 16-bit sum would overflow for h >= 8),
// every patch size the matcher uses and beyond, runs that end at the image's right edge.
TEST(Features, PatchSadsEqualPlainSums) {
  std::mt19937 rng(7);
  cv::Mat left(64, 200, CV_8U), right(64, 200, CV_8U);
  cv::randu(left, 0, 256);
  cv::randu(right, 0, 256);
  left(cv::Rect(0, 0, 100, 64)).setTo(0);
  right(cv::Rect(0, 0, 120, 64)).setTo(255);
  const auto plain = [&](int x, int y, int xr, int h) {
    std::uint32_t sad = 0;
    for (int dy = -h; dy <= h; ++dy)
      for (int dx = -h; dx <= h; ++dx)
        sad += std::abs(left.at<uchar>(y + dy, x + dx) - right.at<uchar>(y + dy, xr + dx));
    return sad;
  };
  for (int h : {1, 3, 5, 8, 10, 12, 13, 15}) {
    for (int trial = 0; trial < 40; ++trial) {
      const int y = std::uniform_int_distribution<int>(h, left.rows - 1 - h)(rng);
      const int x = std::uniform_int_distribution<int>(h, left.cols - 1 - h)(rng);
      const int n = std::uniform_int_distribution<int>(1, 60)(rng);
      // Half the runs end exactly at the right edge, the rest anywhere.
      const int last =
          trial % 2 ? right.cols - 1 - h : std::uniform_int_distribution<int>(h + n - 1, right.cols - 1 - h)(rng);
      const int xr = last - n + 1;
      std::vector<std::uint32_t> sads(n);
      patchSads(left, right, x, y, xr, n, h, sads.data());
      for (int p = 0; p < n; ++p) ASSERT_EQ(sads[p], plain(x, y, xr + p, h)) << "h " << h << " n " << n << " p " << p;
    }
  }
  // Patches of 0 against ones of 255, the largest SIMD patch (25 x 25): 2.4 x what 16 bits hold.
  std::uint32_t worst[16];
  patchSads(left, right, 50, 30, 40, 16, 12, worst);
  for (std::uint32_t w : worst) EXPECT_EQ(w, 25u * 25u * 255u);
}

TEST(Features, StereoDepthFromAKnownSubPixelDisparity) {
  const cv::Mat left = texture(2);
  for (double d : {9.0, 15.3, 30.7}) {
    cv::Mat right;
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -d, 0, 1, 0);
    cv::warpAffine(left, right, shift, left.size(), cv::INTER_LINEAR);
    const FeatureExtractor ex{FeatureParams{}};
    Features fl = ex.extract(left);
    const double bf = 48.0;
    matchStereo(left, right, bf, 0.5, 200, &fl);
    std::vector<double> err;
    for (std::size_t i = 0; i < fl.size(); ++i) {
      if (fl.depth[i] <= 0 || fl.keypoints[i].pt.x < d + 10) continue;
      err.push_back(std::fabs(fl.keypoints[i].pt.x - fl.u_right[i] - d));
      EXPECT_NEAR(fl.depth[i], bf / (fl.keypoints[i].pt.x - fl.u_right[i]), 1e-3);
    }
    ASSERT_GT(err.size(), 0.6 * fl.size()) << "disparity " << d;
    std::sort(err.begin(), err.end());
    EXPECT_LT(err[err.size() / 2], 0.15) << "median disparity error, disparity " << d;  // sub-pixel
    EXPECT_LT(err[err.size() * 95 / 100], 0.6) << "95th percentile, disparity " << d;
  }
}

// The row scan has no right-image features to lean on: where the row repeats itself (tiles, a
// fence) or the left patch is hidden in the right image, it must give no depth rather than a
// wrong one. Left: textured on the left half; on the right half, rows of identical squares every
// 9 to 17 px in the upper band and, in the lower band, a texture the right image does not share.
TEST(Features, StereoGivesNoDepthToRepeatedOrHiddenPatches) {
  constexpr double kDisparity = 10.4, kBf = 48.0;
  for (int period = 9; period <= 17; period += 2) {
    SCOPED_TRACE("period " + std::to_string(period) + " px");
    cv::Mat left = texture(3);
    cv::Rect tiles(320, 0, 320, 240), hidden(320, 240, 320, 240);
    left(tiles).setTo(cv::Scalar(40));
    for (int y = 4; y + 6 < tiles.height; y += period) {
      for (int x = 2; x + 6 < tiles.width; x += period) {
        cv::rectangle(left, cv::Rect(tiles.x + x, y, 6, 6), cv::Scalar(210), cv::FILLED);
      }
    }
    cv::Mat right;
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -kDisparity, 0, 1, 0);
    cv::warpAffine(left, right, shift, left.size(), cv::INTER_LINEAR);
    texture(4)(hidden).copyTo(right(hidden));  // what the left camera sees there, the right does not
    const FeatureExtractor ex{FeatureParams{}};
    Features f = ex.extract(left);
    matchStereo(left, right, kBf, 0.5, 200, &f);
    int in_tiles = 0, in_hidden = 0, in_texture = 0, depth_tiles = 0, depth_hidden = 0, good_texture = 0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      const cv::Point2f& p = f.keypoints[i].pt;
      const bool has = f.depth[i] > 0;
      // Patches that straddle a region's edge see both: left out of the count.
      const int margin = 25;
      if (p.x > tiles.x + margin && p.y < tiles.height - margin) {
        ++in_tiles;
        depth_tiles += has;
      } else if (p.x > hidden.x + margin && p.y > hidden.y + margin) {
        ++in_hidden;
        depth_hidden += has;
      } else if (p.x < tiles.x - margin && p.x > kDisparity + margin) {
        ++in_texture;
        good_texture += has && std::fabs(p.x - f.u_right[i] - kDisparity) < 0.5;
      }
    }
    ASSERT_GT(in_tiles, 50);
    ASSERT_GT(in_hidden, 50);
    ASSERT_GT(in_texture, 200);
    EXPECT_EQ(depth_tiles, 0) << "of " << in_tiles << " keypoints on the repeated squares";
    EXPECT_LE(depth_hidden, in_hidden / 20) << "of " << in_hidden << " keypoints the right camera cannot see";
    EXPECT_GE(good_texture, 0.8 * in_texture) << "of " << in_texture << " keypoints on plain texture";
  }
}

TEST(Features, DepthImageGivesURight) {
  Features f;
  f.keypoints = {cv::KeyPoint(10.2f, 20.0f, 31), cv::KeyPoint(30.0f, 5.0f, 31), cv::KeyPoint(-1.0f, 5.0f, 31)};
  f.u_right.assign(3, -1);
  f.depth.assign(3, -1);
  cv::Mat depth(40, 40, CV_16U, cv::Scalar(0));
  depth.at<std::uint16_t>(20, 10) = 2500;  // 2.5 m at 1000 per metre
  depthFromImage(depth, 1000.0, 40.0, &f);
  EXPECT_NEAR(f.depth[0], 2.5, 1e-6);
  EXPECT_NEAR(f.u_right[0], 10.2 - 40.0 / 2.5, 1e-5);
  EXPECT_EQ(f.depth[1], -1);  // no depth there
  EXPECT_EQ(f.depth[2], -1);  // outside
}

const char* kSettings = R"(%YAML:1.0
Sensor: "stereo"
Camera.type: "PinHole"
Camera1.fx: 400
Camera1.fy: 400
Camera1.cx: 319.5
Camera1.cy: 239.5
Camera.width: 640
Camera.height: 480
Camera.fps: 30
Stereo.b: 0.12
Camera.T_b_c: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [0, 0, 1, 0.25, -1, 0, 0, 0, 0, -1, 0, 0.4, 0, 0, 0, 1]
Estimator.Features: 800
Tracking.SlipHold: 1.5
Tracking.TrustedMaxPs: 0.2
Reliability.Ph: 0.8
)";

// A stage's durations: mean, median, 95th percentile (the sample at 0.95 n, rounded down) and max.
TEST(Report, TimingStatsOfDurations) {
  const TimingStats s = TimingStats::of({5, 1, 3, 2, 4, 9, 8, 7, 6, 10});
  EXPECT_EQ(s.count, 10u);
  EXPECT_DOUBLE_EQ(s.mean, 5.5);
  EXPECT_EQ(s.p50, 6);
  EXPECT_EQ(s.p95, 10);
  EXPECT_EQ(s.max, 10);
  const TimingStats none = TimingStats::of({});
  EXPECT_EQ(none.count, 0u);
  EXPECT_EQ(none.p50, 0);
}

TEST(Options, FromSettings) {
  const rvwo::Settings s = rvwo::Settings::fromString(kSettings, "s.yaml");
  const Rig rig = readRig(s);
  EXPECT_EQ(rig.sensor, Sensor::kStereo);
  EXPECT_DOUBLE_EQ(rig.bf(), 48.0);
  EXPECT_DOUBLE_EQ(rig.T_b_c.translation().z(), 0.4);
  EXPECT_DOUBLE_EQ(rig.T_b_c.linear()(1, 0), -1.0);
  const EstimatorOptions o = readEstimatorOptions(s);
  EXPECT_EQ(o.features, 800);
  EXPECT_DOUBLE_EQ(o.tracking.slip_hold, 1.5);
  EXPECT_DOUBLE_EQ(o.tracking.trusted_max_ps, 0.2);
  EXPECT_EQ(o.tracking.slip_hold_min_frames, 3);  // the default where the file is silent
  EXPECT_TRUE(o.tracking.wheel_gate);             // on by default
  EXPECT_DOUBLE_EQ(o.mono_max_mapping_lag, 0.25);
  EXPECT_DOUBLE_EQ(readEstimatorOptions(rvwo::Settings::fromString(
                                            std::string(kSettings) + "Estimator.MonoMaxMappingLag: 0\n", "s.yaml"))
                       .mono_max_mapping_lag,
                   0.0);
  EXPECT_FALSE(
      readEstimatorOptions(rvwo::Settings::fromString(std::string(kSettings) + "Tracking.WheelGate: 0\n", "s.yaml"))
          .tracking.wheel_gate);
  EXPECT_DOUBLE_EQ(o.reliability.p_h, 0.8);
  // The label dilation under the ORB-SLAM3 plugin's key, and under the estimator's old one.
  EXPECT_EQ(readEstimatorOptions(
                rvwo::Settings::fromString(std::string(kSettings) + "Segmentation.LabelDilation: 3\n", "s.yaml"))
                .label_dilation_px,
            3);
  EXPECT_EQ(readEstimatorOptions(
                rvwo::Settings::fromString(std::string(kSettings) + "Estimator.LabelDilation: 5\n", "old.yaml"))
                .label_dilation_px,
            5);
}

// One radial-tangential camera (TUM fr1's published coefficients) is undistorted on input onto its
// own intrinsics: a bright dot drawn where OpenCV's model puts a point lands where the pinhole puts
// it, and depth moves with the image (nearest, none outside it).
TEST(Options, DistortedPinholeIsUndistortedOnInput) {
  std::string y = kSettings;
  const std::string stereo = "Sensor: \"stereo\"";
  y.replace(y.find(stereo), stereo.size(), "Sensor: \"rgbd\"");
  y += "RGBD.DepthMapFactor: 1000\nCamera1.k1: 0.2624\nCamera1.k2: -0.9531\nCamera1.p1: -0.0054\n"
       "Camera1.p2: 0.0026\nCamera1.k3: 1.1633\n";
  const Rig rig = readRig(rvwo::Settings::fromString(y, "s.yaml"));
  ASSERT_TRUE(rig.rectification);
  EXPECT_DOUBLE_EQ(rig.camera->fx(), 400);
  // The coefficients kept, for a host that undistorts keypoints itself (ORB-SLAM3's settings).
  EXPECT_EQ(rig.radtan, (std::array<double, 5>{0.2624, -0.9531, -0.0054, 0.0026, 1.1633}));
  const cv::Mat K = (cv::Mat_<double>(3, 3) << 400, 0, 319.5, 0, 400, 239.5, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(5, 1) << 0.2624, -0.9531, -0.0054, 0.0026, 1.1633);
  for (const cv::Point3d P :
       {cv::Point3d(0.5, 0.3, 1.0), cv::Point3d(-0.6, -0.35, 1.2), cv::Point3d(-0.55, 0.4, 1.0)}) {
    std::vector<cv::Point2d> raw;
    cv::projectPoints(std::vector<cv::Point3d>{P}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, raw);
    cv::Mat image(480, 640, CV_8U, cv::Scalar(0));
    cv::circle(image, cv::Point(cvRound(raw[0].x * 16), cvRound(raw[0].y * 16)), 3 * 16, cv::Scalar(255), cv::FILLED,
               cv::LINE_AA, 4);
    cv::Mat out, none;
    rig.rectification->rectify(image, cv::Mat(), &out, &none);
    const cv::Moments m = cv::moments(out);
    const Eigen::Vector2d pinhole = rig.camera->project(Eigen::Vector3d(P.x, P.y, P.z));
    EXPECT_NEAR(m.m10 / m.m00, pinhole.x(), 0.25) << P;
    EXPECT_NEAR(m.m01 / m.m00, pinhole.y(), 0.25) << P;
    EXPECT_GT(cv::norm(raw[0] - cv::Point2d(pinhole.x(), pinhole.y())), 5.0) << "the lens moved the point";
    cv::Mat depth(480, 640, CV_16U, cv::Scalar(0));
    depth.at<std::uint16_t>(cvRound(raw[0].y), cvRound(raw[0].x)) = 1234;
    const cv::Mat moved = rig.rectification->rectifyLeftDepth(depth);
    cv::Point at;
    cv::minMaxLoc(moved, nullptr, nullptr, nullptr, &at);
    EXPECT_EQ(moved.at<std::uint16_t>(at), 1234);
    EXPECT_LT(cv::norm(cv::Point2d(at) - cv::Point2d(pinhole.x(), pinhole.y())), 1.5) << P;
  }
}

TEST(Options, ErrorsNameTheKey) {
  auto message = [](const std::string& yaml) {
    try {
      const rvwo::Settings s = rvwo::Settings::fromString(yaml, "s.yaml");
      readRig(s);
      readEstimatorOptions(s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string y = kSettings;
  const std::string no_tbc = y.substr(0, y.find("Camera.T_b_c")) + "Estimator.Features: 800\n";
  EXPECT_EQ(message(no_tbc), "s.yaml: missing key Camera.T_b_c");
  std::string no_fx = y;
  no_fx.replace(no_fx.find("Camera1.fx: 400\n"), 16, "");
  EXPECT_EQ(message(no_fx), "s.yaml: missing key Camera1.fx");
  // A distorted pinhole stereo pair (ORB-SLAM3's radial-tangential keys): refused, not ignored.
  EXPECT_EQ(message(y + "Camera1.k1: 0\nCamera1.p2: 0.0026\n"),
            "s.yaml: Camera1.p2 is not 0: a stereo pair is taken rectified (Stereo.b), without distortion");
  EXPECT_EQ(message(y + "Camera1.k1: 0\nCamera1.k2: 0\nCamera1.p1: 0\nCamera1.p2: 0\nCamera1.k3: 0\n"), "no error");
  std::string bad_rot = y;
  bad_rot.replace(bad_rot.find("[0, 0, 1,"), 9, "[0, 0, 2,");
  EXPECT_NE(message(bad_rot).find("Camera.T_b_c is not a rigid transform"), std::string::npos);
  std::string bad_window = y + "Estimator.Window: 1\n";
  EXPECT_NE(message(bad_window).find("Estimator.Window"), std::string::npos);
  auto with = [&](const std::string& from, const std::string& to) {
    std::string c = y;
    return c.replace(c.find(from), from.size(), to);
  };
  EXPECT_EQ(message(with("SlipHold: 1.5", "SlipHold: -1")), "s.yaml: tracking options: Tracking.SlipHold: >= 0 s");
  EXPECT_NE(message(y + "Tracking.SlipHoldMinFrames: 0\n").find("Tracking.SlipHoldMinFrames"), std::string::npos);
  EXPECT_NE(message(y + "Tracking.SlipMinInliers: 0.5\n").find("Tracking.SlipMinInliers"), std::string::npos);
  EXPECT_NE(message(with("TrustedMaxPs: 0.2", "TrustedMaxPs: 0")).find("Tracking.TrustedMaxPs"), std::string::npos);
  EXPECT_NE(message(y + "Estimator.MonoMaxMappingLag: -0.1\n").find("Estimator.MonoMaxMappingLag: >= 0"),
            std::string::npos);
  EXPECT_EQ(message(y + "Segmentation.LabelDilation: 2.5\n"),
            "s.yaml: Segmentation.LabelDilation must be a whole number of pixels, 0 to 100");
  EXPECT_EQ(message(y + "Segmentation.LabelDilation: 3\nEstimator.LabelDilation: 3\n"),
            "s.yaml: Segmentation.LabelDilation and its old name Estimator.LabelDilation are both given; keep "
            "Segmentation.LabelDilation");
}

// Fisheye stereo (ORB-SLAM3's KannalaBrandt8 pair, the right camera turned a little): the
// rectified pinhole rig and the remap tables agree with the raw cameras. A point seen by both raw
// cameras lands, in the rectified pair, on one row with the disparity bf / z, and the tables send
// those rectified pixels back to the raw pixels the fisheyes saw.
TEST(Options, FisheyeStereoIsRectifiedOnInput) {
  const double k1 = -0.0105, k2 = 0.0463, k3 = -0.0431, k4 = 0.0079;
  const rvwo::KannalaBrandtCamera left(286, 286, 423.5, 399.5, k1, k2, k3, k4),
      right(290, 288, 420.0, 401.0, k1, k2, k3, k4);
  Eigen::Isometry3d T_c1_c2 = Eigen::Isometry3d::Identity();
  T_c1_c2.translation() << 0.064, 0.001, -0.002;
  T_c1_c2.linear() = (Eigen::AngleAxisd(0.4 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                      Eigen::AngleAxisd(-0.3 * M_PI / 180, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix();
  Rig rig;
  rig.width = 848;
  rig.height = 800;
  rig.T_b_c.translation() << 0.25, 0, 0.4;
  rectifyFisheyeStereo(left, right, T_c1_c2, &rig);
  ASSERT_TRUE(rig.rectification);
  EXPECT_EQ(rig.radtan, (std::array<double, 5>{}));  // no radial-tangential model: ORB-SLAM3 refuses the pair
  ASSERT_EQ(rig.camera->kind(), rvwo::CameraModel::Kind::kPinhole);
  EXPECT_NEAR(rig.baseline, T_c1_c2.translation().norm(), 1e-9);
  EXPECT_NEAR(rig.T_b_c.translation().x(), 0.25, 1e-12);  // rectification turns the camera, never moves it
  const Eigen::Isometry3d T_c1_rect = Eigen::Isometry3d(Eigen::Translation3d(-0.25, 0, -0.4)) * rig.T_b_c;
  // Rectified pixels on the grid (integer columns and disparities), so that the tables are read
  // where they were computed, without interpolation.
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> col(0, 847), row(0, 799), disparity(2, 40);
  const StereoRectification& table = *rig.rectification;
  int checked = 0;
  for (int i = 0; i < 300; ++i) {
    const int u = col(rng), v = row(rng), d = disparity(rng);
    if (u - d < 0) continue;
    const double z = rig.bf() / d;  // in the rectified left camera
    const Eigen::Vector3d P_rect(z * (u - rig.camera->cx()) / rig.camera->fx(),
                                 z * (v - rig.camera->cy()) / rig.camera->fy(), z);
    const Eigen::Vector3d P_c1 = T_c1_rect * P_rect, P_c2 = T_c1_c2.inverse() * P_c1;
    const Eigen::Vector2d raw_l(table.left_x.at<float>(v, u), table.left_y.at<float>(v, u));
    const Eigen::Vector2d raw_r(table.right_x.at<float>(v, u - d), table.right_y.at<float>(v, u - d));
    if (raw_l.minCoeff() < 0 || raw_r.minCoeff() < 0 || raw_l.x() > 847 || raw_r.x() > 847 || raw_l.y() > 799 ||
        raw_r.y() > 799)
      continue;  // outside what the raw cameras see
    EXPECT_LT((raw_l - left.project(P_c1)).norm(), 1e-3) << u << " " << v;
    EXPECT_LT((raw_r - right.project(P_c2)).norm(), 1e-3) << u << " " << v << " " << d;
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

TEST(Estimator, RefusesBadFrames) {
  const rvwo::Settings s = rvwo::Settings::fromString(kSettings, "s.yaml");
  EstimatorOptions o = readEstimatorOptions(s);
  o.deterministic = true;
  Estimator e(readRig(s), o);
  FrameInput f;
  f.timestamp = 1.0;
  f.image = cv::Mat(240, 320, CV_8U, cv::Scalar(0));
  f.right = f.image;
  try {
    e.addFrame(f);
    FAIL() << "a 320x240 frame was taken";
  } catch (const std::invalid_argument& ex) {
    EXPECT_EQ(std::string(ex.what()), "frame: camera image is 320x240, the settings say 640x480");
  }
  f.image = texture(3);
  f.right = cv::Mat();
  EXPECT_THROW(e.addFrame(f), std::invalid_argument);  // stereo without the right image
  f.right = f.image;
  e.addFrame(f);
  EXPECT_THROW(e.addFrame(f), std::invalid_argument);  // same time again
  EXPECT_THROW(e.addWheelAngles(0.5, NAN, 0.0), std::invalid_argument);
  e.finish();
  EXPECT_EQ(e.trajectory().size(), 1u);
}

// A segmenter that sees only background (class 0), counting its calls (from its own thread).
class Background final : public rvwo::Segmenter {
 public:
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    ++calls;
    return {cv::Mat(image.size(), CV_32S, cv::Scalar(0)), {}};
  }
  const std::vector<std::string>& classNames() const override { return names_; }
  std::atomic<int> calls{0};

 private:
  std::vector<std::string> names_ = rvwo::SemanticPriors::builtin("voc21").classes();
};

// A synthetic stereo sequence for the threaded estimator: the robot drives at 0.25 m/s towards a
// textured wall 3 m ahead; each frame is the first one zoomed about the principal point by Z0 / Z,
// the right image shifted by bf / Z. Odometry (the robot's own pose) at 90 Hz, over-reading the
// distance by 3 %. Returns the distance driven.
constexpr double kWallSpeed = 0.25, kWallOverRead = 1.03;
double driveTowardsAWall(Estimator& e, const Rig& rig, int n, const std::function<void(int)>& before_frame = {}) {
  const cv::Mat wall = texture(4, 1280, 960);  // twice the image: zooming in stays textured
  const double z0 = 3.0, fps = 30;
  const double cx = 319.5, cy = 239.5, bf = rig.bf();
  for (int k = 0; k < n; ++k) {
    if (before_frame) before_frame(k);
    const double t = k / fps, z = z0 - kWallSpeed * t;
    for (int i = k == 0 ? 0 : 3 * k - 2; i <= 3 * k; ++i) {
      const double to = i / (3 * fps);
      e.addOdometryPose(to, rvwo::SE2(kWallOverRead * kWallSpeed * to, 0, 0));
    }
    const double scale = z0 / z * 0.5;  // wall pixels -> image pixels (the wall image is 2x)
    cv::Mat left, right;
    const cv::Mat A = (cv::Mat_<double>(2, 3) << scale, 0, cx - scale * 639.5, 0, scale, cy - scale * 479.5);
    cv::warpAffine(wall, left, A, cv::Size(640, 480));
    cv::Mat B = A.clone();
    B.at<double>(0, 2) -= bf / z;
    cv::warpAffine(wall, right, B, cv::Size(640, 480));
    e.addFrame({t, left, right, {}});
  }
  return kWallSpeed * (n - 1) / fps;
}

// The threaded estimator (tracking, local mapping, segmentation each in a thread) recovers the
// distance driven; under ThreadSanitizer (scripts/test.sh) it checks the threads.
TEST(Estimator, ThreadedTracksTowardsAWall) {
  const rvwo::Settings s = rvwo::Settings::fromString(kSettings, "s.yaml");
  const Rig rig = readRig(s);
  EstimatorOptions o = readEstimatorOptions(s);
  o.deterministic = false;
  auto segmenter = std::make_shared<Background>();
  Estimator e(rig, o, segmenter);
  const int n = 60;
  const double driven = driveTowardsAWall(e, rig, n);
  e.finish();
  const auto poses = e.trajectory();
  ASSERT_EQ(poses.size(), static_cast<std::size_t>(n));
  // Vision corrects the wheels' 3 % over-reading.
  EXPECT_NEAR(poses.back().T_w_b.translation().x(), driven, 0.01);
  EXPECT_NEAR(poses.back().T_w_b.translation().y(), 0.0, 0.01);
  EXPECT_GT(e.report().keyframes, 1u);
  EXPECT_GT(segmenter->calls.load(), 0);
}

// Threaded mono waits for local mapping (Estimator.MonoMaxMappingLag; 0 here: it never tracks
// past an unmapped keyframe's next frame), and the report's timings show the waits; stereo never
// waits, whatever the setting. Either way the drive is measured.
TEST(Estimator, ThreadedMonoWaitsForLocalMapping) {
  auto waits = [](const rvwo::estimator::Report& r) {
    for (const auto& [stage, stats] : r.timings) {
      if (stage == "wait for mapping") return stats.count;
    }
    return std::size_t{0};
  };
  for (const bool mono : {true, false}) {
    SCOPED_TRACE(mono ? "mono" : "stereo");
    std::string yaml = kSettings;
    if (mono) yaml.replace(yaml.find("Sensor: \"stereo\""), 16, "Sensor: \"mono\"");
    const rvwo::Settings s = rvwo::Settings::fromString(yaml, "s.yaml");
    const Rig rig = readRig(s);
    EstimatorOptions o = readEstimatorOptions(s);
    o.deterministic = false;
    o.mono_max_mapping_lag = 0;
    Estimator e(rig, o, nullptr);
    const double driven = driveTowardsAWall(e, rig, 60);
    e.finish();
    const auto poses = e.trajectory();
    ASSERT_EQ(poses.size(), 60u);
    EXPECT_NEAR(poses.back().T_w_b.translation().x(), driven, mono ? 0.03 : 0.01);
    const rvwo::estimator::Report r = e.report();
    EXPECT_GT(r.keyframes, 1u);
    if (mono) {
      EXPECT_GE(waits(r), 1u);
    } else {
      EXPECT_EQ(waits(r), 0u);
    }
  }
}

// A segmenter whose labels (background) come only once the test opens its gate, or that fails.
class Gated final : public rvwo::Segmenter {
 public:
  explicit Gated(bool fail = false) : fail_(fail) {}
  rvwo::Segmentation segment(const cv::Mat& image, const rvwo::FrameInfo&) override {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [&] { return open_; });
    if (fail_) throw std::runtime_error("no labels");
    return {cv::Mat(image.size(), CV_32S, cv::Scalar(0)), {}};
  }
  const std::vector<std::string>& classNames() const override { return names_; }
  void open() {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }

 private:
  const bool fail_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
  std::vector<std::string> names_ = rvwo::SemanticPriors::builtin("voc21").classes();
};

// Threaded, a keyframe's new landmarks do not count as vision until its labels came: with the
// labels held back, every frame follows the (3 % long) wheels; once they come, vision takes over
// again and the rest of the drive is measured right. A segmenter that fails gives no labels to
// wait for: vision counts from the start. (Held back for long, the segmentation queue would drop
// keyframes, and their landmarks would count; here they are held for half a second.)
TEST(Estimator, ThreadedVisionWaitsForAKeyframesLabels) {
  const rvwo::Settings s = rvwo::Settings::fromString(kSettings, "s.yaml");
  const Rig rig = readRig(s);
  EstimatorOptions o = readEstimatorOptions(s);
  o.deterministic = false;
  const int n = 60, opened_at = 15;
  {
    auto segmenter = std::make_shared<Gated>();
    Estimator e(rig, o, segmenter);
    driveTowardsAWall(e, rig, n, [&](int k) {
      if (k == opened_at) segmenter->open();
    });
    e.finish();
    const auto poses = e.trajectory();
    ASSERT_EQ(poses.size(), static_cast<std::size_t>(n));
    // Held back: on the wheels (the pose comes a frame late: the gate opens while frame
    // opened_at - 1 may still be tracked). (Local BA still calibrates the wheels from these
    // landmarks: the poses are not the raw readings.)
    for (int k = 1; k < opened_at - 1; ++k) EXPECT_FALSE(poses[k].visual) << "frame " << k;
    // Labelled: vision again, and the second half's travel is the true one (the wheels' would be
    // 3 % = 7.5 mm longer).
    EXPECT_TRUE(poses[n - 1].visual);
    const double travel = poses[n - 1].T_w_b.translation().x() - poses[opened_at + 5].T_w_b.translation().x();
    EXPECT_NEAR(travel, kWallSpeed * (n - 1 - opened_at - 5) / 30.0, 0.004);
  }
  {
    auto segmenter = std::make_shared<Gated>(true);
    segmenter->open();
    Estimator e(rig, o, segmenter);
    const double driven = driveTowardsAWall(e, rig, n);
    e.finish();
    const auto poses = e.trajectory();
    ASSERT_EQ(poses.size(), static_cast<std::size_t>(n));
    EXPECT_NEAR(poses.back().T_w_b.translation().x(), driven, 0.01);
    EXPECT_GE(std::count_if(poses.begin(), poses.end(), [](const PoseEstimate& p) { return p.visual; }), n - 5);
  }
}

}  // namespace
