// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// Random vectors drawn in one order on every compiler. C++ leaves open the order in which a
// call's arguments are evaluated: Eigen::Vector3d(g(rng), g(rng), g(rng)) draws z first under gcc
// and x first under clang, so that one seed made two test worlds. drawVector draws the last
// coordinate first, as gcc did, so that the worlds the tests' bounds were measured on stay.
#pragma once

#include <Eigen/Core>

namespace rvwo::test {

template <int N, typename Distribution, typename Rng>
Eigen::Matrix<double, N, 1> drawVector(Distribution& d, Rng& rng) {
  Eigen::Matrix<double, N, 1> v;
  for (int i = N - 1; i >= 0; --i) v[i] = d(rng);
  return v;
}

}  // namespace rvwo::test
