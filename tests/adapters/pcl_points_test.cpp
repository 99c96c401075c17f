#include "adapters/pcl/pcl_points.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace apo::pcl_adapter {
namespace {

TEST(NearestNeighbours, MatchBruteForce) {
  const auto points = test::randomCubePoints(2000, 1);
  const std::vector<std::uint32_t> queries = {0, 17, 999, 1999};
  const auto neighbours = nearestNeighbours(points, queries, 5).value();
  for (std::size_t q = 0; q < queries.size(); ++q) {
    std::vector<std::pair<float, int>> all;
    for (std::size_t i = 0; i < points.size(); ++i)
      all.emplace_back((points[i] - points[queries[q]]).squaredNorm(), static_cast<int>(i));
    std::sort(all.begin(), all.end());
    ASSERT_EQ(neighbours[q].size(), 5u);
    EXPECT_EQ(neighbours[q][0], static_cast<int>(queries[q]));  // itself first
    for (int j = 0; j < 5; ++j) EXPECT_EQ(neighbours[q][j], all[j].second);
  }
}

TEST(NearestInReference, MatchesBruteForce) {
  const auto reference = test::randomCubePoints(500, 2);
  const auto queries = test::randomCubePoints(300, 3);
  const auto nearest = nearestInReference(reference, queries).value();
  for (std::size_t q = 0; q < queries.size(); ++q) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < reference.size(); ++i)
      if ((reference[i] - queries[q]).squaredNorm() < (reference[best] - queries[q]).squaredNorm()) best = i;
    EXPECT_EQ(nearest[q], static_cast<int>(best));
  }
}

TEST(StatisticalOutlierKeepMask, DropsFarPointsOnly) {
  auto points = test::randomCubePoints(3000, 4);
  points.emplace_back(20.0f, 20.0f, 20.0f);
  points.emplace_back(-30.0f, 0.0f, 0.0f);
  const auto keep = statisticalOutlierKeepMask(points, 8, 3.0).value();
  EXPECT_FALSE(keep[3000]);
  EXPECT_FALSE(keep[3001]);
  EXPECT_GT(std::count(keep.begin(), keep.end(), 1), 2950);
}

}  // namespace
}  // namespace apo::pcl_adapter
