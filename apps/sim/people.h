// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The people rvwo-sim's walkers wear: real people cut out of a TUM RGB-D frame with their masks
// (apps/sim/people/README.md), compiled into the program.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace rvwo::sim {

struct Person {
  cv::Mat grey;   // CV_8U, the person as a grey camera sees them
  cv::Mat alpha;  // CV_8U, 255 on the person, 0 around them
  double metres;  // how tall the image is in the world (its top row to its bottom row)
};

// Every person, decoded once; a looks index k wears person k / 2, mirrored when k is odd.
const std::vector<Person>& people();
inline int peopleLooks() { return 2 * static_cast<int>(people().size()); }

}  // namespace rvwo::sim
