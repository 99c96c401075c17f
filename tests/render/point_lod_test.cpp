// The point LOD (Maximo et al., with Sequential Point Trees' perpendicular
// error): merges against hand-computed discs, the levels against a
// brute-force re-merge of each group, the object texture's bookkeeping, the
// error projection against hand-computed cases, and the geometry shader's
// choices against chooseLodLevel on the CPU, surfel for surfel.
#include "render/render.h"

#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

namespace apo {
namespace {

TEST(MergeSurfels, TwoCoplanarDiscsAreFlat) {
  const Surfel a{Vec3f(0, 0, 0), Vec3f::UnitZ(), 1.0f, 0.0f};
  const Surfel b{Vec3f(2, 0, 0), Vec3f::UnitZ(), 1.0f, 0.0f};
  const Surfel m = mergeSurfels({a, b});
  EXPECT_TRUE(m.position.isApprox(Vec3f(1, 0, 0)));
  EXPECT_TRUE(m.normal.isApprox(Vec3f::UnitZ()));
  EXPECT_FLOAT_EQ(m.radius, 2.0f);
  EXPECT_FLOAT_EQ(m.perpendicularError, 0.0f);
}

TEST(MergeSurfels, ThicknessAlongTheNormalIsTheError) {
  // Two tiny discs h apart along their common normal: the error is h.
  const float h = 0.3f;
  const Surfel low{Vec3f(0, 0, 0), Vec3f::UnitZ(), 1e-6f, 0.0f};
  const Surfel high{Vec3f(0.1f, 0, h), Vec3f::UnitZ(), 1e-6f, 0.0f};
  EXPECT_NEAR(mergeSurfels({low, high}).perpendicularError, h, 1e-5);
  // A child's own error adds half of itself on each side.
  Surfel thick = high;
  thick.perpendicularError = 0.2f;
  EXPECT_NEAR(mergeSurfels({low, thick}).perpendicularError, h + 0.1f, 1e-5);
}

TEST(MergeSurfels, TiltedDiscsByHand) {
  // A flat unit disc at the origin and one at (2, 0, 0) tilted by theta
  // about y: equal areas, so the merged normal bisects them (theta / 2),
  // each centre sits sin(theta / 2) off the merged plane and each disc
  // reaches sin(theta / 2) further: the error is 4 sin(theta / 2).
  const float theta = 0.5f;
  const Surfel flat{Vec3f(0, 0, 0), Vec3f::UnitZ(), 1.0f, 0.0f};
  const Surfel tilted{Vec3f(2, 0, 0), Vec3f(std::sin(theta), 0, std::cos(theta)), 1.0f, 0.0f};
  const Surfel m = mergeSurfels({flat, tilted});
  EXPECT_TRUE(m.normal.isApprox(Vec3f(std::sin(theta / 2), 0, std::cos(theta / 2)), 1e-5f));
  EXPECT_NEAR(m.perpendicularError, 4.0f * std::sin(theta / 2), 1e-5);
  EXPECT_FLOAT_EQ(m.radius, 2.0f);
  // Each normal is theta / 2 from the merged one; the LOD's error is the
  // larger of the thickness and radius x spread = 2 x 0.25 = 0.5 here.
  EXPECT_NEAR(m.normalSpread, theta / 2, 1e-5);
  EXPECT_NEAR(lodError(m), std::max(4.0f * std::sin(theta / 2), 2.0f * theta / 2), 1e-5);
  // Spreads add up the levels.
  Surfel spread = tilted;
  spread.normalSpread = 0.1f;
  EXPECT_NEAR(mergeSurfels({flat, spread}).normalSpread, theta / 2 + 0.1f, 1e-5);
}

TEST(PointLodError, ProjectsByDistanceAndPicksTheCoarsestLevelWithinTheThreshold) {
  // 0.01 units seen from 2 units with 1000 pixels per unit at distance 1: 5 pixels.
  EXPECT_FLOAT_EQ(projectedLodError(0.01f, Vec3f(0, 0, 0), Vec3f(0, 0, 2), 1000.0f), 5.0f);
  const Surfel patch{Vec3f::Zero(), Vec3f::UnitZ(), 1.0f, 0.04f, 0.0f};
  LodPatch finer;
  finer.maxError = {0.01f, 0.002f, 0.0f};
  const auto levelAt = [&](float distance) { return chooseLodLevel(patch, finer, Vec3f(0, 0, distance), 1000.0f, 1.0f); };
  EXPECT_EQ(levelAt(100.0f), 3);  // 0.4 px
  EXPECT_EQ(levelAt(20.0f), 2);   // 2 px for the patch, 0.5 px for level 2
  EXPECT_EQ(levelAt(5.0f), 1);    // 2 px for level 2, 0.4 px for level 1
  EXPECT_EQ(levelAt(1.0f), 0);    // 2 px for level 1
}

// Points on a jittered grid of the plane z = 0 and of a sphere.
PointSet planePoints(int side) {
  PointSet points;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) {
      points.positions.emplace_back(static_cast<float>(i) + 0.1f * std::sin(7.0f * static_cast<float>(i * side + j)),
                                    static_cast<float>(j), 0.0f);
      points.normals.push_back(Vec3f::UnitZ());
    }
  return points;
}

PointSet spherePoints(std::size_t count) {
  PointSet points;
  for (const Vec3f& d : test::fibonacciSpherePoints(count)) {
    points.positions.push_back(d);
    points.normals.push_back(d);
  }
  return points;
}

TEST(BuildPointLod, EveryLevelIsTheMergeOfItsGroupsAndTheObjectTextureHoldsEverySampleOnce) {
  for (const PointSet& points : {planePoints(48), spherePoints(6000)}) {
    auto lod = buildPointLod(points);
    ASSERT_TRUE(lod.ok()) << lod.error().message;
    ASSERT_EQ(lod->levels[0].size(), points.size());
    for (int level = 0; level + 1 < kLodLevels; ++level) {
      // Brute force: each sample of the next level, merged again from its children.
      std::vector<std::vector<Surfel>> groups(lod->levels[level + 1].size());
      for (std::size_t i = 0; i < lod->levels[level].size(); ++i) {
        ASSERT_LT(lod->parent[level][i], groups.size());
        groups[lod->parent[level][i]].push_back(lod->levels[level][i]);
      }
      for (std::size_t j = 0; j < groups.size(); ++j) {
        ASSERT_GE(groups[j].size(), 1u);
        ASSERT_LE(groups[j].size(), kLodFanOut);
        const Surfel expected = mergeSurfels(groups[j]);
        const Surfel& actual = lod->levels[level + 1][j];
        // The same merge, its children summed in another order.
        ASSERT_TRUE(actual.position.isApprox(expected.position, 1e-5f));
        ASSERT_NEAR(actual.radius, expected.radius, 1e-5f * expected.radius);
        ASSERT_NEAR(actual.perpendicularError, expected.perpendicularError, 1e-5f * expected.radius);
        // Adjacent samples, on the same side.
        for (const Surfel& child : groups[j]) ASSERT_GT(child.normal.dot(actual.normal), 0.0f);
      }
      // Merging mostly fills groups: each level has well under half the samples of the one below.
      EXPECT_LT(lod->levels[level + 1].size(), lod->levels[level].size() * 2 / 5) << "level " << level + 1;
    }
    // The object texture: every sample of levels 2, 1, 0 once, under its patch.
    ASSERT_EQ(lod->patches.size(), lod->levels[3].size());
    std::size_t total = 0;
    std::set<std::pair<float, float>> seenPoints;
    for (std::size_t p = 0; p < lod->patches.size(); ++p) {
      const LodPatch& patch = lod->patches[p];
      ASSERT_EQ(patch.first, total);
      ASSERT_LE(patch.count[0], 4u);
      ASSERT_LE(patch.count[1], 16u);
      ASSERT_LE(patch.count[2], 64u);
      for (int slot = 0; slot < 3; ++slot) {
        float largest = 0.0f;
        for (std::uint32_t i = 0; i < patch.count[slot]; ++i) {
          const Surfel& s = lod->objectTexture[total + i];
          largest = std::max(largest, lodError(s));
          if (slot == 2) seenPoints.emplace(s.position.x(), s.position.y() + 1000.0f * s.position.z());
        }
        ASSERT_FLOAT_EQ(patch.maxError[slot], largest);
        total += patch.count[slot];
      }
    }
    EXPECT_EQ(total, lod->levels[2].size() + lod->levels[1].size() + lod->levels[0].size());
    EXPECT_EQ(seenPoints.size(), points.size());
    // The paper's order of magnitude: at least 10x fewer patches than points.
    EXPECT_LT(lod->patches.size() * 10, points.size());
  }
}

TEST(BuildPointLod, AFlatPlaneHasNoErrorAndACurvedSurfaceSome) {
  auto plane = buildPointLod(planePoints(32));
  ASSERT_TRUE(plane.ok());
  for (const Surfel& s : plane->levels[3]) EXPECT_NEAR(s.perpendicularError, 0.0f, 1e-5f);
  auto sphere = buildPointLod(spherePoints(4000));
  ASSERT_TRUE(sphere.ok());
  double mean[kLodLevels] = {0, 0, 0, 0};
  for (int level = 1; level < kLodLevels; ++level) {
    for (const Surfel& s : sphere->levels[level]) mean[level] += s.perpendicularError;
    mean[level] /= static_cast<double>(sphere->levels[level].size());
  }
  EXPECT_GT(mean[1], 0.0);
  EXPECT_GT(mean[2], mean[1]);
  EXPECT_GT(mean[3], mean[2]);
}

TEST(BuildPointLod, RefusesPointsWithoutNormals) {
  PointSet points = planePoints(4);
  points.normals.clear();
  EXPECT_EQ(buildPointLod(points).error().kind, ErrorKind::BadInput);
}

// Rendered: the geometry shader emits, per patch, the surfels of the level
// chooseLodLevel picks on the CPU (counted by GL_PRIMITIVES_GENERATED); at
// a huge threshold only the patches, at a tiny one every point; and the
// normals it draws are close to every point's disc.
// The report's viewer draws M's points from the finest LOD level within its
// limit: every point when they fit, else that level's discs, as built.
TEST(WebglPoints, TheFinestLevelWithinTheLimit) {
  const PointSet points = spherePoints(6000);
  auto lod = buildPointLod(points);
  ASSERT_TRUE(lod.ok()) << lod.error().message;
  auto all = webglPoints(points, 6000);
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->radii.size(), 6000u);
  EXPECT_EQ(all->description, "M as its 6,000 points");
  const std::size_t limit = lod->levels[1].size();  // level 0 does not fit, level 1 just does
  auto some = webglPoints(points, limit);
  ASSERT_TRUE(some.ok()) << some.error().message;
  ASSERT_EQ(some->radii.size(), limit);
  EXPECT_EQ(some->positions.size(), 3 * limit);
  EXPECT_FALSE(some->isMesh());
  for (std::size_t i = 0; i < limit; ++i) {
    EXPECT_EQ(some->radii[i], lod->levels[1][i].radius);
    EXPECT_EQ(some->positions[3 * i], lod->levels[1][i].position.x());
    EXPECT_EQ(some->normals[3 * i + 2], lod->levels[1][i].normal.z());
  }
  EXPECT_THAT(some->description, ::testing::HasSubstr("level 1 of the point LOD"));
}

