// Average spacing and grid subsampling against brute force.
#include "adapters/cgal/cgal_jobs.h"

#include <gtest/gtest.h>

#include "tests/test_support.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>

namespace apo::cgal_adapter {
namespace {

// CGAL's definition: the k nearest other points' distances summed, divided by
// k + 1 (the query point counts as its own nearest neighbour, at distance 0).
double bruteForceSpacing(const std::vector<Vec3f>& points, int k) {
  double total = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::vector<double> distances;
    for (std::size_t j = 0; j < points.size(); ++j)
      if (j != i) distances.push_back((points[i].cast<double>() - points[j].cast<double>()).norm());
    std::partial_sort(distances.begin(), distances.begin() + k, distances.end());
    double sum = 0.0;
    for (int n = 0; n < k; ++n) sum += distances[n];
    total += sum / (k + 1);
  }
  return total / static_cast<double>(points.size());
}

TEST(AverageSpacing, MatchesBruteForceOnARandomCloud) {
  const auto points = test::randomCubePoints(400, 7);
  for (int k : {2, 6, 12}) EXPECT_NEAR(averageSpacing(points, k).value(), bruteForceSpacing(points, k), 1e-6) << "k=" << k;
}

TEST(AverageSpacing, ScalesWithTheCloud) {
  auto points = test::randomCubePoints(400, 8);
  const double spacing = averageSpacing(points, 6).value();
  for (Vec3f& p : points) p *= 3.0f;
  EXPECT_NEAR(averageSpacing(points, 6).value(), 3.0 * spacing, 1e-6);
}

TEST(AverageSpacing, IsZeroWithoutNeighbours) {
  EXPECT_EQ(averageSpacing({}, 6).value(), 0.0);
  EXPECT_EQ(averageSpacing({Vec3f(1, 2, 3)}, 6).value(), 0.0);
}

using Cell = std::array<long long, 3>;
Cell cellOf(const Vec3f& p, double size) {
  return {static_cast<long long>(std::floor(p.x() / size)), static_cast<long long>(std::floor(p.y() / size)),
          static_cast<long long>(std::floor(p.z() / size))};
}

TEST(GridSubsampleMask, KeepsExactlyOnePointPerOccupiedCell) {
  const auto points = test::randomCubePoints(20000, 9);
  const double size = 0.13;
  const auto keep = gridSubsampleMask(points, size).value();
  ASSERT_EQ(keep.size(), points.size());
  std::map<Cell, int> keptPerCell;
  for (std::size_t i = 0; i < points.size(); ++i) keptPerCell[cellOf(points[i], size)] += keep[i] ? 1 : 0;
  ASSERT_GT(keptPerCell.size(), 1000u);  // cells hold several points: there is something to drop
  ASSERT_LT(keptPerCell.size(), points.size() / 4);
  for (const auto& [cell, kept] : keptPerCell) EXPECT_EQ(kept, 1);
}

TEST(GridSubsampleMask, IsDeterministic) {
  const auto points = test::randomCubePoints(5000, 10);
  EXPECT_EQ(gridSubsampleMask(points, 0.2).value(), gridSubsampleMask(points, 0.2).value());
}

TEST(GridSubsampleMask, KeepsDistinctCellsAndHandlesEmptyInput) {
  const std::vector<Vec3f> points = {{0.05f, 0, 0}, {0.06f, 0, 0}, {0.15f, 0, 0}, {-0.05f, 0, 0}};
  const auto keep = gridSubsampleMask(points, 0.1).value();
  EXPECT_EQ(keep[0] + keep[1], 1);  // same cell
  EXPECT_EQ(keep[2], 1);
  EXPECT_EQ(keep[3], 1);  // cells are anchored at the origin: -0.05 is in cell -1
  EXPECT_TRUE(gridSubsampleMask({}, 0.1).value().empty());
}

}  // namespace
}  // namespace apo::cgal_adapter
