#include "adapters/embree/embree_ray_caster.h"

#include "core/triangle_geometry.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <thread>

namespace apo {
namespace {

// Moller-Trumbore, the independent reference.
std::optional<float> intersectTriangle(const Ray& ray, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f e1 = b - a, e2 = c - a;
  const Vec3f p = ray.direction.cross(e2);
  const float det = e1.dot(p);
  if (std::abs(det) < 1e-12f) return std::nullopt;
  const Vec3f s = ray.origin - a;
  const float u = s.dot(p) / det;
  const Vec3f q = s.cross(e1);
  const float v = ray.direction.dot(q) / det;
  const float t = e2.dot(q) / det;
  if (u < 0 || v < 0 || u + v > 1 || t < ray.tNear || t > ray.tFar) return std::nullopt;
  return t;
}

TEST(EmbreeMeshCaster, HitsOneTriangleWithKnownDistanceAndBarycentrics) {
  Scan triangle;
  triangle.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.triangles = {{0, 1, 2}};
  auto caster = makeEmbreeMeshCaster(triangle);
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits;
  (*caster)->intersect({{Vec3f(0.25f, 0.5f, 2.0f), Vec3f(0, 0, -1)}, {Vec3f(2, 2, 2), Vec3f(0, 0, -1)}}, hits);
  ASSERT_TRUE(hits[0].hit());
  EXPECT_FLOAT_EQ(hits[0].t, 2.0f);
  EXPECT_FLOAT_EQ(hits[0].u, 0.25f);
  EXPECT_FLOAT_EQ(hits[0].v, 0.5f);
  EXPECT_FALSE(hits[1].hit());
}

using MeshCasterFactory = Result<std::unique_ptr<RayCaster>> (*)(const Scan&);

void expectBruteForceHitsOnAnIcosphere(MeshCasterFactory makeCaster) {
  const Scan sphere = test::makeIcosphere(2);
  auto caster = makeCaster(sphere);
  ASSERT_TRUE(caster.ok());
  std::mt19937 random(3);
  std::uniform_real_distribution<float> uniform(-1.5f, 1.5f);
  std::vector<Ray> rays;
  for (int i = 0; i < 2000; ++i)
    rays.push_back({Vec3f(uniform(random), uniform(random), uniform(random)), Vec3f(uniform(random), uniform(random), uniform(random))});
  std::vector<RayHit> hits;
  (*caster)->intersect(rays, hits);
  int hitCount = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    std::optional<float> nearest;
    for (const Triangle& t : sphere.triangles) {
      const auto& p = sphere.points.positions;
      if (auto hit = intersectTriangle(rays[i], p[t[0]], p[t[1]], p[t[2]]); hit && (!nearest || *hit < *nearest)) nearest = hit;
    }
    ASSERT_EQ(hits[i].hit(), nearest.has_value()) << "ray " << i;
    if (nearest) {
      EXPECT_NEAR(hits[i].t, *nearest, 1e-4f * (1 + *nearest)) << "ray " << i;
      ++hitCount;
    }
  }
  EXPECT_GT(hitCount, 500);  // the comparison covered real hits
}

// Rays from outside aimed at the middle of every edge and at every vertex:
// each meets the closed sphere there, where a non-watertight test may let
// some slip between the triangles.
void expectEdgesAndVerticesHit(MeshCasterFactory makeCaster) {
  const Scan sphere = test::makeIcosphere(2);
  auto caster = makeCaster(sphere);
  ASSERT_TRUE(caster.ok());
  const auto& p = sphere.points.positions;
  std::vector<Vec3f> targets(p.begin(), p.end());
  for (const Triangle& t : sphere.triangles)
    for (int c = 0; c < 3; ++c) targets.push_back(0.5f * (p[t[c]] + p[t[(c + 1) % 3]]));
  std::vector<Ray> rays;
  for (const Vec3f& target : targets) rays.push_back({2.0f * target.normalized(), -target.normalized()});
  std::vector<RayHit> hits;
  (*caster)->intersect(rays, hits);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    ASSERT_TRUE(hits[i].hit()) << "ray " << i;
    EXPECT_NEAR(hits[i].t, 2.0f - targets[i].norm(), 1e-5f) << "ray " << i;
  }
}

