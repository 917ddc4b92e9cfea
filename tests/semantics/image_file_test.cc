// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Image files are checked before OpenCV decodes them: a PNG cut short or with a damaged chunk, and
// a JPEG cut short, are refused in one line of ours, and OpenCV's decoders print nothing (libpng
// would print "libpng error: ..." on stderr); whole files decode as OpenCV reads them.
#include "rvwo/semantics/image_file.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "../common/temp.h"

namespace rvwo {
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
  for (const std::string ext : {".png", ".jpg", ".pgm", ".pbm"}) {
    const std::vector<unsigned char> bytes = encoded(ext);
    EXPECT_EQ(imageProblem(bytes), "") << ext;
    const std::string path = written(bytes, "whole" + ext);
    const cv::Mat ours = readImageFile(path, cv::IMREAD_UNCHANGED), theirs = cv::imread(path, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(ours.size(), theirs.size()) << ext;
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0) << ext;
  }
  // A PNM header with a comment and CR line ends, as OpenCV's reader takes it.
  const std::string pgm = "P2\r# made by hand\r3 2\r9\r0 1 2\r3 4 5\r";
  const cv::Mat grey = readImageFile(written({pgm.begin(), pgm.end()}, "comment.pgm"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(grey.size(), cv::Size(3, 2));
  EXPECT_EQ(grey.at<unsigned char>(1, 2), 5 * 255 / 9);
}

// A header whose width and height are patched; a PNG's IHDR gets its CRC again so only the size
// is wrong.
std::vector<unsigned char> declaring(const std::string& ext, std::uint32_t width, std::uint32_t height) {
  std::vector<unsigned char> b = encoded(ext);
  const auto put = [&b](std::size_t at, std::uint32_t value, int bytes) {
    for (int i = 0; i < bytes; ++i) b[at + i] = static_cast<unsigned char>(value >> (8 * (bytes - 1 - i)));
  };
  if (ext == ".png") {
    put(16, width, 4);
    put(20, height, 4);
    put(29, static_cast<std::uint32_t>(crc32(crc32(0L, Z_NULL, 0), &b[12], 17)), 4);
  } else {
    std::size_t sof = 2;
    while (!(b[sof] == 0xFF && b[sof + 1] == 0xC0)) ++sof;
    put(sof + 5, height, 2);
    put(sof + 7, width, 2);
  }
  return b;
}

// A header that declares more pixels than an image may have is refused before any decoder
// allocates them (fuzzing found 30000 x 30000 asking for 900 MB); zero pixels too.
TEST(ImageFile, AnImageDeclaringTooManyPixelsOrNoneIsRefusedBeforeDecoding) {
  EXPECT_EQ(imageProblem(declaring(".png", 8192, 4096)), "");
  EXPECT_EQ(imageProblem(declaring(".png", 8192, 4097)),
            "it declares 8192x4097 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
  EXPECT_EQ(
      imageProblem(declaring(".png", 4294967295u, 4294967295u)),
      "it declares 4294967295x4294967295 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
  EXPECT_EQ(imageProblem(declaring(".jpg", 30000, 30000)),
            "it declares 30000x30000 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
  EXPECT_EQ(imageProblem(declaring(".jpg", 640, 0)),
            "it declares 640x0 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
  const std::string pnm = "P5\n30000 # width\n30000\n255\n";
  const auto [what, printed] = readQuietly(written({pnm.begin(), pnm.end()}, "huge.pgm"));
  EXPECT_NE(
      what.find(
          "huge.pgm: it declares 30000x30000 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)"),
      std::string::npos)
      << what;
  EXPECT_EQ(printed, "");
  const std::string wide = "P5 2171111 1 255 ";  // fuzzing: OpenCV threw above 2^20 a side
  EXPECT_EQ(imageProblem({wide.begin(), wide.end()}),
            "it declares 2171111x1 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
  const std::string digits = "P5 99999999999999999999999 99999999999999999999999 255 ";
  EXPECT_NE(imageProblem({digits.begin(), digits.end()}).find("pixels; a camera image has"), std::string::npos);
  const std::string long_width = "P5 99999999999999999999999 7 255 ";  // every digit is the width's
  EXPECT_EQ(imageProblem({long_width.begin(), long_width.end()}),
            "it declares 4294967295x7 pixels; a camera image has 1 to 65535 a side and at most 33554432 (2^25)");
}

TEST(ImageFile, OtherFormatsAndHeadersThatDoNotParseAreRefused) {
  for (const std::string ext : {".bmp", ".tiff"})
    EXPECT_EQ(imageProblem(encoded(ext)), "not a PNG, JPEG or PNM (PGM, PPM) image: convert it to PNG") << ext;
  const std::string pam = "P7\nWIDTH 4\n", bad = "P5\n4 x 4\n255\n", cut = "P6\n4 4";
  EXPECT_EQ(imageProblem({pam.begin(), pam.end()}), "not a PNG, JPEG or PNM (PGM, PPM) image: convert it to PNG");
  EXPECT_EQ(imageProblem({bad.begin(), bad.end()}),
            "a damaged PNM image (a byte in its header that is not a number, space or comment)");
  EXPECT_EQ(imageProblem({cut.begin(), cut.end()}), "a PNM image cut short (in its header)");
  // A JPEG whose frame header is gone: its scan comes first.
  std::vector<unsigned char> jpg = encoded(".jpg");
  for (std::size_t at = 2; at + 1 < jpg.size(); ++at)
    if (jpg[at] == 0xFF && jpg[at + 1] == 0xC0) jpg[at + 1] = 0xFE;  // SOF0 becomes a comment
  EXPECT_EQ(imageProblem(jpg), "a damaged JPEG (no frame header, SOF, before its scan)");
  // A PNG whose first chunk is not IHDR.
  std::vector<unsigned char> png = encoded(".png");
  png.erase(png.begin() + 8, png.begin() + 33);
  EXPECT_EQ(imageProblem(png), "a damaged PNG (its first chunk is not a header, IHDR)");
}

TEST(ImageFile, APngCutShortOrDamagedIsRefusedInOneLineAndOpenCvPrintsNothing) {
  const std::vector<unsigned char> png = encoded(".png");
  for (const std::size_t keep : {std::size_t{8}, std::size_t{40}, png.size() / 2, png.size() - 1}) {
    const std::vector<unsigned char> cut(png.begin(), png.begin() + static_cast<long>(keep));
    EXPECT_EQ(imageProblem(cut).rfind("a PNG cut short (", 0), 0u) << keep << ": " << imageProblem(cut);
    const auto [what, printed] = readQuietly(written(cut, "cut.png"));
    EXPECT_NE(what.find(": a PNG cut short ("), std::string::npos) << what;
    EXPECT_EQ(printed, "") << keep;
  }
  // One bit flipped in the image data: its chunk's CRC no longer holds (libpng would print).
  std::vector<unsigned char> flipped = png;
  flipped[png.size() / 2] ^= 0x10;
  EXPECT_NE(imageProblem(flipped).find("chunk at byte 33 fails its CRC"), std::string::npos) << imageProblem(flipped);
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
  EXPECT_NE(text.find("text.png: not a PNG, JPEG or PNM (PGM, PPM) image: convert it to PNG"), std::string::npos)
      << text;
  EXPECT_NE(readQuietly("/nonexistent/x.png").first.find("/nonexistent/x.png: cannot open it"), std::string::npos);
}

}  // namespace
}  // namespace rvwo
