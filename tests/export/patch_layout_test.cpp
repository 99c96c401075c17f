// The packed per-triangle patches: every triangle of m laid flat without
// shearing, inside the map, its gutter free of every other patch.
#include "export/export.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace apo {
namespace {

// A mesh of very different triangles: an icosphere whose vertices are pulled
// in and out, so that patches of many sizes and shapes must be packed.
Scan unevenSphere() {
  Scan mesh = test::makeIcosphere(3);
  for (std::size_t i = 0; i < mesh.points.positions.size(); ++i)
    mesh.points.positions[i] *= 1.0f + 0.3f * static_cast<float>((i * 7919) % 13) / 13.0f;
  mesh.points.normals.clear();
  return mesh;
}

struct Box {
  float x0, y0, x1, y1;
};

Box boxOf(const std::array<Vec2f, 3>& c, float grow) {
  const Vec2f low = c[0].cwiseMin(c[1]).cwiseMin(c[2]), high = c[0].cwiseMax(c[1]).cwiseMax(c[2]);
  return {low.x() - grow, low.y() - grow, high.x() + grow, high.y() + grow};
}

TEST(PatchLayout, EveryTriangleIsLaidFlatUnshearedInsideTheMapApartFromTheOthers) {
  const Scan mesh = unevenSphere();
  const auto atlas = packTrianglePatches(mesh, 512, 256, 2);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  ASSERT_EQ(atlas->corners.size(), mesh.triangles.size());
  EXPECT_GT(atlas->texelsPerUnit, 0.0f);
  const auto& p = mesh.points.positions;
  double area = 0.0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const auto& c = atlas->corners[f];
    // Each edge keeps its length, scaled by the one density: no shear.
    for (int k = 0; k < 3; ++k) {
      const float model = (p[t[(k + 1) % 3]] - p[t[k]]).norm() * atlas->texelsPerUnit;
      const float flat = (c[static_cast<std::size_t>((k + 1) % 3)] - c[static_cast<std::size_t>(k)]).norm();
      EXPECT_NEAR(flat, model, 1e-3f * model + 1e-4f) << "triangle " << f << " edge " << k;
    }
    // Inside the map with its gutter.
    const Box box = boxOf(c, 2.0f);
    EXPECT_GE(box.x0, -1e-3f);
    EXPECT_GE(box.y0, -1e-3f);
    EXPECT_LE(box.x1, 512.0f + 1e-3f);
    EXPECT_LE(box.y1, 256.0f + 1e-3f);
    const Vec2f e1 = c[1] - c[0], e2 = c[2] - c[0];
    area += 0.5 * std::abs(e1.x() * e2.y() - e2.x() * e1.y());
  }
  // No two patches' gutters overlap (brute force over every pair).
  std::uint64_t overlaps = 0;
  for (std::size_t a = 0; a < atlas->corners.size(); ++a) {
    const Box ba = boxOf(atlas->corners[a], 2.0f);
    for (std::size_t b = a + 1; b < atlas->corners.size(); ++b) {
      const Box bb = boxOf(atlas->corners[b], 2.0f);
      overlaps += ba.x0 < bb.x1 - 1e-3f && bb.x0 < ba.x1 - 1e-3f && ba.y0 < bb.y1 - 1e-3f && bb.y0 < ba.y1 - 1e-3f ? 1 : 0;
    }
  }
  EXPECT_EQ(overlaps, 0u);
  EXPECT_NEAR(atlas->usedShare, area / (512.0 * 256.0), 1e-3);
  // Shelves of bounding boxes: a triangle fills at most half of its box;
  // here the gutters (4 texels a side) cost as much again (patches of about
  // 6 x 5 texels).
  EXPECT_GT(atlas->usedShare, 0.1);
  EXPECT_LT(atlas->usedShare, 0.5);

  // The same layout every time.
  const auto again = packTrianglePatches(mesh, 512, 256, 2);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->corners, atlas->corners);
}

TEST(PatchLayout, RefusesSizesOutOfRangeAndMeshesWithoutArea) {
  const Scan mesh = test::makeIcosphere(1);
  EXPECT_EQ(packTrianglePatches(mesh, 8, 512).error().kind, ErrorKind::Usage);
  EXPECT_EQ(packTrianglePatches(mesh, 512, 20000).error().kind, ErrorKind::Usage);
  EXPECT_EQ(packTrianglePatches(mesh, 512, 512, 0).error().kind, ErrorKind::Usage);
  Scan flat = mesh;
  for (Vec3f& v : flat.points.positions) v = Vec3f(1, 2, 3);
  const auto none = packTrianglePatches(flat, 512, 512);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().kind, ErrorKind::BadInput);
  // 1,280 patches of at least 16 x 16 texels with their gutters: one fits.
  const auto crowded = packTrianglePatches(test::makeIcosphere(3), 16, 16, 8);
  ASSERT_FALSE(crowded.ok());
  EXPECT_EQ(crowded.error().kind, ErrorKind::BadInput);
}

}  // namespace
}  // namespace apo
