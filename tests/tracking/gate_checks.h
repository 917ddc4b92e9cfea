// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// What the pose solves' tests check of a result's classification: every gross outlier is out,
// beyond its gate, and the gate keeps about 95 % of the good matches (at least 85 % here).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "rvwo/tracking/planar_pose.h"

namespace rvwo::test {

// Result: PlanarPoseResult or SpatialPoseResult (inlier, error, inliers).
template <class Result>
void expectGrossOutliersOut(const std::vector<PoseObservation>& obs, const std::vector<char>& is_outlier,
                            const Result& r) {
  int good = 0, good_in = 0;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    if (is_outlier[k]) {
      EXPECT_FALSE(r.inlier[k]) << k;
      EXPECT_GT(r.error[k], std::sqrt(chi2Gate(obs[k].stereo))) << k;
    } else {
      ++good;
      good_in += r.inlier[k];
    }
  }
  EXPECT_GT(good_in, 0.85 * good);
  EXPECT_EQ(r.inliers, good_in);
}

}  // namespace rvwo::test
