// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "support/output.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace rvwo::apps {

namespace fs = std::filesystem;

namespace {

// The same file: equal resolved paths, or (both existing) the same inode.
bool sameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec) && !ec) return true;
  return fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec) && !ec;
}

}  // namespace

void checkOutputs(const std::vector<PathArg>& outputs, const std::vector<PathArg>& inputs) {
  for (const PathArg& out : outputs) {
    if (out.path.empty()) continue;
    for (const PathArg& in : inputs) {
      if (!in.path.empty() && sameFile(out.path, in.path))
        throw std::invalid_argument(out.option + " " + out.path + " is the " + in.option +
                                    " input: give the output another path");
    }
    std::error_code ec;
    if (fs::is_directory(out.path, ec))
      throw std::invalid_argument(out.option + " " + out.path + " is a folder: give a file name");
    const fs::path folder = fs::absolute(out.path).parent_path();
    if (!fs::is_directory(folder, ec))
      throw std::invalid_argument(out.option + " " + out.path + ": no folder " + folder.string() +
                                  " (make it, or give another path)");
    if (access(folder.c_str(), W_OK | X_OK) != 0)
      throw std::invalid_argument(out.option + " " + out.path + ": folder " + folder.string() +
                                  " cannot be written (give another path)");
  }
}

std::string partialPath(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / ("." + p.stem().string() + ".partial" + p.extension().string())).string();
}

void writeWhole(const std::string& path, const std::function<void(const std::string& tmp)>& write) {
  const std::string tmp = partialPath(path);
  try {
    write(tmp);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot be written (" + ec.message() + ")");
  }
}

}  // namespace rvwo::apps
