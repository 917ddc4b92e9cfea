// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Image files are checked before OpenCV decodes them: a PNG cut short or with a damaged chunk, and
// a JPEG cut short, are refused in one line of ours, and OpenCV's decoders print nothing (libpng
// would print "libpng error: ..." on stderr); whole files decode as OpenCV reads them.
#include "support/image_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "../common/temp.h"

namespace rvwo::apps {
namespace {

std::vector<unsigned char> encoded(const std::string& ext) {
  cv::Mat image(48, 64, CV_8U);
  cv::randu(image, 0, 255);
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes));
  return bytes;
}

std::string written(const std::vector<unsigned char>& bytes, const std::string& name) {
  const std::filesystem::path dir = rvwo::test::scratch("image_file");
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

// What readImageFile says, and what was printed on stderr meanwhile.
std::pair<std::string, std::string> readQuietly(const std::string& path) {
  std::fflush(stderr);
  const int saved = dup(2);
  std::FILE* sink = std::tmpfile();
  dup2(fileno(sink), 2);
  std::string what;
  try {
    readImageFile(path, cv::IMREAD_UNCHANGED);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  std::fflush(stderr);
  dup2(saved, 2);
  close(saved);
  std::rewind(sink);
  std::string printed;
  for (int c; (c = std::fgetc(sink)) != EOF;) printed += static_cast<char>(c);
  std::fclose(sink);
  return {what, printed};
}

TEST(ImageFile, WholeFilesPassAndDecodeAsOpenCvReadsThem) {
  for (const std::string ext : {".png", ".jpg"}) {
    const std::vector<unsigned char> bytes = encoded(ext);
    EXPECT_EQ(imageDamage(bytes), "") << ext;
    const std::string path = written(bytes, "whole" + ext);
    const cv::Mat ours = readImageFile(path, cv::IMREAD_UNCHANGED), theirs = cv::imread(path, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(ours.size(), theirs.size()) << ext;
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0) << ext;
  }
  EXPECT_EQ(imageDamage({'B', 'M', 0, 0}), "");  // a format not checked goes to OpenCV
}

TEST(ImageFile, APngCutShortOrDamagedIsRefusedInOneLineAndOpenCvPrintsNothing) {
  const std::vector<unsigned char> png = encoded(".png");
  for (const std::size_t keep : {std::size_t{8}, std::size_t{40}, png.size() / 2, png.size() - 1}) {
    const std::vector<unsigned char> cut(png.begin(), png.begin() + static_cast<long>(keep));
    EXPECT_EQ(imageDamage(cut).rfind("a PNG cut short (", 0), 0u) << keep << ": " << imageDamage(cut);
    const auto [what, printed] = readQuietly(written(cut, "cut.png"));
    EXPECT_NE(what.find(": a PNG cut short ("), std::string::npos) << what;
    EXPECT_EQ(printed, "") << keep;
  }
  // One bit flipped in the image data: its chunk's CRC no longer holds (libpng would print).
  std::vector<unsigned char> flipped = png;
  flipped[png.size() / 2] ^= 0x10;
  EXPECT_NE(imageDamage(flipped).find("chunk at byte 33 fails its CRC"), std::string::npos) << imageDamage(flipped);
  const auto [what, printed] = readQuietly(written(flipped, "flipped.png"));
  EXPECT_EQ(what.rfind("cannot read image ", 0), 0u) << what;
  EXPECT_NE(what.find("flipped.png: a damaged PNG (its IDAT chunk at byte 33 fails its CRC)"), std::string::npos)
      << what;
  EXPECT_EQ(printed, "");
}

TEST(ImageFile, AJpegCutShortAnEmptyFileAndNoImageAreRefused) {
  const std::vector<unsigned char> jpg = encoded(".jpg");
  const std::vector<unsigned char> cut(jpg.begin(), jpg.begin() + static_cast<long>(jpg.size() / 2));
  const auto [what, printed] = readQuietly(written(cut, "cut.jpg"));
  EXPECT_NE(what.find("cut.jpg: a JPEG cut short (no EOI at its end)"), std::string::npos) << what;
  EXPECT_EQ(printed, "");
  EXPECT_NE(readQuietly(written({}, "empty.png")).first.find("empty.png: the file is empty"), std::string::npos);
  const std::string text = readQuietly(written({'h', 'e', 'l', 'l', 'o'}, "text.png")).first;
  EXPECT_NE(text.find("text.png: not an image OpenCV can decode"), std::string::npos) << text;
  EXPECT_NE(readQuietly("/nonexistent/x.png").first.find("/nonexistent/x.png: cannot open it"), std::string::npos);
}

}  // namespace
}  // namespace rvwo::apps
