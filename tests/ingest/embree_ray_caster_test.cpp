#include "ingest/ingest.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <random>

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

TEST(EmbreeMeshCaster, AgreesWithBruteForceOnAnIcosphere) {
  const Scan sphere = test::makeIcosphere(2);
  auto caster = makeEmbreeMeshCaster(sphere);
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

TEST(EmbreeMeshCaster, RefusesAPointCloud) {
  Scan cloud;
  cloud.points.positions = {{0, 0, 0}};
  EXPECT_FALSE(makeEmbreeMeshCaster(cloud).ok());
}

}  // namespace
}  // namespace apo
