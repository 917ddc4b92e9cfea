// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Rawlogs: a round trip for each observation type RVWO uses (stereo with embedded and external
// images, RGB-D, mono, odometry with encoders), and a truncated or corrupt file: one error that
// names the record, with every record before it read intact.
#include "support/rawlog.h"

#include <gtest/gtest.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/serialization/CArchive.h>
#include <mrpt/system/datetime.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../common/temp.h"

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;
using namespace mrpt::obs;

mrpt::img::CImage pattern(int w, int h, int seed) {
  mrpt::img::CImage img(w, h, mrpt::img::CH_GRAY);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) *img(x, y) = static_cast<uint8_t>((x * 7 + y * 13 + seed * 31) % 251);
  }
  return img;
}

mrpt::img::TCamera camera(int w, int h) {
  mrpt::img::TCamera c;
  c.ncols = w;
  c.nrows = h;
  c.setIntrinsicParamsFromValues(400, 401, w / 2.0, h / 2.0);
  return c;
}

fs::path fresh(const std::string& name) {
  const fs::path dir = rvwo::test::scratch(name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(Rawlog, RoundTripOfEveryObservationType) {
  const fs::path dir = fresh("rvwo_rawlog_roundtrip");
  const std::string path = (dir / "seq.rawlog").string();
  fs::create_directories(RawlogWriter::imagesFolder(path));
  {
    RawlogWriter w(path);
    CObservationStereoImages stereo;  // embedded images
    stereo.sensorLabel = "CAMERA";
    stereo.timestamp = mrpt::Clock::fromDouble(100.0);
    stereo.imageLeft = pattern(64, 48, 1);
    stereo.imageRight = pattern(64, 48, 2);
    stereo.hasImageRight = true;
    stereo.leftCamera = stereo.rightCamera = camera(64, 48);
    stereo.rightCameraPose = mrpt::poses::CPose3DQuat(0.12, 0, 0, mrpt::math::CQuaternionDouble());
    w.write(stereo);

    CObservationStereoImages external = stereo;  // external images in <rawlog>_Images/
    external.timestamp = mrpt::Clock::fromDouble(100.1);
    stereo.imageLeft.saveToFile(RawlogWriter::imagesFolder(path) + "/L_000001.png");
    stereo.imageRight.saveToFile(RawlogWriter::imagesFolder(path) + "/R_000001.png");
    external.imageLeft.setExternalStorage("L_000001.png");
    external.imageRight.setExternalStorage("R_000001.png");
    w.write(external);

    CObservationOdometry odo;
    odo.sensorLabel = "ODOMETRY";
    odo.timestamp = mrpt::Clock::fromDouble(100.105);
    odo.odometry = mrpt::poses::CPose2D(1.5, -0.25, 0.3);
    odo.hasEncodersInfo = true;
    odo.encoderLeftTicks = 1234;
    odo.encoderRightTicks = -56;
    odo.hasVelocities = true;
    odo.velocityLocal = mrpt::math::TTwist2D(0.4, 0, 0.1);
    w.write(odo);

    CObservation3DRangeScan rgbd;
    rgbd.sensorLabel = "RGBD";
    rgbd.timestamp = mrpt::Clock::fromDouble(100.2);
    rgbd.hasIntensityImage = true;
    rgbd.intensityImage = pattern(32, 24, 3);
    rgbd.hasRangeImage = true;
    rgbd.range_is_depth = true;
    rgbd.rangeUnits = 1e-3f;
    rgbd.rangeImage_setSize(24, 32);
    for (int r = 0; r < 24; ++r) {
      for (int c = 0; c < 32; ++c) rgbd.rangeImage(r, c) = static_cast<uint16_t>(1000 + r * 32 + c);
    }
    rgbd.cameraParams = rgbd.cameraParamsIntensity = camera(32, 24);
    w.write(rgbd);

    CObservationImage mono;
    mono.sensorLabel = "CAMERA";
    mono.timestamp = mrpt::Clock::fromDouble(100.3);
    mono.image = pattern(40, 30, 4);
    mono.cameraParams = camera(40, 30);
    w.write(mono);
    EXPECT_EQ(w.count(), 5u);
  }
  RawlogReader r(path);
  auto stereo = std::dynamic_pointer_cast<CObservationStereoImages>(*r.next());
  ASSERT_TRUE(stereo);
  EXPECT_EQ(stereo->sensorLabel, "CAMERA");
  EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(stereo->timestamp), 100.0);
  EXPECT_EQ(*stereo->imageRight(10, 7), *pattern(64, 48, 2)(10, 7));
  EXPECT_DOUBLE_EQ(stereo->leftCamera.fx(), 400);
  EXPECT_DOUBLE_EQ(stereo->rightCameraPose.x(), 0.12);
  auto external = std::dynamic_pointer_cast<CObservationStereoImages>(*r.next());
  ASSERT_TRUE(external);
  EXPECT_TRUE(external->imageLeft.isExternallyStored());
  external->imageLeft.forceLoad();
  EXPECT_EQ(external->imageLeft.getWidth(), 64u);
  EXPECT_EQ(*external->imageLeft(33, 21), *pattern(64, 48, 1)(33, 21));
  auto odo = std::dynamic_pointer_cast<CObservationOdometry>(*r.next());
  ASSERT_TRUE(odo);
  EXPECT_DOUBLE_EQ(odo->odometry.phi(), 0.3);
  EXPECT_EQ(odo->encoderLeftTicks, 1234);
  EXPECT_EQ(odo->encoderRightTicks, -56);
  EXPECT_DOUBLE_EQ(odo->velocityLocal.vx, 0.4);
  auto rgbd = std::dynamic_pointer_cast<CObservation3DRangeScan>(*r.next());
  ASSERT_TRUE(rgbd);
  EXPECT_EQ(rgbd->rangeImage(5, 7), 1000 + 5 * 32 + 7);
  EXPECT_FLOAT_EQ(rgbd->rangeUnits, 1e-3f);
  EXPECT_EQ(*rgbd->intensityImage(3, 4), *pattern(32, 24, 3)(3, 4));
  auto mono = std::dynamic_pointer_cast<CObservationImage>(*r.next());
  ASSERT_TRUE(mono);
  EXPECT_EQ(*mono->image(39, 29), *pattern(40, 30, 4)(39, 29));
  EXPECT_FALSE(r.next().has_value());
  EXPECT_FALSE(r.next().has_value());
  EXPECT_EQ(r.count(), 5u);
}

std::string writeOdometry(const fs::path& dir, int n, int compression) {
  const std::string path = (dir / "odo.rawlog").string();
  RawlogWriter w(path, compression);
  for (int i = 0; i < n; ++i) {
    CObservationOdometry o;
    o.sensorLabel = "ODOMETRY";
    o.timestamp = mrpt::Clock::fromDouble(i * 0.01);
    o.odometry = mrpt::poses::CPose2D(0.01 * i, 0, 0);
    w.write(o);
  }
  return path;
}

TEST(Rawlog, TruncatedFileNamesTheRecordAndKeepsWhatCameBefore) {
  const fs::path dir = fresh("rvwo_rawlog_truncated");
  const std::string path = writeOdometry(dir, 200, 0);  // uncompressed: a cut lands inside a record
  fs::resize_file(path, fs::file_size(path) * 6 / 10 + 7);
  RawlogReader r(path);
  std::size_t good = 0;
  try {
    while (auto o = r.next()) {
      auto odo = std::dynamic_pointer_cast<CObservationOdometry>(*o);
      ASSERT_TRUE(odo);
      EXPECT_DOUBLE_EQ(odo->odometry.x(), 0.01 * good);  // every record before the cut is intact
      ++good;
    }
    FAIL() << "a truncated rawlog read to its end";
  } catch (const RawlogError& e) {
    EXPECT_EQ(e.index(), good);
    EXPECT_GT(good, 100u);
    EXPECT_LT(good, 130u);
    const std::string what = e.what();
    EXPECT_NE(what.find(path + ": record " + std::to_string(good) + ": truncated or corrupt"), std::string::npos)
        << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
  }
}

TEST(Rawlog, CorruptBytesAndMissingFileGetClearErrors) {
  const fs::path dir = fresh("rvwo_rawlog_corrupt");
  // Large enough that zlib inflates it in several reads (a real rawlog, with images, is far larger):
  // the damage lies in a later chunk than the first records.
  const std::string path = writeOdometry(dir, 4000, 1);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(path) / 2));
    const char junk[16] = {'\xff', '\x00', '\x13', '\x37', '\xff', '\xff', '\xff', '\xff',
                           'n',    'o',    't',    'a',    'r',    'e',    'c',    'o'};
    f.write(junk, sizeof junk);
  }
  RawlogReader r(path);
  std::size_t good = 0;
  EXPECT_THROW(
      {
        while (r.next()) ++good;
      },
      RawlogError);
  EXPECT_GT(good, 100u);
  EXPECT_LT(good, 4000u);
  EXPECT_THROW(RawlogReader((dir / "none.rawlog").string()), std::runtime_error);
  // Not a rawlog at all: said so, in one line, with MRPT's cause and not its banner or stack trace.
  std::ofstream(dir / "text.rawlog") << "this is a text file, not a rawlog\n";
  RawlogReader text((dir / "text.rawlog").string());
  try {
    text.next();
    FAIL() << "a text file read as a rawlog";
  } catch (const RawlogError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.index(), 0u);
    EXPECT_NE(what.find(": record 0: not a rawlog, or corrupt from its start ("), std::string::npos) << what;
    EXPECT_EQ(what.find("===="), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // An empty file is an empty rawlog.
  std::ofstream(dir / "empty.rawlog").close();
  RawlogReader empty((dir / "empty.rawlog").string());
  EXPECT_FALSE(empty.next().has_value());
}

