// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-sim --randomise: a scenario drawn from a seed, as the text of a scenario file (written
// beside the output, so that --scenario on it renders the same sequence). docs/simulator.md lists
// what is drawn and from which ranges.
#pragma once

#include <string>

namespace rvwo::sim {

// The bundled motions (scenarios/motion/*.txt, real robot trajectories), found beside the
// installed program or in the source tree; throws std::runtime_error naming where it looked.
std::string motionFolder();

// A scenario for camera ("stereo", "rgbd" or "mono") and lens ("pinhole", "fisheye", or "" to draw
// one) lasting at most duration s (less when the drawn motion ends sooner), its motion one of the
// files in motion_folder, everything else drawn from seed.
std::string randomScenario(unsigned seed, const std::string& camera, const std::string& lens, double duration,
                           const std::string& motion_folder);

}  // namespace rvwo::sim
