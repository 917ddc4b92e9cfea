// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "epipolar_index.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace rvwo::estimator {
namespace {

// Lower edges of the bands of s = |ray x b|: rays near the baseline's axis (the epipole) have wide
// windows, so they are kept apart from the rest.
constexpr double kBandEdges[] = {0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7};
// Below this s a query's angle about the axis is too uncertain to key on: it scans every band.
constexpr double kOnTheAxis = 1e-3;

}  // namespace

EpipolarIndex::EpipolarIndex(const Eigen::Vector3d& base, const std::vector<Eigen::Vector3d>& rays,
                             const std::vector<int>& which)
    : b_(base.normalized()), e1_(b_.unitOrthogonal()), e2_(b_.cross(e1_)) {
  for (double edge : kBandEdges) bands_.push_back(Band{edge, {}});
  for (int j : which) {
    double s;
    const double theta = angle(rays[j], &s);
    auto band = std::find_if(bands_.rbegin(), bands_.rend(), [s](const Band& b) { return s >= b.edge; });
    // A ray that is not finite goes where every query looks (the first band, scanned whole), at an
    // angle that keeps the sort's order strict.
    if (band == bands_.rend() || !std::isfinite(theta)) {
      bands_.front().theta.emplace_back(0.0, j);
    } else {
      band->theta.emplace_back(theta, j);
    }
  }
  for (Band& band : bands_) std::sort(band.theta.begin(), band.theta.end());
}

double EpipolarIndex::angle(const Eigen::Vector3d& ray, double* s) const {
  const double x = ray.dot(e1_), y = ray.dot(e2_);
  *s = std::hypot(x, y);
  return std::atan2(y, x);
}

void EpipolarIndex::addWindow(const Band& band, double from, double to, std::vector<int>* out) const {
  if (from < -M_PI) {
    addWindow(band, from + 2 * M_PI, M_PI, out);
    from = -M_PI;
  }
  if (to > M_PI) {
    addWindow(band, -M_PI, to - 2 * M_PI, out);
    to = M_PI;
  }
  auto lo = std::lower_bound(band.theta.begin(), band.theta.end(), std::make_pair(from, -1));
  for (auto it = lo; it != band.theta.end() && it->first <= to; ++it) out->push_back(it->second);
}

void EpipolarIndex::near(const Eigen::Vector3d& ray, double tolerance, std::vector<int>* out) const {
  out->clear();
  double s;
  const double phi = angle(ray, &s);
  // A margin far above rounding error keeps every ray the exact test would take.
  const double tol = tolerance + 1e-9;
  for (const Band& band : bands_) {
    if (!(s >= kOnTheAxis) || band.edge <= tol) {  // on the axis, or not finite
      for (const auto& [theta, j] : band.theta) out->push_back(j);
      continue;
    }
    // Both half-planes: the one the ray is in and the one opposite (behind a camera).
    const double w = std::asin(tol / band.edge), opposite = phi > 0 ? phi - M_PI : phi + M_PI;
    addWindow(band, phi - w, phi + w, out);
    addWindow(band, opposite - w, opposite + w, out);
  }
}

}  // namespace rvwo::estimator
