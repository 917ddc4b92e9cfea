// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/shipped_model.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace rvwo {
namespace {

namespace fs = std::filesystem;

// The file (program or shared library) this function was loaded from.
fs::path thisBinary() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&thisBinary), &info) == 0 || info.dli_fname == nullptr) return {};
  std::error_code ec;
  const fs::path p = fs::canonical(info.dli_fname, ec);
  return ec ? fs::path() : p;
}

std::vector<fs::path> candidateFolders() {
  std::vector<fs::path> out;
  if (const char* env = std::getenv("RVWO_MODEL_DIR"); env && *env) out.emplace_back(env);
  // bin/ or lib/ (lib/<multiarch>/ on Debian) below the prefix: share/rvwo/models above them.
  if (const fs::path binary = thisBinary(); !binary.empty()) {
    fs::path dir = binary.parent_path();
    for (int up = 0; up < 3 && dir.has_relative_path(); ++up, dir = dir.parent_path())
      out.push_back(dir.parent_path() / "share" / "rvwo" / "models");
  }
  out.emplace_back(RVWO_INSTALL_MODEL_DIR);
  out.emplace_back(RVWO_SOURCE_MODEL_DIR);
  return out;
}

}  // namespace

std::string shippedModelPath() {
  std::string looked;
  for (const fs::path& dir : candidateFolders()) {
    std::error_code ec;
    if (fs::is_regular_file(dir / kShippedModelFile, ec)) return (dir / kShippedModelFile).string();
    looked += (looked.empty() ? "" : ", ") + dir.string();
  }
  throw std::runtime_error(std::string("the shipped segmentation model ") + kShippedModelFile +
                           " is in none of: " + looked + " (set RVWO_MODEL_DIR to its folder, or name a model file)");
}

}  // namespace rvwo
