// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Scratch paths for tests, unique per process: ctest runs tests in parallel, and two test suites
// may run on one machine at once. And a file's bytes, for comparing what programs wrote.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace rvwo::test {

inline std::filesystem::path scratch(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("rvwo_" + std::to_string(::getpid()) + "_" + name);
}

// The whole file, bytes as they are ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace rvwo::test
