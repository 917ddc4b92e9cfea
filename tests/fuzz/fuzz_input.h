// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// What the fuzz targets share: the readers under test take a path, so each input is written to a
// scratch file of this process first.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace rvwo::fuzz {

// The input as a file named "<process>_<name>" in the temporary folder (overwritten each call).
inline std::string asFile(const std::uint8_t* data, std::size_t size, const std::string& name) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("rvwo_fuzz_" + std::to_string(::getpid()) + "_" + name)).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace rvwo::fuzz
