// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Scratch paths for tests, unique per process: ctest runs tests in parallel, and two test suites
// may run on one machine at once.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

namespace rvwo::test {

inline std::filesystem::path scratch(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("rvwo_" + std::to_string(::getpid()) + "_" + name);
}

}  // namespace rvwo::test
