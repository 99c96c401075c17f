#include "adapters/meshopt/meshopt_simplify.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/test_support.h"

#include <cmath>

namespace apo::meshopt_adapter {
namespace {

// A flat n x n grid of squares in z = 0, two triangles each, unit side.
Scan flatGrid(int n) {
  Scan grid;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) grid.points.positions.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
  auto at = [n](int x, int y) { return static_cast<std::uint32_t>(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      grid.triangles.push_back({at(x, y), at(x + 1, y), at(x + 1, y + 1)});
      grid.triangles.push_back({at(x, y), at(x + 1, y + 1), at(x, y + 1)});
    }
  return grid;
}

TEST(MeshoptQuickCollapse, AFlatGridStaysFlatAndKeepsItsOutline) {
  const Scan grid = flatGrid(100);  // 20,000 faces
  const QuickCollapse result = quickCollapse(grid, 2000, 0.01).value();
  EXPECT_LE(result.mesh.triangles.size(), 2000u);
  EXPECT_GT(result.mesh.triangles.size(), 100u);
  EXPECT_LT(result.relativeError, 1e-4);  // a plane costs nothing to collapse
  double area = 0.0;
  for (const Triangle& t : result.mesh.triangles) {
    const auto& p = result.mesh.points.positions;
    const Vec3f normal = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    EXPECT_GT(normal.z(), 0.0f);  // the winding kept: no folded triangle
    area += 0.5 * normal.norm();
  }
  EXPECT_NEAR(area, 100.0 * 100.0, 1e-3);  // the outline kept: the same square
  for (const Vec3f& p : result.mesh.points.positions) EXPECT_EQ(p.z(), 0.0f);
  // Only vertices some triangle uses remain.
  std::vector<char> used(result.mesh.points.size(), 0);
  for (const Triangle& t : result.mesh.triangles)
    for (std::uint32_t v : t) used[v] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
}

TEST(MeshoptQuickCollapse, TheErrorBoundStopsItEarly) {
  const Scan sphere = test::makeIcosphere(5);  // 20,480 faces
  const QuickCollapse loose = quickCollapse(sphere, 100, 1.0).value();
  const QuickCollapse tight = quickCollapse(sphere, 100, 1e-4).value();
  EXPECT_LE(loose.mesh.triangles.size(), 100u);
  EXPECT_GT(tight.mesh.triangles.size(), 1000u);
  EXPECT_LE(tight.relativeError, 1e-4);
}

TEST(MeshoptQuickCollapse, ABadIndexIsBadInput) {
  Scan broken = flatGrid(2);
  broken.triangles[3][1] = 99;
  const auto result = quickCollapse(broken, 2, 0.01);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(result.error().message, testing::HasSubstr("vertex 99 of 9"));
}

}  // namespace
}  // namespace apo::meshopt_adapter