TEST(EmbreeMeshCaster, AgreesWithBruteForceOnAnIcosphere) { expectBruteForceHitsOnAnIcosphere(makeEmbreeMeshCaster); }

TEST(EmbreeMeshCaster, QuickBuiltAgreesWithBruteForceOnAnIcosphere) {
  expectBruteForceHitsOnAnIcosphere(makeQuickBuiltEmbreeMeshCaster);
}

TEST(EmbreeMeshCaster, NoRaySlipsThroughAnEdgeOrAVertex) { expectEdgesAndVerticesHit(makeEmbreeMeshCaster); }

TEST(EmbreeMeshCaster, NoRaySlipsThroughAnEdgeOrAVertexWhenQuickBuilt) {
  expectEdgesAndVerticesHit(makeQuickBuiltEmbreeMeshCaster);
}

TEST(EmbreeMeshCaster, RefusesAPointCloud) {
  Scan cloud;
  cloud.points.positions = {{0, 0, 0}};
  EXPECT_FALSE(makeEmbreeMeshCaster(cloud).ok());
  EXPECT_FALSE(makeQuickBuiltEmbreeMeshCaster(cloud).ok());
}

// ---- Oriented discs ----------------------------------------------------------

PointSet oneDisc(const Vec3f& centre, const Vec3f& normal) {
  PointSet disc;
  disc.positions = {centre};
  disc.normals = {normal};
  return disc;
}

// Points uniform in [-1, 1]^3 with uniformly random unit normals.
PointSet randomOrientedPoints(std::size_t count, std::uint64_t seed) {
  PointSet points;
  points.positions = test::randomCubePoints(count, seed);
  std::mt19937 random(static_cast<unsigned>(seed));
  std::normal_distribution<float> gaussian;
  for (std::size_t i = 0; i < count; ++i)
    points.normals.push_back(Vec3f(gaussian(random), gaussian(random), gaussian(random)).normalized());
  return points;
}

std::vector<float> scaled(std::vector<float> radii, float factor) {
  for (float& r : radii) r *= factor;
  return radii;
}

TEST(EmbreeDiscCaster, AgreesWithBruteForceOnRandomDiscs) {
  const PointSet points = randomOrientedPoints(400, 5);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> radius(0.03f, 0.15f), uniform(-1.5f, 1.5f);
  std::vector<float> radii(points.size());
  for (float& r : radii) r = radius(random);
  std::vector<Ray> rays;
  for (int i = 0; i < 3000; ++i)
    rays.push_back({Vec3f(uniform(random), uniform(random), uniform(random)), Vec3f(uniform(random), uniform(random), uniform(random))});
  auto caster = makeEmbreeDiscCaster(points, radii);
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits, expected, inner, outer;
  (*caster)->intersect(rays, hits);
  Scan cloud;
  cloud.points = points;
  test::BruteForceCaster(cloud, radii).intersect(rays, expected);
  // A ray grazing a rim may go either way in float: such rays are those whose
  // answer changes when every radius shrinks or grows by 1e-4, and are skipped.
  test::BruteForceCaster(cloud, scaled(radii, 1 - 1e-4f)).intersect(rays, inner);
  test::BruteForceCaster(cloud, scaled(radii, 1 + 1e-4f)).intersect(rays, outer);
  int compared = 0, hitCount = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    if (inner[i].primitive != outer[i].primitive) continue;
    ++compared;
    ASSERT_EQ(hits[i].primitive, expected[i].primitive) << "ray " << i;
    if (!expected[i].hit()) continue;
    ++hitCount;
    EXPECT_NEAR(hits[i].t, expected[i].t, 1e-4f * std::abs(expected[i].t)) << "ray " << i;
    EXPECT_TRUE(hits[i].geometricNormal.isApprox(points.normals[hits[i].primitive], 1e-6f)) << "ray " << i;
    EXPECT_EQ(hits[i].u, 0.0f);
    EXPECT_EQ(hits[i].v, 0.0f);
  }
  EXPECT_GT(compared, 2990);  // grazing rays are rare
  EXPECT_GT(hitCount, 500);   // the comparison covered real hits
}

