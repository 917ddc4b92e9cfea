// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Image files read whole or refused in our own words. OpenCV's decoders print their own text on
// stderr for a damaged file (libpng: "libpng error: Read Error"), so a file is checked before it
// is decoded: a PNG must hold its signature, every chunk whole with its CRC, and IEND last; a JPEG
// must start with SOI and end with EOI (it has no checksum: damage inside it cannot be told).
// Other formats go to OpenCV unchecked.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace rvwo::apps {

// "" for bytes whose structure is whole (or of a format not checked), else what is wrong.
std::string imageDamage(const std::vector<unsigned char>& bytes);

// The image at path decoded with cv::imdecode flags; throws std::runtime_error
// "cannot read image <path>: <why>" for a file missing, unreadable, damaged or not decodable.
cv::Mat readImageFile(const std::string& path, int flags);

}  // namespace rvwo::apps
