// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/image_file.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace rvwo {

namespace {

// What a file's header says before its decoder runs: what is wrong with it ("" if nothing), else
// the width and height it declares.
struct Header {
  std::string problem;
  std::uint64_t width = 0, height = 0;
};

Header refused(std::string problem) { return {std::move(problem), 0, 0}; }

std::uint32_t bigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

std::uint32_t bigEndian16(const unsigned char* p) { return (std::uint32_t{p[0]} << 8) | p[1]; }

// Each chunk: length (4), type (4), data, CRC (4) of type and data; IHDR comes first and holds the
// width and height (PNG specification, 5.3 and 11.2.2).
Header pngHeader(const std::vector<unsigned char>& b) {
  Header header;
  std::size_t at = 8;
  while (true) {
    if (b.size() - at < 12) return refused("a PNG cut short (at byte " + std::to_string(at) + ", before IEND)");
    const std::uint32_t length = bigEndian32(&b[at]);
    if (length > b.size() - at - 12) return refused("a PNG cut short (its chunk at byte " + std::to_string(at) + ")");
    const std::string type(b.begin() + static_cast<long>(at) + 4, b.begin() + static_cast<long>(at) + 8);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), &b[at + 4], length + 4);
    if (crc != bigEndian32(&b[at + 8 + length]))
      return refused("a damaged PNG (its " + type + " chunk at byte " + std::to_string(at) + " fails its CRC)");
    if (at == 8) {
      if (type != "IHDR" || length != 13) return refused("a damaged PNG (its first chunk is not a header, IHDR)");
      header.width = bigEndian32(&b[at + 8]);
      header.height = bigEndian32(&b[at + 12]);
    }
    at += 12 + length;
    if (type == "IEND") return header;
  }
}

// Markers from SOI to the first frame header (SOFn), which holds the height and width (ITU T.81,
// B.1.1 and B.2.2). Bytes between markers are skipped, as libjpeg skips them.
Header jpegHeader(const std::vector<unsigned char>& b) {
  if (b.size() < 4 || b[b.size() - 2] != 0xFF || b[b.size() - 1] != 0xD9)
    return refused("a JPEG cut short (no EOI at its end)");
  std::size_t at = 2;
  while (at < b.size()) {
    if (b[at] != 0xFF) {
      ++at;
      continue;
    }
    while (at < b.size() && b[at] == 0xFF) ++at;
    if (at >= b.size()) break;
    const unsigned marker = b[at++];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // TEM, RSTn: no segment
    if (marker == 0xD9 || marker == 0xDA || at + 2 > b.size()) break;    // EOI, SOS, or cut
    const std::size_t length = bigEndian16(&b[at]);
    const bool frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (frame) {
      if (length < 8 || at + 7 > b.size()) break;
      return {"", bigEndian16(&b[at + 5]), bigEndian16(&b[at + 3])};
    }
    at += std::max<std::size_t>(length, 2);
  }
  return refused("a damaged JPEG (no frame header, SOF, before its scan)");
}

// "P1" to "P6", then width, height and (but for the bitmaps P1 and P4) the largest value, each
// after white space or '#' comments to the line's end, as OpenCV's PNM reader parses them.
Header pnmHeader(const std::vector<unsigned char>& b) {
  const bool bitmap = b[1] == '1' || b[1] == '4';
  std::uint64_t value[3] = {0, 0, 0};
  std::size_t at = 2;
  for (int i = 0; i < (bitmap ? 2 : 3); ++i) {
    while (at < b.size() && !std::isdigit(b[at])) {
      if (b[at] == '#') {
        while (at < b.size() && b[at] != '\n' && b[at] != '\r') ++at;
      } else if (!std::isspace(b[at])) {
        return refused("a damaged PNM image (a byte in its header that is not a number, space or comment)");
      }
      ++at;
    }
    // Every digit belongs to this number; its value saturates, as any over kMaxImageSide is refused.
    for (; at < b.size() && std::isdigit(b[at]); ++at)
      value[i] = std::min<std::uint64_t>(value[i] * 10 + (b[at] - '0'), 0xFFFFFFFF);
    if (at >= b.size()) return refused("a PNM image cut short (in its header)");
  }
  return {"", value[0], value[1]};
}

}  // namespace

std::string imageProblem(const std::vector<unsigned char>& b) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  Header header;
  if (b.size() >= 8 && std::equal(kPng, kPng + 8, b.begin()))
    header = pngHeader(b);
  else if (b.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8)
    header = jpegHeader(b);
  else if (b.size() >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6')
    header = pnmHeader(b);
  else
    return "not a PNG, JPEG or PNM (PGM, PPM) image: convert it to PNG";
  if (!header.problem.empty()) return header.problem;
  const std::uint64_t w = header.width, h = header.height;
  if (w == 0 || h == 0 || w > kMaxImageSide || h > kMaxImageSide || w * h > kMaxImagePixels)
    return "it declares " + std::to_string(w) + "x" + std::to_string(h) + " pixels; a camera image has 1 to " +
           std::to_string(kMaxImageSide) + " a side and at most " + std::to_string(kMaxImagePixels) + " (2^25)";
  return "";
}

cv::Mat readImageFile(const std::string& path, int flags) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw std::runtime_error("cannot read image " + path + ": cannot open it");
  std::vector<unsigned char> bytes(static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg())));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    throw std::runtime_error("cannot read image " + path + ": a read error");
  if (bytes.empty()) throw std::runtime_error("cannot read image " + path + ": the file is empty");
  const std::string problem = imageProblem(bytes);
  if (!problem.empty()) throw std::runtime_error("cannot read image " + path + ": " + problem);
  cv::Mat m;
  try {
    m = cv::imdecode(bytes, flags);
  } catch (const cv::Exception&) {  // an OpenCV check the header checks did not foresee: still our line
  }
  if (m.empty()) throw std::runtime_error("cannot read image " + path + ": not an image OpenCV can decode");
  return m;
}

}  // namespace rvwo
