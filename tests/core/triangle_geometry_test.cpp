#include "core/triangle_geometry.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace apo {
namespace {

// The nearest of a dense grid of the triangle's points: the independent
// reference for Ericson's region tests.
float denseSearchDistance(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  float best = 1e9f;
  const int n = 400;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j)
      best = std::min(best, (a + (b - a) * (float(i) / n) + (c - a) * (float(j) / n) - p).norm());
  return best;
}

TEST(ClosestPointOnTriangle, MatchesDenseSearchInEveryRegion) {
  const Vec3f a(0, 0, 0), b(1, 0, 0), c(0.2f, 0.9f, 0.1f);
  for (const Vec3f& p : {Vec3f(0.3f, 0.3f, 1.0f), Vec3f(-1, -1, 0), Vec3f(2, 0.1f, 0), Vec3f(0.5f, -0.5f, 0.3f),
                         Vec3f(0.1f, 2.0f, -0.2f), Vec3f(0.9f, 0.9f, 0.0f)}) {
    const TrianglePoint closest = closestPointOnTriangle(p, a, b, c);
    const Vec3f& w = closest.weights;
    const Vec3f q = w[0] * a + w[1] * b + w[2] * c;
    EXPECT_NEAR((q - p).norm(), denseSearchDistance(p, a, b, c), 2e-3f);
    EXPECT_NEAR((closest.position - q).norm(), 0.0f, 1e-6f);
    EXPECT_NEAR(closest.squaredDistance, (p - q).squaredNorm(), 1e-5f);
    EXPECT_NEAR(w.sum(), 1.0f, 1e-5f);
    EXPECT_GE(w.minCoeff(), 0.0f);
  }
}

TEST(ClosestPointOnTriangle, ATriangleWithoutAreaIsItsEdges) {
  // Collinear corners: the closest point is on the segment from a to c.
  const Vec3f a(0, 0, 0), b(1, 0, 0), c(2, 0, 0);
  const TrianglePoint closest = closestPointOnTriangle(Vec3f(1.5f, 1.0f, 0.0f), a, b, c);
  EXPECT_NEAR((closest.position - Vec3f(1.5f, 0, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(closest.squaredDistance, 1.0f, 1e-6f);
  // A triangle collapsed to a point.
  const TrianglePoint point = closestPointOnTriangle(Vec3f(0, 3, 4), a, a, a);
  EXPECT_NEAR(point.squaredDistance, 25.0f, 1e-5f);
}

}  // namespace
}  // namespace apo
