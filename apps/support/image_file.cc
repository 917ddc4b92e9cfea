// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "image_file.h"

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace rvwo::apps {

namespace {

std::uint32_t bigEndian32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

// Each chunk: length (4), type (4), data, CRC (4) of type and data (PNG specification, 5.3).
std::string pngDamage(const std::vector<unsigned char>& b) {
  std::size_t at = 8;
  while (true) {
    if (b.size() - at < 12) return "a PNG cut short (at byte " + std::to_string(at) + ", before IEND)";
    const std::uint32_t length = bigEndian32(&b[at]);
    if (length > b.size() - at - 12) return "a PNG cut short (its chunk at byte " + std::to_string(at) + ")";
    const std::string type(b.begin() + static_cast<long>(at) + 4, b.begin() + static_cast<long>(at) + 8);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), &b[at + 4], length + 4);
    if (crc != bigEndian32(&b[at + 8 + length]))
      return "a damaged PNG (its " + type + " chunk at byte " + std::to_string(at) + " fails its CRC)";
    at += 12 + length;
    if (type == "IEND") return "";
  }
}

}  // namespace

std::string imageDamage(const std::vector<unsigned char>& b) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (b.size() >= 8 && std::equal(kPng, kPng + 8, b.begin())) return pngDamage(b);
  if (b.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8) {
    if (b.size() < 4 || b[b.size() - 2] != 0xFF || b[b.size() - 1] != 0xD9)
      return "a JPEG cut short (no EOI at its end)";
  }
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
  const std::string damage = imageDamage(bytes);
  if (!damage.empty()) throw std::runtime_error("cannot read image " + path + ": " + damage);
  cv::Mat m = cv::imdecode(bytes, flags);
  if (m.empty()) throw std::runtime_error("cannot read image " + path + ": not an image OpenCV can decode");
  return m;
}

}  // namespace rvwo::apps