// An embedded image whose size in the file no machine can hold (2^21 x 2^21 pixels): MRPT asks
// OpenCV for the buffer before reading a pixel, the allocation fails, and the record is reported
// as corrupt (found by fuzzing, docs/decisions/0013).
TEST(Rawlog, EmbeddedImageOfImpossibleSizeIsACorruptRecord) {
  const fs::path dir = fresh("rvwo_rawlog_huge_image");
  const std::string path = (dir / "huge.rawlog").string();
  {
    CObservationOdometry odo;
    odo.sensorLabel = "ODOMETRY";
    CObservationImage mono;
    mono.sensorLabel = "CAMERA";
    mono.image = pattern(37, 23, 1);
    mrpt::io::CFileOutputStream f(path);  // uncompressed, so the bytes can be edited in place
    auto archive = mrpt::serialization::archiveFrom(f);
    archive << odo << mono;
  }
  // CImage's record holds the width and height as 32-bit integers, side by side, after its
  // class name: set both to 2^21.
  std::string bytes = rvwo::test::slurp(path);
  const std::int32_t size[2] = {37, 23}, huge[2] = {1 << 21, 1 << 21};
  const std::size_t size_at =
      bytes.find(std::string(reinterpret_cast<const char*>(size), sizeof size), bytes.find("mrpt::img::CImage"));
  ASSERT_NE(size_at, std::string::npos);
  bytes.replace(size_at, sizeof huge, reinterpret_cast<const char*>(huge), sizeof huge);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;

  RawlogReader r(path);
  ASSERT_TRUE(r.next());  // the odometry record before it
  try {
    r.next();
    FAIL() << "an image of 2^42 pixels was read";
  } catch (const RawlogError& e) {
    EXPECT_EQ(e.index(), 1u);
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": record 1: truncated or corrupt (", 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
  }
}

