// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
// The epipolar index must give every ray the exact plane test takes (so triangulation's matches
// do not change), each once, and far fewer than all of them.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include "epipolar_index.h"
#include "rvwo/estimator/features.h"

namespace rvwo::estimator {
namespace {

Eigen::Vector3d randomRay(std::mt19937* rng) {
  std::normal_distribution<double> n;
  return Eigen::Vector3d(n(*rng), n(*rng), n(*rng)).normalized();
}

// The test triangulation applies, written as Map::triangulate writes it.
bool onPlane(const Eigen::Vector3d& d1, const Eigen::Vector3d& base, const Eigen::Vector3d& d2, double tol) {
  const Eigen::Vector3d normal = d1.cross(base).normalized();
  return std::fabs(normal.dot(d2)) <= tol;
}

TEST(EpipolarIndex, GivesEveryRayOnThePlaneAndFewOthers) {
  std::mt19937 rng(7);
  std::size_t given = 0, total = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Eigen::Vector3d base = 0.3 * randomRay(&rng);
    std::vector<Eigen::Vector3d> rays;
    for (int k = 0; k < 800; ++k) rays.push_back(randomRay(&rng));
    // Rays on the baseline's axis, on either side, and just off it.
    rays.push_back(base.normalized());
    rays.push_back(-base.normalized());
    rays.push_back((base.normalized() + 2e-4 * base.normalized().unitOrthogonal()).normalized());
    std::vector<int> which;
    for (int j = 0; j < static_cast<int>(rays.size()); j += (trial % 2) + 1) which.push_back(j);
    const EpipolarIndex index(base, rays, which);
    for (double tol : {0.002, 0.0095, 0.03}) {
      for (int i = 0; i < 60; ++i) {
        // Some query rays lie on a plane with an indexed ray, in front or behind.
        Eigen::Vector3d d1 = randomRay(&rng);
        if (i % 3 == 0) {
          const Eigen::Vector3d& d2 = rays[which[i % which.size()]];
          d1 = (d2 + (i % 2 ? 0.5 : -3.0) * base.normalized()).normalized();
        }
        if (i == 1) d1 = base.normalized();
        std::vector<int> near;
        index.near(d1, tol, &near);
        std::sort(near.begin(), near.end());
        ASSERT_EQ(std::adjacent_find(near.begin(), near.end()), near.end());
        for (int j : which) {
          if (onPlane(d1, base, rays[j], tol)) {
            ASSERT_TRUE(std::binary_search(near.begin(), near.end(), j))
                << "trial " << trial << " tol " << tol << " query " << i << " ray " << j;
          }
        }
        if (i != 1) given += near.size(), total += which.size();
      }
    }
  }
  // Rays spread over the sphere: the windows hold a few percent of them.
  EXPECT_LT(static_cast<double>(given) / total, 0.1) << given << " of " << total;
}

TEST(EpipolarIndex, ARayOnTheAxisGetsEveryIndexedRay) {
  std::mt19937 rng(3);
  const Eigen::Vector3d base(0.0, 0.0, 0.2);
  std::vector<Eigen::Vector3d> rays;
  for (int k = 0; k < 50; ++k) rays.push_back(randomRay(&rng));
  std::vector<int> which = {4, 9, 17, 30, 49};
  const EpipolarIndex index(base, rays, which);
  std::vector<int> near;
  index.near(Eigen::Vector3d(0.0, 0.0, -1.0), 0.001, &near);
  std::sort(near.begin(), near.end());
  EXPECT_EQ(near, which);
}

// A ray that is not finite (a camera model's failure) is neither lost nor allowed to break the
// index's order; a query that is not finite gets every ray.
TEST(EpipolarIndex, RaysThatAreNotFiniteAreKeptAndGiven) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector3d> rays = {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(nan, 0, 1),
                                             Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0, nan)};
  const EpipolarIndex index(Eigen::Vector3d(0, 0, 0.2), rays, {0, 1, 2, 3});
  std::vector<int> near;
  index.near(Eigen::Vector3d(1, 0, 0), 0.01, &near);  // on the plane of ray 0, not of ray 2
  std::sort(near.begin(), near.end());
  EXPECT_EQ(near, (std::vector<int>{0, 1, 3}));
  index.near(Eigen::Vector3d(nan, 0, 0), 0.01, &near);
  std::sort(near.begin(), near.end());
  EXPECT_EQ(near, (std::vector<int>{0, 1, 2, 3}));
}

// Triangulation offers the index's rays in no set order: the match must be the one offer() gives
// in ascending order, ties included.
TEST(BestTwo, OfferInAnyOrderMatchesAscendingOffers) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> distance(40, 52);  // few values: many ties, some at the cap
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<std::pair<int, int>> offers;  // (index, distance)
    for (int i = 0; i < 1 + trial % 9; ++i) offers.emplace_back(3 * i + trial % 3, distance(rng));
    BestTwo ascending;
    ascending.best = 51;
    for (const auto& [i, d] : offers) ascending.offer(d, i);
    std::shuffle(offers.begin(), offers.end(), rng);
    BestTwo any;
    any.best = 51;
    for (const auto& [i, d] : offers) any.offerAnyOrder(d, i);
    ASSERT_EQ(any.index, ascending.index) << "trial " << trial;
    ASSERT_EQ(any.best, ascending.best) << "trial " << trial;
    ASSERT_EQ(any.second, ascending.second) << "trial " << trial;
  }
}

}  // namespace
}  // namespace rvwo::estimator
