// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The settings reader on any text: a file loaded and read as each host reads it, or one
// std::exception naming the file, never a crash.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <sstream>

#include "fuzz_input.h"
#include "rvwo/settings/settings.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rvwo::fuzz::asFile(data, size, "settings.yaml");
  try {
    const rvwo::Settings s = rvwo::Settings::load(path);
    std::ostringstream warnings;
    rvwo::readTrackingOptions(s, {}, &warnings);
    rvwo::readReliability(s);
    rvwo::readWheelNoise(s);
    rvwo::readDiffDrive(s);
    rvwo::readSemanticPriors(s);
    rvwo::readIsometry(s, "Camera.T_b_c", false);
    s.matrix("Camera.T_b_c", 4, 4);
    s.text("Sensor");
    s.file("Semantics.Model");
  } catch (const std::exception&) {  // one line naming the file and key: what the apps report
  }
  return 0;
}