TEST(EmbreeDiscCaster, RayStraightDownHitsTheUpperDiscAtItsHeight) {
  PointSet discs = oneDisc(Vec3f(0.3f, -0.2f, 0.75f), Vec3f::UnitZ());
  discs.positions.push_back(Vec3f(0.3f, -0.2f, 0.25f));  // a second disc below
  discs.normals.push_back(Vec3f::UnitZ());
  auto caster = makeEmbreeDiscCaster(discs, {0.5f, 0.5f});
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits;
  (*caster)->intersect({{Vec3f(0.5f, 0.1f, 3.0f), Vec3f(0, 0, -1)}, {Vec3f(0.5f, 0.1f, 3.0f), Vec3f(0, 0, -2)}}, hits);
  ASSERT_EQ(hits[0].primitive, 0u);
  EXPECT_FLOAT_EQ(hits[0].t, 2.25f);
  EXPECT_TRUE(hits[0].geometricNormal.normalized().isApprox(Vec3f::UnitZ()));
  ASSERT_EQ(hits[1].primitive, 0u);
  EXPECT_FLOAT_EQ(hits[1].t, 1.125f);  // t is in units of the direction
}

TEST(EmbreeDiscCaster, RayJustOutsideTheRadiusMissesAndJustInsideHits) {
  auto caster = makeEmbreeDiscCaster(oneDisc(Vec3f::Zero(), Vec3f::UnitZ()), {0.5f});
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits;
  (*caster)->intersect({{Vec3f(0.501f, 0, 1), Vec3f(0, 0, -1)},
                        {Vec3f(0.499f, 0, 1), Vec3f(0, 0, -1)},
                        {Vec3f(0.36f, 0.36f, 1), Vec3f(0, 0, -1)},    // 0.509 from the centre
                        {Vec3f(0.35f, 0.35f, 1), Vec3f(0, 0, -1)}},  // 0.495 from the centre
                       hits);
  EXPECT_FALSE(hits[0].hit());
  EXPECT_TRUE(hits[1].hit());
  EXPECT_FALSE(hits[2].hit());
  EXPECT_TRUE(hits[3].hit());
}

TEST(EmbreeDiscCaster, TiltedDiscIsHitOnItsPlaneFromEitherSide) {
  const Vec3f normal(0.0f, 0.6f, 0.8f);  // plane through the origin: z = -0.75 y
  auto caster = makeEmbreeDiscCaster(oneDisc(Vec3f::Zero(), normal), {1.0f});
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits;
  (*caster)->intersect({{Vec3f(0.1f, 0.4f, 2.0f), Vec3f(0, 0, -1)}, {Vec3f(0.1f, 0.4f, -2.0f), Vec3f(0, 0, 1)}}, hits);
  ASSERT_TRUE(hits[0].hit());
  EXPECT_NEAR(hits[0].t, 2.3f, 1e-5f);
  ASSERT_TRUE(hits[1].hit());
  EXPECT_NEAR(hits[1].t, 1.7f, 1e-5f);
  EXPECT_TRUE(hits[1].geometricNormal.isApprox(normal));  // as given, not flipped towards the ray
}

TEST(EmbreeDiscCaster, RespectsTheRaySegment) {
  auto caster = makeEmbreeDiscCaster(oneDisc(Vec3f::Zero(), Vec3f::UnitZ()), {0.5f});
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::vector<RayHit> hits;
  (*caster)->intersect({{Vec3f(0, 0, 1), Vec3f(0, 0, -1), 0.0f, 0.9f}, {Vec3f(0, 0, 1), Vec3f(0, 0, -1), 1.1f}}, hits);
  EXPECT_FALSE(hits[0].hit());
  EXPECT_FALSE(hits[1].hit());
}