TEST(PointLodRender, TheGeometryShaderDrawsTheLevelsTheCpuChooses) {
  const PointSet points = spherePoints(20000);
  Scan detail;
  detail.points = points;
  const Scan coarse = test::makeIcosphere(2);
  auto lod = buildPointLod(points);
  ASSERT_TRUE(lod.ok());
  const ApoTexture empty = [] {
    Octree octree;
    octree.nodes.push_back({});
    octree.nodes[0].normal = Vec3f::UnitZ();
    return encodeApo(octree, 0, NormalEncoding::Oct24, 0, 0).value();
  }();
  for (const float threshold : {0.05f, 0.5f, 2.0f, 1000.0f}) {
    RenderOptions options;
    options.size = 256;
    options.views = 3;
    options.timedFrames = 0;
    options.lodThreshold = threshold;
    auto views = renderViews(&detail, coarse, empty, test::checked(options));
    ASSERT_TRUE(views.ok()) << views.error().message;
    for (const ViewImages& view : *views) {
      const float pixelsPerUnit = 256.0f / (2.0f * std::tan(0.5f * view.camera.fovYDegrees * std::numbers::pi_v<float> / 180.0f));
      std::uint64_t expected = 0;
      for (std::size_t p = 0; p < lod->patches.size(); ++p) {
        const int level = chooseLodLevel(lod->levels[3][p], lod->patches[p], view.camera.eye, pixelsPerUnit, threshold);
        expected += level == 3 ? 1 : lod->patches[p].count[2 - level];
      }
      EXPECT_EQ(view.cost.referenceSent, lod->patches.size());
      EXPECT_EQ(view.cost.referenceDrawn, expected) << "threshold " << threshold;
      if (threshold == 1000.0f) {
        EXPECT_EQ(view.cost.referenceDrawn, lod->patches.size());
      }
    }
  }
  // Against every point's disc at the default threshold: the same sphere,
  // normals within a tenth of a degree on average (at 256 px, 20,000 points
  // are about a pixel each: the LOD draws them all).
  RenderOptions options;
  options.size = 256;
  options.views = 3;
  options.timedFrames = 0;
  auto withLod = renderViews(&detail, coarse, empty, test::checked(options));
  options.pointLod = false;
  auto allPoints = renderViews(&detail, coarse, empty, test::checked(options));
  ASSERT_TRUE(withLod.ok() && allPoints.ok());
  for (std::size_t v = 0; v < withLod->size(); ++v) {
    EXPECT_EQ((*allPoints)[v].cost.referenceSent, points.size());
    EXPECT_EQ((*allPoints)[v].cost.referenceDrawn, points.size());
    const AngularStats apart = angularErrors((*withLod)[v].reference.normals, (*allPoints)[v].reference.normals);
    EXPECT_GT(apart.pixels, 10000u);
    EXPECT_LT(apart.mean, 0.1) << "view " << v;
  }
}

}  // namespace
}  // namespace apo
