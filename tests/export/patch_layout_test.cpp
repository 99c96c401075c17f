// The packed per-triangle patches: every triangle of m laid flat without
// shearing, inside the map, its gutter free of every other patch.
#include "export/export.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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

// Distance from q to a 2D triangle (0 inside), by its three edges.
float distanceToTriangle(const std::array<Vec2f, 3>& t, const Vec2f& q) {
  const auto side = [&](int k) {
    const Vec2f a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
    return (b - a).x() * (q - a).y() - (b - a).y() * (q - a).x();
  };
  const float s0 = side(0), s1 = side(1), s2 = side(2);
  if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return 0.0f;
  float best = std::numeric_limits<float>::max();
  for (int k = 0; k < 3; ++k) {
    const Vec2f a = t[static_cast<std::size_t>(k)], ab = t[static_cast<std::size_t>((k + 1) % 3)] - a;
    const float s = ab.squaredNorm() > 0 ? std::clamp((q - a).dot(ab) / ab.squaredNorm(), 0.0f, 1.0f) : 0.0f;
    best = std::min(best, (a + s * ab - q).norm());
  }
  return best;
}

// One density for all (no scales), or each patch at its own scale of it.
void expectAPackedLayout(const Scan& mesh, const std::vector<float>& scales) {
  const auto atlas = packTrianglePatches(mesh, 512, 256, 2, scales);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  ASSERT_EQ(atlas->scales.size(), mesh.triangles.size());
  if (!scales.empty()) {
    EXPECT_EQ(atlas->scales, scales);
  }
  ASSERT_EQ(atlas->corners.size(), mesh.triangles.size());
  EXPECT_GT(atlas->texelsPerUnit, 0.0f);
  const auto& p = mesh.points.positions;
  double area = 0.0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    const auto& c = atlas->corners[f];
    // Each edge keeps its length, scaled by the patch's density: no shear.
    const float density = atlas->texelsPerUnit * (scales.empty() ? 1.0f : scales[f]);
    for (int k = 0; k < 3; ++k) {
      const float model = (p[t[(k + 1) % 3]] - p[t[k]]).norm() * density;
      const float flat = (c[static_cast<std::size_t>((k + 1) % 3)] - c[static_cast<std::size_t>(k)]).norm();
      EXPECT_NEAR(flat, model, 1e-3f * model + 1e-4f) << "triangle " << f << " edge " << k;
    }
    const Vec2f e1 = c[1] - c[0], e2 = c[2] - c[0];
    area += 0.5 * std::abs(e1.x() * e2.y() - e2.x() * e1.y());
  }
  // No texel is claimed by two patches: every texel whose centre lies within
  // the gutter of a triangle (brute force, Euclidean, as the fill takes
  // them) belongs to that triangle alone, and lies inside the map.
  std::vector<int> owner(512 * 256, -1);
  std::uint64_t shared = 0, outside = 0;
  for (std::size_t f = 0; f < atlas->corners.size(); ++f) {
    const Box box = boxOf(atlas->corners[f], 2.0f);
    for (int y = static_cast<int>(std::floor(box.y0)) - 1; y <= static_cast<int>(std::ceil(box.y1)); ++y)
      for (int x = static_cast<int>(std::floor(box.x0)) - 1; x <= static_cast<int>(std::ceil(box.x1)); ++x) {
        if (distanceToTriangle(atlas->corners[f], Vec2f(x + 0.5f, y + 0.5f)) > 2.0f) continue;
        if (x < 0 || y < 0 || x >= 512 || y >= 256) {
          ++outside;
          continue;
        }
        int& who = owner[static_cast<std::size_t>(y) * 512 + static_cast<std::size_t>(x)];
        shared += who >= 0 ? 1 : 0;
        who = static_cast<int>(f);
      }
  }
  EXPECT_EQ(shared, 0u);
  EXPECT_EQ(outside, 0u);
  EXPECT_NEAR(atlas->usedShare, area / (512.0 * 256.0), 1e-3);
  // Small patches (about 6 x 5 texels here) lose most of the map to their
  // gutters (bunny00's 3,000 at 1024^2: 34%, docs/export.md).
  EXPECT_GT(atlas->usedShare, 0.12);
  EXPECT_LT(atlas->usedShare, 0.7);

  // The same layout every time.
  const auto again = packTrianglePatches(mesh, 512, 256, 2, scales);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->corners, atlas->corners);
}

TEST(PatchLayout, EveryTriangleIsLaidFlatUnshearedInsideTheMapApartFromTheOthers) {
  const Scan mesh = unevenSphere();
  expectAPackedLayout(mesh, {});
  // Scales from 0.5 to 2, as detailPatchScales gives them.
  std::vector<float> scales;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) scales.push_back(0.5f + 1.5f * static_cast<float>((f * 31) % 7) / 6.0f);
  expectAPackedLayout(mesh, scales);
  EXPECT_EQ(packTrianglePatches(mesh, 512, 256, 2, {1.0f, 2.0f}).error().kind, ErrorKind::Internal);
}

// Patch scales: a triangle whose normals turn k times faster than
// another's gets a patch cbrt(k) times as dense, within [0.5, 2]; a field
// without detail gives one density.
TEST(PatchLayout, PatchesAreSizedByTheCubeRootOfTheDetailTheyCover) {
  // Two equal triangles apart on the plane z = 0.
  Scan mesh;
  mesh.points.positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(5, 0, 0), Vec3f(6, 0, 0), Vec3f(5, 1, 0)};
  mesh.points.normals.assign(6, Vec3f::UnitZ());
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  // The normal turns about y by rate(x) radians per unit of x: 0.01 on the
  // first triangle, `fast` times that on the second.
  const auto turning = [](float fast) {
    return [fast](const Vec3f& p, const Vec3f&) {
      const float angle = p.x() < 3.0f ? 0.01f * p.x() : 0.01f * fast * (p.x() - 5.0f);
      return Vec3f(std::sin(angle), 0.0f, std::cos(angle));
    };
  };
  // The median of two is the larger: the fast one at scale 1.
  std::vector<float> scales = detailPatchScales(mesh, turning(8.0f));
  ASSERT_EQ(scales.size(), 2u);
  EXPECT_NEAR(scales[0], 0.5f, 1e-3f);
  EXPECT_NEAR(scales[1], 1.0f, 1e-6f);
  scales = detailPatchScales(mesh, turning(1.0f / 3.375f));  // the first is faster by 1.5^3
  EXPECT_NEAR(scales[0], 1.0f, 1e-6f);
  EXPECT_NEAR(scales[1], 1.0f / 1.5f, 1e-3f);
  scales = detailPatchScales(mesh, turning(1000.0f));  // clamped
  EXPECT_NEAR(scales[0], kMinPatchScale, 1e-6f);
  // m's own normal everywhere: no detail, one density.
  scales = detailPatchScales(mesh, [](const Vec3f&, const Vec3f& coarse) { return coarse; });
  EXPECT_EQ(scales, std::vector<float>(2, 1.0f));
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
