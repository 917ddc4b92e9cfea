// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The image file reader (the PNG and JPEG checks, then OpenCV's decoders) on any bytes: an image,
// or one std::runtime_error naming the file, never a crash.
#include <cstddef>
#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "fuzz_input.h"
#include "rvwo/semantics/image_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rvwo::fuzz::asFile(data, size, "image");
  try {
    rvwo::readImageFile(path, cv::IMREAD_UNCHANGED);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
