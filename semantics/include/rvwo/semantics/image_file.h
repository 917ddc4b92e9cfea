// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Image files read whole or refused in our own words. A file is checked before OpenCV decodes it,
// so that its decoders neither print their own text on stderr for a damaged file (libpng:
// "libpng error: Read Error") nor allocate the size a damaged header declares:
// - a PNG must hold its signature, IHDR first, every chunk whole with its CRC, and IEND last;
// - a JPEG must start with SOI, reach a frame header (SOFn) before its scan, and end with EOI (it
//   has no checksum: damage inside it cannot be told);
// - a PNM (P1 to P6: PBM, PGM, PPM) must hold a header that parses;
// - each must declare 1 to kMaxImageSide pixels a side, kMaxImagePixels in all.
// Other formats are refused. The apps read every image file through it, and so does
// LabelImageSegmenter.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace rvwo {

// The most pixels an image file may declare: 2^25 (33.5 megapixels, 8192 x 4096), above any
// robot camera's, and at 8 bytes a pixel (16-bit RGBA) 256 MiB to decode; and on a side, a
// JPEG's most (OpenCV throws above 2^20).
inline constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 25;
inline constexpr std::uint64_t kMaxImageSide = 65535;

// "" for bytes that pass the checks above, else what is wrong with them.
std::string imageProblem(const std::vector<unsigned char>& bytes);

// The image at path decoded with cv::imdecode flags; throws std::runtime_error
// "cannot read image <path>: <why>" for a file missing, unreadable, damaged, too large, of another
// format, or not decodable.
cv::Mat readImageFile(const std::string& path, int flags);

}  // namespace rvwo
