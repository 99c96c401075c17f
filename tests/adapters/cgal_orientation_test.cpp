#include "adapters/cgal/cgal_jobs.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

namespace apo::cgal_adapter {
namespace {

TEST(OrientNormalsMst, FlipsScrambledSphereNormalsOutwards) {
  const auto points = test::fibonacciSpherePoints(3000);
  std::vector<Vec3f> normals;
  for (std::size_t i = 0; i < points.size(); ++i) normals.push_back(i % 3 == 0 ? Vec3f(-points[i]) : points[i]);
  const auto unoriented = orientNormalsMst(points, normals, 12).value();
  EXPECT_TRUE(unoriented.empty());
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_GT(normals[i].dot(points[i]), 0.99f) << i;
}

TEST(OrientNormalsMst, ReportsTheUnreachedIsland) {
  auto points = test::fibonacciSpherePoints(1000);
  const auto far = test::fibonacciSpherePoints(500);
  for (const Vec3f& p : far) points.push_back(p + Vec3f(10, 0, -10));  // lower than the first sphere's top
  std::vector<Vec3f> normals(points.size(), Vec3f::UnitX());
  const auto unoriented = orientNormalsMst(points, normals, 12).value();
  ASSERT_EQ(unoriented.size(), 500u);
  EXPECT_EQ(unoriented.front(), 1000u);
  EXPECT_EQ(unoriented.back(), 1499u);
}

}  // namespace
}  // namespace apo::cgal_adapter