// The gz check before replay: a whole stream is intact, one with a flipped bit damaged (though
// the reader delivers records before the damage shows), one cut short truncated, and a plain
// (uncompressed) file has no check to make.
TEST(Rawlog, TheStreamCheckTellsDamageFromACutAndFromNoCheck) {
  const fs::path dir = fresh("rvwo_rawlog_check");
  const std::string path = writeOdometry(dir, 4000, 1);
  const std::string bytes = rvwo::test::slurp(path);
  StreamCheck c = checkRawlogStream(path);
  EXPECT_EQ(c.result, StreamCheck::Result::kIntact) << c.error;
  EXPECT_GT(c.bytes, 4000u * 50);
  // (A flip that hits the stream's last block can make it read as cut short instead: docs/rawlog.md.)
  for (const std::size_t at : {bytes.size() / 4, bytes.size() / 3, bytes.size() / 2, bytes.size() * 2 / 3}) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ 0x10);
    std::ofstream(dir / "flipped.rawlog", std::ios::binary) << flipped;
    c = checkRawlogStream((dir / "flipped.rawlog").string());
    EXPECT_EQ(c.result, StreamCheck::Result::kDamaged) << "byte " << at << ": " << c.error;
    EXPECT_FALSE(c.error.empty());
  }
  std::ofstream(dir / "cut.rawlog", std::ios::binary) << bytes.substr(0, bytes.size() * 2 / 3);
  c = checkRawlogStream((dir / "cut.rawlog").string());
  EXPECT_EQ(c.result, StreamCheck::Result::kTruncated) << c.error;
  EXPECT_EQ(c.error, "unexpected end of file");
  const std::string plain = (dir / "plain.rawlog").string();
  ASSERT_EQ(std::system(("gzip -dc " + path + " > " + plain).c_str()), 0);
  c = checkRawlogStream(plain);
  EXPECT_EQ(c.result, StreamCheck::Result::kUncompressed);
  RawlogReader r(plain);
  std::size_t n = 0;
  while (r.next()) ++n;
  EXPECT_EQ(n, 4000u);  // read all the same
}

