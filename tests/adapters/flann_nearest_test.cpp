#include "adapters/flann/flann_search.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "tests/test_support.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace apo::flann_adapter {
namespace {

struct BruteForce {
  std::uint32_t index = 0;
  double distance = std::numeric_limits<double>::infinity();
};

BruteForce nearestByBruteForce(const std::vector<Vec3f>& reference, const Vec3f& query) {
  BruteForce best;
  for (std::uint32_t i = 0; i < reference.size(); ++i) {
    const double d = (reference[i].cast<double>() - query.cast<double>()).norm();
    if (d < best.distance) best = {i, d};
  }
  return best;
}

TEST(FlannNearest, MatchesBruteForceOnRandomPoints) {
  const auto reference = test::randomCubePoints(5000, 1);
  const auto queries = test::randomCubePoints(2000, 2);
  const auto distances = nearestDistances(reference, queries).value();
  const auto indices = nearestIndices(reference, queries).value();
  ASSERT_EQ(distances.size(), queries.size());
  ASSERT_EQ(indices.size(), queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q) {
    const BruteForce expected = nearestByBruteForce(reference, queries[q]);
    EXPECT_NEAR(distances[q], expected.distance, 1e-6) << q;
    // The same point, or a tie at the same distance.
    const double found = (reference[indices[q]].cast<double>() - queries[q].cast<double>()).norm();
    EXPECT_NEAR(found, expected.distance, 1e-6) << q;
  }
}

TEST(FlannNearest, FindsReferencePointsThemselves) {
  const auto reference = test::randomCubePoints(1000, 3);
  const auto indices = nearestIndices(reference, reference).value();
  const auto distances = nearestDistances(reference, reference).value();
  for (std::uint32_t i = 0; i < reference.size(); ++i) {
    EXPECT_EQ(indices[i], i);
    EXPECT_EQ(distances[i], 0.0f);
  }
}

// Each row: k other points, nearest first, at the brute-force k nearest
// distances (ties may swap indices, never distances).
TEST(FlannNearest, NeighbourGraphMatchesBruteForce) {
  auto points = test::randomCubePoints(3000, 3);
  points.push_back(points[5]);  // a coincident pair: each is the other's nearest
  const NeighbourGraph graph = nearestNeighbourGraph(points, 8).value();
  ASSERT_EQ(graph.k, 8u);
  ASSERT_EQ(graph.neighbours.size(), points.size() * 8);
  for (std::size_t i = 0; i < points.size(); i += 7) {
    std::vector<double> expected;
    for (std::size_t j = 0; j < points.size(); ++j)
      if (j != i) expected.push_back((points[j].cast<double>() - points[i].cast<double>()).norm());
    std::sort(expected.begin(), expected.end());
    for (std::size_t n = 0; n < 8; ++n) {
      const std::uint32_t j = graph.neighbours[i * 8 + n];
      ASSERT_NE(j, i) << i;
      EXPECT_NEAR((points[j].cast<double>() - points[i].cast<double>()).norm(), expected[n], 1e-6) << i << " " << n;
    }
  }
  EXPECT_EQ(graph.neighbours[5 * 8], points.size() - 1);
  EXPECT_EQ(graph.neighbours[(points.size() - 1) * 8], 5u);
  // Fewer points than k + 1: every other point.
  const NeighbourGraph small = nearestNeighbourGraph({Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(3, 0, 0)}, 8).value();
  EXPECT_EQ(small.k, 2u);
  EXPECT_EQ(small.neighbours, (std::vector<std::uint32_t>{1, 2, 0, 2, 1, 0}));
  EXPECT_EQ(nearestNeighbourGraph({}, 8).value().neighbours.size(), 0u);
}

// A regular grid is all ties: equal distances come in the order of the
// points' indices, and the rows do not depend on the number of threads.
TEST(FlannNearest, NeighbourGraphOrdersTiesByIndexOnAnyThreadCount) {
  std::vector<Vec3f> grid;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) grid.emplace_back(static_cast<float>(i), static_cast<float>(j), 0.0f);
  const NeighbourGraph graph = nearestNeighbourGraph(grid, 8).value();
  // Point (10, 10) = index 610: its four at distance 1 are 550, 609, 611, 670;
  // its four at sqrt 2 are 549, 551, 669, 671.
  const std::vector<std::uint32_t> row(graph.neighbours.begin() + 610 * 8, graph.neighbours.begin() + 611 * 8);
  EXPECT_EQ(row, (std::vector<std::uint32_t>{550, 609, 611, 670, 549, 551, 669, 671}));
  tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
  EXPECT_EQ(nearestNeighbourGraph(grid, 8).value().neighbours, graph.neighbours);
}

TEST(FlannNearest, EmptyInputs) {
  const auto points = test::randomCubePoints(3, 4);
  EXPECT_TRUE(nearestDistances(points, {}).value().empty());
  const auto distances = nearestDistances({}, points).value();
  ASSERT_EQ(distances.size(), 3u);
  EXPECT_TRUE(std::isinf(distances[0]));
  EXPECT_EQ(nearestIndices({}, points).value()[2], std::numeric_limits<std::uint32_t>::max());
}

}  // namespace
}  // namespace apo::flann_adapter
