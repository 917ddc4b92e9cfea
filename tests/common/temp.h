// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Scratch paths for tests, unique per process (ctest runs tests in parallel, and two test suites
// may run on one machine at once) and gone when it exits. And a file's bytes, for comparing what
// programs wrote.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

namespace rvwo::test {

// Every scratch path a test process names is removed when the process exits, passed or failed
// (simulated sequences run to hundreds of MB each); RVWO_KEEP_SCRATCH=1 keeps them to look at.
class ScratchPaths {
 public:
  ~ScratchPaths() {
    const char* keep = std::getenv("RVWO_KEEP_SCRATCH");
    if (keep && std::string(keep) == "1") return;
    std::error_code ignored;
    for (const std::filesystem::path& p : paths_) std::filesystem::remove_all(p, ignored);
  }
  std::filesystem::path add(std::filesystem::path p) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::find(paths_.begin(), paths_.end(), p) == paths_.end()) paths_.push_back(p);
    return p;
  }

 private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> paths_;
};

inline std::filesystem::path scratch(const std::string& name) {
  static ScratchPaths paths;
  return paths.add(std::filesystem::temp_directory_path() / ("rvwo_" + std::to_string(::getpid()) + "_" + name));
}

// The whole file, bytes as they are ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace rvwo::test
