#include "core/mesh_edit.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

namespace apo {
namespace {

TEST(KeepPoints, CompactsAttributesAndRenumbersTriangles) {
  Scan mesh = test::squareOfTwoTriangles();
  EXPECT_EQ(keepPoints(mesh, {1, 0, 1, 1}), 1u);  // vertex 1 goes, and triangle {0, 1, 2} with it
  EXPECT_EQ(mesh.points.intensities, (std::vector<float>{0, 2, 3}));
  EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{0, 1, 2}}));
  EXPECT_EQ(keepPoints(mesh, {1, 1, 1}), 0u);
}

TEST(DropDegenerateTriangles, RepeatedIndexAndZeroArea) {
  Scan mesh;
  mesh.points.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 3}, {0, 0, 1}, {0, 1, 2}};  // fine, repeated, collinear
  EXPECT_EQ(dropDegenerateTriangles(mesh), 2u);
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], (Triangle{0, 1, 3}));
}

TEST(DropUnreferencedVertices, RenumbersTriangles) {
  Scan mesh = test::squareOfTwoTriangles();
  mesh.points.positions.insert(mesh.points.positions.begin(), Vec3f(9, 9, 9));
  mesh.points.intensities.insert(mesh.points.intensities.begin(), 99.0f);
  for (auto& t : mesh.triangles)
    for (auto& v : t) ++v;
  EXPECT_EQ(dropUnreferencedVertices(mesh), 1u);
  EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}}));
  EXPECT_EQ(mesh.points.intensities, (std::vector<float>{0, 1, 2, 3}));
}

}  // namespace
}  // namespace apo
