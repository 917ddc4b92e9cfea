// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The rays of one keyframe, keyed by their angle about a baseline, so that a ray of another
// keyframe finds the ones near its epipolar plane without a scan of them all.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace rvwo::estimator {

class EpipolarIndex {
 public:
  // base: c2 - c1, the second camera's centre from the first's (non-zero); rays: the second
  // keyframe's unit rays in the world frame; which: the indices of rays to index.
  EpipolarIndex(const Eigen::Vector3d& base, const std::vector<Eigen::Vector3d>& rays, const std::vector<int>& which);

  // Every indexed j with |n . rays[j]| <= tolerance, where n = normalised(ray x base) is the normal
  // of ray's epipolar plane, and possibly some more, each once, in no set order, into *out. A ray
  // closer than 1e-3 rad to the baseline has no well-defined plane: it gets every indexed j.
  void near(const Eigen::Vector3d& ray, double tolerance, std::vector<int>* out) const;

 private:
  // A ray at distance s from the baseline's axis (s = |ray x b|) and angle theta about it is off a
  // plane through the axis at angle phi by s |sin(theta - phi)|: a band of rays with s >= its lower
  // edge lies within tolerance only where |sin(theta - phi)| <= tolerance / edge.
  struct Band {
    double edge = 0.0;                          // smallest s in the band
    std::vector<std::pair<double, int>> theta;  // (angle in [-pi, pi], index), by angle
  };
  void addWindow(const Band& band, double from, double to, std::vector<int>* out) const;
  double angle(const Eigen::Vector3d& ray, double* s) const;

  Eigen::Vector3d b_, e1_, e2_;  // unit baseline and two unit axes across it
  std::vector<Band> bands_;
};

}  // namespace rvwo::estimator