TEST(EmbreeDiscCaster, ConcurrentCallsMatchOneCall) {
  const PointSet points = randomOrientedPoints(300, 11);
  auto caster = makeEmbreeDiscCaster(points, std::vector<float>(points.size(), 0.1f));
  ASSERT_TRUE(caster.ok()) << caster.error().message;
  std::mt19937 random(13);
  std::uniform_real_distribution<float> uniform(-1.5f, 1.5f);
  std::vector<Ray> rays;
  for (int i = 0; i < 4000; ++i)
    rays.push_back({Vec3f(uniform(random), uniform(random), uniform(random)), Vec3f(uniform(random), uniform(random), uniform(random))});
  std::vector<RayHit> sequential;
  (*caster)->intersect(rays, sequential);
  std::vector<std::vector<RayHit>> perThread(3);
  std::vector<std::thread> threads;
  for (auto& hits : perThread) threads.emplace_back([&] { (*caster)->intersect(rays, hits); });
  for (auto& thread : threads) thread.join();
  for (const auto& hits : perThread)
    for (std::size_t i = 0; i < rays.size(); ++i) {
      ASSERT_EQ(hits[i].primitive, sequential[i].primitive) << "ray " << i;
      EXPECT_EQ(hits[i].t, sequential[i].t) << "ray " << i;
    }
}

TEST(EmbreeDiscCaster, RefusesMissingNormalsAndBadRadii) {
  const PointSet disc = oneDisc(Vec3f::Zero(), Vec3f::UnitZ());
  PointSet noNormals = disc;
  noNormals.normals.clear();
  auto refused = [](const Result<std::unique_ptr<RayCaster>>& result) {
    return !result.ok() && result.error().kind == ErrorKind::BadInput;
  };
  EXPECT_TRUE(refused(makeEmbreeDiscCaster(PointSet{}, {})));
  EXPECT_TRUE(refused(makeEmbreeDiscCaster(noNormals, {0.5f})));
  EXPECT_TRUE(refused(makeEmbreeDiscCaster(disc, {})));
  EXPECT_TRUE(refused(makeEmbreeDiscCaster(disc, {0.5f, 0.5f})));
  for (float bad : {0.0f, -0.5f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()})
    EXPECT_TRUE(refused(makeEmbreeDiscCaster(disc, {bad}))) << bad;
  const auto result = makeEmbreeDiscCaster(disc, {-0.5f});
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.error().message.find("point 0"), std::string::npos) << result.error().message;
}

// The closest point against brute force over every triangle, on a thin
// slab of large triangles (two 4 x 4 grids 0.002 apart, facing away): the
// case where the nearest vertices lie on the other sheet.
TEST(EmbreeClosestPoint, AgreesWithBruteForceOnAThinSlabOfLargeTriangles) {
  Scan slab;
  for (int side = 0; side < 2; ++side) {
    const Scan grid = test::makeSquareGrid(4);
    const auto first = static_cast<std::uint32_t>(slab.points.size());
    for (const Vec3f& p : grid.points.positions) {
      slab.points.positions.push_back(p + Vec3f(0.0f, 0.0f, side == 0 ? 0.001f : -0.001f));
      slab.points.normals.push_back(side == 0 ? Vec3f::UnitZ() : Vec3f(-Vec3f::UnitZ()));
    }
    for (const Triangle& t : grid.triangles)
      slab.triangles.push_back(side == 0 ? Triangle{first + t[0], first + t[1], first + t[2]}
                                         : Triangle{first + t[0], first + t[2], first + t[1]});
  }
  auto finder = makeEmbreeClosestPoint(slab);
  ASSERT_TRUE(finder.ok()) << finder.error().message;
  std::mt19937 random(3);
  std::uniform_real_distribution<float> inside(0.0f, 1.0f), height(-0.0015f, 0.0015f);
  int upper = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3f q(inside(random), inside(random), height(random));
    float best = std::numeric_limits<float>::infinity();
    for (const Triangle& t : slab.triangles) {
      const auto& p = slab.points.positions;
      best = std::min(best, std::sqrt(closestPointOnTriangle(q, p[t[0]], p[t[1]], p[t[2]]).squaredDistance));
    }
    const auto found = (*finder)->closest(q);
    ASSERT_TRUE(found.has_value());
    ASSERT_NEAR((found->position - q).norm(), best, 1e-6f) << q.transpose();
    // The normal is the nearer sheet's.
    ASSERT_FLOAT_EQ(found->normal.z(), q.z() >= 0.0f ? 1.0f : -1.0f) << q.transpose();
    upper += q.z() >= 0.0f ? 1 : 0;
  }
  EXPECT_GT(upper, 5000);
  EXPECT_FALSE(makeEmbreeClosestPoint(test::makeSquareGrid(2)).ok()) << "no vertex normals";
}

}  // namespace
}  // namespace apo
