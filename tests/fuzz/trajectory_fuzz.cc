// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The trajectory reader (TUM, OpenLORIS blocks) on any text: poses, or one std::runtime_error
// naming the file and line, never a crash. What it reads is evaluated against itself.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "fuzz_input.h"
#include "support/trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rvwo::fuzz::asFile(data, size, "trajectory.txt");
  for (int block = 0; block < 3; ++block) {
    try {
      const rvwo::apps::Trajectory t = rvwo::apps::readTum(path, block);
      const auto pairs = rvwo::apps::associate(t, t, 0.01);
      if (pairs.size() >= 3) {
        rvwo::apps::ate(t, t, pairs, rvwo::apps::Alignment::kSim3);
        rvwo::apps::rpe(t, t, pairs, 1.0, true);
      }
    } catch (const std::runtime_error&) {
    }
  }
  return 0;
}
