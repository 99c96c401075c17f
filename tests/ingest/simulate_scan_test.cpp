#include "ingest/ingest.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace apo {
namespace {

// The scanner against the brute-force caster, the independent reference.
Result<SimulatedScan> scanOf(const Scan& mesh, const SimulateScanOptions& options) {
  const test::BruteForceCaster caster(mesh);
  return simulateScan(mesh, caster, test::checked(options));
}

TEST(SimulateScan, NoiselessScanOfASphereLiesOnIt) {
  const Scan sphere = test::makeIcosphere(4);  // faceting error below 0.3%
  SimulateScanOptions options;
  options.views = 6;
  options.raysPerSide = 60;
  options.rangeNoise = 0.0;
  options.misregistration = 0.0;
  options.withNormals = true;
  auto simulated = scanOf(sphere, options);
  ASSERT_TRUE(simulated.ok()) << simulated.error().message;
  const auto& points = simulated->scan.points;
  ASSERT_GT(points.size(), 6u * 60 * 60 / 2);
  ASSERT_EQ(points.normals.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(points.positions[i].norm(), 1.0f, 0.004f);
    EXPECT_GT(points.normals[i].dot(points.positions[i].normalized()), 0.99f);  // outward, faceted
  }
  ASSERT_EQ(simulated->viewOrigins.size(), 6u);
  for (const Vec3f& origin : simulated->viewOrigins) EXPECT_GT(origin.norm(), 1.9f);
}

TEST(SimulateScan, NoiseHasTheRequestedSpread) {
  const Scan sphere = test::makeIcosphere(4);
  SimulateScanOptions options;
  options.views = 4;
  options.raysPerSide = 80;
  options.rangeNoise = 0.01;  // of the bbox diagonal (2 * sqrt(3) for a unit sphere)
  options.misregistration = 0.0;
  auto simulated = scanOf(sphere, options);
  ASSERT_TRUE(simulated.ok());
  double sum = 0, sumSquares = 0;
  for (const Vec3f& p : simulated->scan.points.positions) {
    const double d = p.norm() - 1.0;
    sum += d;
    sumSquares += d * d;
  }
  const double n = static_cast<double>(simulated->scan.points.size());
  const double sigma = std::sqrt(sumSquares / n - (sum / n) * (sum / n));
  // Range noise along grazing rays projects less onto the radius: between the
  // cosine-weighted average (about 2/3) and the full sigma.
  const double expected = 0.01 * 2.0 * std::sqrt(3.0);
  EXPECT_GT(sigma, 0.5 * expected);
  EXPECT_LT(sigma, 1.1 * expected);
}

TEST(SimulateScan, SameSeedSameScanOtherSeedOtherScan) {
  const Scan sphere = test::makeIcosphere(3);
  SimulateScanOptions options;
  options.views = 3;
  options.raysPerSide = 30;
  auto a = scanOf(sphere, options);
  auto b = scanOf(sphere, options);
  options.seed = 2;
  auto c = scanOf(sphere, options);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->scan.points.positions, b->scan.points.positions);
  EXPECT_NE(a->scan.points.positions, c->scan.points.positions);
}

TEST(SimulateScan, RejectsBadOptions) {
  SimulateScanOptions options;
  options.views = 0;
  auto result = check(options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().kind, ErrorKind::Usage);
}

}  // namespace
}  // namespace apo