// A real 2006 MRPT rawlog in the action/observation format: its 224 odometry actions come out as
// ODOMETRY observations whose pose sums their increments, in time order; its laser scans as they are.
TEST(Rawlog, OdometryActionsOfAnOldMrptRawlogAreReadAsOdometry) {
  const std::string file = std::string(RVWO_SHARED_DIR) + "/data/mrpt_rawlogs/laser_odometry_actions_2006.rawlog";
  if (!fs::exists(file)) GTEST_SKIP() << "../shared is absent: no MRPT action/observation rawlog";
  RawlogReader r(file);
  std::size_t odometry = 0, scans = 0;
  double last_t = -1e300, travelled = 0;
  mrpt::poses::CPose2D last;
  while (auto o = r.next()) {
    if (auto od = std::dynamic_pointer_cast<mrpt::obs::CObservationOdometry>(*o)) {
      ++odometry;
      EXPECT_EQ(od->sensorLabel, "ODOMETRY");
      const double t = mrpt::Clock::toDouble(od->timestamp);
      EXPECT_GT(t, last_t) << odometry;
      last_t = t;
      travelled += (od->odometry - last).norm();
      last = od->odometry;
    } else {
      ++scans;
    }
  }
  EXPECT_EQ(odometry, 224u);
  EXPECT_EQ(scans, 225u);
  EXPECT_GT(travelled, 5.0);  // a loop of a faculty's corridors
  EXPECT_LT(travelled, 500.0);
}

TEST(Rawlog, MrptMessageIsTheInnermostCause) {
  const std::string nested =
      "==== MRPT exception ====\nMessage:  Exception while parsing typed object 'x' from .\nOriginal exception:\n"
      "==== MRPT exception ====\nMessage:  Expecting 0x00 00 00 while parsing\nLocation: a.cpp:364: [f]\n"
      "Call stack backtrace:\n[0 ] 0x7f\n\nLocation: a.cpp:432: [f]\n";
  EXPECT_EQ(mrptMessage(nested), "Expecting 0x00 00 00 while parsing");
  EXPECT_EQ(mrptMessage("plain first line\nsecond"), "plain first line");
  EXPECT_EQ(mrptMessage("Message:"), "Message:");  // nothing after the key: the line as it is
}

}  // namespace
// The one image loader the apps share: in the rawlog or beside it, grey when asked, one clear
// line when the file is missing.
TEST(Rawlog, ImagesLoadGreyWhenAskedWhereverTheyAreStored) {
  const fs::path dir = fresh("rvwo_rawlog_images");
  cv::Mat bgr(4, 6, CV_8UC3);
  for (int r = 0; r < bgr.rows; ++r)
    for (int c = 0; c < bgr.cols; ++c) bgr.at<cv::Vec3b>(r, c) = cv::Vec3b(10 * c, 40 * r, 200 - 20 * c);
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);

  mrpt::img::CImage inside;
  inside.loadFromMemoryBuffer(bgr.cols, bgr.rows, true, bgr.data);  // BGR, as CImage keeps colour
  const cv::Mat grey = rvwo::apps::loadImage(inside, cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(grey, expected, cv::NORM_INF), 0);
  EXPECT_EQ(rvwo::apps::loadImage(inside, cv::IMREAD_UNCHANGED).channels(), 3);

  const fs::path png = dir / "im.png";
  ASSERT_TRUE(cv::imwrite(png.string(), bgr));
  mrpt::img::CImage outside;
  outside.setExternalStorage(png.string());
  // libpng's own grey conversion rounds differently from cvtColor's.
  EXPECT_LE(cv::norm(rvwo::apps::loadImage(outside, cv::IMREAD_GRAYSCALE), expected, cv::NORM_INF), 1);
  mrpt::img::CImage missing;
  missing.setExternalStorage((dir / "none.png").string());
  try {
    rvwo::apps::loadImage(missing, cv::IMREAD_GRAYSCALE);
    FAIL() << "no error for a missing image";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot read image " + (dir / "none.png").string() + ": no such file");
  }
  // An image cut short (a copy that stopped): refused in our words, before libpng sees it.
  const std::string whole = rvwo::test::slurp(png);
  std::ofstream(dir / "cut.png", std::ios::binary) << whole.substr(0, whole.size() / 2);
  mrpt::img::CImage cut;
  cut.setExternalStorage((dir / "cut.png").string());
  try {
    rvwo::apps::loadImage(cut, cv::IMREAD_GRAYSCALE);
    FAIL() << "no error for an image cut short";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("cannot read image " + (dir / "cut.png").string() + ": a PNG cut short (", 0),
              0u)
        << e.what();
  }
  // A rawlog moved without its images: the missing folder is named.
  mrpt::img::CImage moved;
  moved.setExternalStorage((dir / "moved_Images" / "L_000000.png").string());
  try {
    rvwo::apps::loadImage(moved, cv::IMREAD_GRAYSCALE);
    FAIL() << "no error for a missing images folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(": no folder " + (dir / "moved_Images").string() + " ("), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(rvwo::apps::requireImageFile(moved), std::runtime_error);
  EXPECT_NO_THROW(rvwo::apps::requireImageFile(outside));
  EXPECT_NO_THROW(rvwo::apps::requireImageFile(inside));
}

}  // namespace rvwo::apps
