// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// rvwo-convert's folder lists on any text (the first byte picks the reader): an image list, an
// OpenLORIS odom.txt, a generic odometry.csv. Entries, or one std::runtime_error naming the file
// and line, never a crash; what is read keeps the readers' promises.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "convert/lists.h"
#include "fuzz_input.h"

namespace {

void check(bool ok) {
  if (!ok) std::abort();  // a broken promise is a finding, as a crash is
}

void checkOdometry(const std::vector<rvwo::apps::Odometry>& odo) {
  for (std::size_t i = 0; i < odo.size(); ++i) {
    check(std::isfinite(odo[i].t) && std::isfinite(odo[i].x) && std::isfinite(odo[i].theta));
    if (i > 0) check(odo[i].t > odo[i - 1].t);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::filesystem::path file = rvwo::fuzz::asFile(data + 1, size - 1, "list.txt");
  try {
    switch (data[0] % 3) {
      case 0: {
        const auto list = rvwo::apps::readList(file.parent_path(), file.filename().string());
        for (std::size_t i = 1; i < list.size(); ++i) check(list[i].t > list[i - 1].t);
        break;
      }
      case 1:
        checkOdometry(rvwo::apps::readOpenLorisOdometry(file));
        break;
      default:
        checkOdometry(rvwo::apps::readOdometryCsv(file));
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
