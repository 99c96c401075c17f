#include "adapters/cgal/cgal_jobs.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace apo::cgal_adapter {
namespace {

TEST(PointToMeshDistances, MatchesAnalyticDistancesToATriangle) {
  Scan triangle;
  triangle.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.triangles = {{0, 1, 2}};
  const std::vector<Vec3f> points = {{0.2f, 0.2f, 0.5f},   // above the inside: height
                                     {-1, 0, 0},           // beyond a corner
                                     {1, 1, 0},            // beyond the hypotenuse, in plane
                                     {2, -1, 0},           // nearest the corner (1, 0, 0)
                                     {0.5f, -2, 2}};       // nearest the edge y = 0
  const auto d = pointToMeshDistances(points, triangle).value();
  ASSERT_EQ(d.size(), points.size());
  EXPECT_NEAR(d[0], 0.5, 1e-6);
  EXPECT_NEAR(d[1], 1.0, 1e-6);
  EXPECT_NEAR(d[2], std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(d[3], std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(d[4], std::sqrt(8.0), 1e-6);
}

TEST(PointToMeshDistances, HeightAboveAPlaneGrid) {
  const Scan grid = test::makeSquareGrid(20);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> inside(0.05f, 0.95f), height(-1.0f, 1.0f);
  std::vector<Vec3f> points;
  for (int i = 0; i < 2000; ++i) points.emplace_back(inside(random), inside(random), height(random));
  const auto d = pointToMeshDistances(points, grid).value();
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_NEAR(d[i], std::abs(points[i].z()), 1e-6) << i;
}

TEST(PointToMeshDistances, InfiniteWithoutTriangles) {
  const auto d = pointToMeshDistances({{0, 0, 0}}, Scan{}).value();
  ASSERT_EQ(d.size(), 1u);
  EXPECT_TRUE(std::isinf(d[0]));
}

}  // namespace
}  // namespace apo::cgal_adapter
