#include "core/geometry.h"

#include <gtest/gtest.h>

namespace apo {
namespace {

TEST(BoundingBox, SpansAllPoints) {
  const Aabb box = boundingBox({{1, 2, 3}, {-1, 5, 0}, {0, 0, 4}});
  EXPECT_EQ(box.min, Vec3f(-1, 0, 0));
  EXPECT_EQ(box.max, Vec3f(1, 5, 4));
  EXPECT_FLOAT_EQ(box.diagonal(), std::sqrt(4.0f + 25.0f + 16.0f));
}

TEST(BoundingBox, EmptyHasZeroDiagonal) {
  const Aabb box = boundingBox({});
  EXPECT_TRUE(box.empty());
  EXPECT_EQ(box.diagonal(), 0.0f);
}

TEST(Scan, IsAMeshOnlyWithTriangles) {
  Scan scan;
  scan.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_FALSE(scan.isMesh());
  scan.triangles.push_back({0, 1, 2});
  EXPECT_TRUE(scan.isMesh());
}

TEST(AreaWeightedVertexNormals, OctahedronVerticesPointOutwards) {
  Scan octahedron;
  octahedron.points.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  octahedron.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  const auto normals = areaWeightedVertexNormals(octahedron);
  for (std::size_t i = 0; i < normals.size(); ++i)
    EXPECT_NEAR((normals[i] - octahedron.points.positions[i]).norm(), 0.0f, 1e-6f) << i;
  // Eight equilateral faces of side sqrt(2).
  EXPECT_NEAR(surfaceArea(octahedron), 8 * std::sqrt(3.0) / 4 * 2, 1e-6);
}

}  // namespace
}  // namespace apo
