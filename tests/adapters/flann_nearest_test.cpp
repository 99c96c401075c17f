#include "adapters/flann/flann_search.h"

#include <gtest/gtest.h>

#include "tests/test_support.h"

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
