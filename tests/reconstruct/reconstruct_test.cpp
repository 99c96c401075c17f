// Points to M against analytic ground truth: scans of a sphere and a torus
// made by the virtual scanner, normals estimated by ingest, reconstructed.
#include "reconstruct/reconstruct.h"

#include "ingest/ingest.h"
#include "pipeline/pipeline.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr float kMajor = 1.0f, kMinor = 0.35f;

// A noisy, slightly misregistered scan of `mesh` with ingest's normals.
PointSet scannedPoints(const Scan& mesh, const std::string& name) {
  SimulateScanOptions scanner;
  scanner.views = 10;
  scanner.raysPerSide = 90;
  scanner.rangeNoise = 0.0005;
  scanner.misregistration = 0.0001;
  auto simulated = simulateRangeScan(mesh, test::checked(scanner));
  EXPECT_TRUE(simulated.ok());
  const fs::path path = test::freshTempDir() / (name + ".ply");
  EXPECT_TRUE(writePly(path, simulated->scan).ok());
  auto ingested = ingestScan(path, test::checked(IngestOptions{}));
  EXPECT_TRUE(ingested.ok()) << ingested.error().message;
  return ingested->scan.points;
}

double meanDistance(const Scan& mesh, const std::function<float(const Vec3f&)>& distance) {
  double sum = 0.0;
  for (const Vec3f& p : mesh.points.positions) sum += distance(p);
  return sum / static_cast<double>(mesh.points.size());
}

struct Case {
  ReconstructionMethod method;
  bool torus;
};

class ReconstructShapes : public ::testing::TestWithParam<Case> {};

TEST_P(ReconstructShapes, MatchesTheAnalyticSurfaceAndTopology) {
  const Case c = GetParam();
  const Scan truth = c.torus ? test::makeTorus(kMajor, kMinor, 160, 64) : test::makeIcosphere(5);
  const PointSet points = scannedPoints(truth, c.torus ? "torus" : "sphere");
  ReconstructOptions options;
  options.method = c.method;
  auto result = reconstructSurface(points, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const Scan& M = result->mesh;
  const ReconstructReport& report = result->report;

  const double diagonal = boundingBox(truth.points.positions).diagonal();
  const double mean = meanDistance(M, [&](const Vec3f& p) {
    return c.torus ? test::distanceToTorus(p, kMajor, kMinor) : std::abs(p.norm() - 1.0f);
  });
  EXPECT_LT(mean / diagonal, 0.005) << "mean distance to the analytic surface";
  EXPECT_EQ(report.quality.components, 1u);
  EXPECT_EQ(report.quality.nonManifoldEdges, 0u);
  if (report.quality.boundaryLoops == 0) {
    EXPECT_EQ(report.quality.eulerCharacteristic, c.torus ? 0 : 2);
  }
  if (c.method == ReconstructionMethod::Poisson) {
    EXPECT_EQ(report.quality.boundaryLoops, 0u);
  }
  EXPECT_LT(report.pointToMeshMean, 0.005);
  // Oriented outwards: vertex normals agree with the analytic ones.
  std::size_t outward = 0;
  for (std::size_t i = 0; i < M.points.size(); ++i) {
    const Vec3f& p = M.points.positions[i];
    Vec3f analytic = p;
    if (c.torus) {
      const Vec3f ringCentre = kMajor * Vec3f(p.x(), p.y(), 0).normalized();
      analytic = p - ringCentre;
    }
    outward += M.points.normals[i].dot(analytic.normalized()) > 0.5f ? 1 : 0;
  }
  EXPECT_GT(static_cast<double>(outward) / M.points.size(), 0.99);
}

INSTANTIATE_TEST_SUITE_P(PoissonAndAdvancingFront, ReconstructShapes,
                         ::testing::Values(Case{ReconstructionMethod::Poisson, false},
                                           Case{ReconstructionMethod::Poisson, true},
                                           Case{ReconstructionMethod::AdvancingFront, false},
                                           Case{ReconstructionMethod::AdvancingFront, true}),
                         [](const auto& info) {
                           return methodName(info.param.method).substr(0, 7) + (info.param.torus ? "_torus" : "_sphere");
                         });

TEST(ReconstructSurface, LargeInputIsSubsampledAndSaysSo) {
  PointSet points;
  for (const Vec3f& p : test::fibonacciSpherePoints(12000)) {
    points.positions.push_back(p);
    points.normals.push_back(p);
  }
  ReconstructOptions options;
  options.method = ReconstructionMethod::AdvancingFront;
  options.maxPoints = 3000;
  auto result = reconstructSurface(points, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->report.pointsIn, 12000u);
  EXPECT_LE(result->report.pointsUsed, 3000u);
  EXPECT_GT(result->report.pointsUsed, 1500u);
}

// Points of the unit sphere's cap above height `zMin`, outward normals.
PointSet sphereCap(float zMin) {
  PointSet cap;
  for (const Vec3f& p : test::fibonacciSpherePoints(6000)) {
    if (p.z() < zMin) continue;
    cap.positions.push_back(p);
    cap.normals.push_back(p);
  }
  return cap;
}

TEST(ReconstructSurface, AutoPicksPoissonForClosedAndAdvancingFrontForOpen) {
  // The mean unit normal of a closed sphere is 0; of the cap above z = 0.5,
  // the mean of z over the cap: (1 + 0.5) / 2 = 0.75.
  EXPECT_LT(normalImbalance(sphereCap(-2.0f)), 0.01);
  EXPECT_NEAR(normalImbalance(sphereCap(0.5f)), 0.75, 0.01);
  auto closed = reconstructSurface(sphereCap(-2.0f), test::checked(ReconstructOptions{}));
  ASSERT_TRUE(closed.ok()) << closed.error().message;
  EXPECT_EQ(closed->report.method, "poisson");
  auto open = reconstructSurface(sphereCap(0.5f), test::checked(ReconstructOptions{}));
  ASSERT_TRUE(open.ok()) << open.error().message;
  EXPECT_EQ(open->report.method, "advancing-front");
  EXPECT_EQ(open->report.quality.boundaryLoops, 1u);
}

TEST(ReconstructSurface, ReportsRisingProgressToTheEnd) {
  std::vector<double> fractions;
  auto result = reconstructSurface(sphereCap(0.5f), test::checked(ReconstructOptions{}), [&](double f) { fractions.push_back(f); });
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_GE(fractions.size(), 3u);  // after the spacing, after the method, after clean-up, the end
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_GT(fractions.front(), 0.0);
  EXPECT_EQ(fractions.back(), 1.0);
}

TEST(ReconstructSurface, TooFewPointsIsBadInput) {
  PointSet points;
  points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  points.normals.assign(3, Vec3f::UnitZ());
  auto result = reconstructSurface(points, test::checked(ReconstructOptions{}));
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(result.error().message, HasSubstr("too few"));
}

TEST(ReconstructSurface, PointsWithoutNormalsAskForIngest) {
  PointSet points;
  points.positions = test::fibonacciSpherePoints(500);
  auto result = reconstructSurface(points, test::checked(ReconstructOptions{}));
  ASSERT_FALSE(result.ok());
  EXPECT_THAT(result.error().message, HasSubstr("apo ingest"));
}

TEST(ReconstructSurface, CoplanarPointsAreBadInput) {
  PointSet points;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) {
      points.positions.emplace_back(i * 0.1f, j * 0.1f, 2.0f);
      points.normals.push_back(Vec3f::UnitZ());
    }
  auto result = reconstructSurface(points, test::checked(ReconstructOptions{}));
  ASSERT_FALSE(result.ok());
  EXPECT_THAT(result.error().message, HasSubstr("one plane"));
}

TEST(ReconstructSurface, BadOptionsAreUsageErrors) {
  ReconstructOptions options;
  options.minComponent = 1.5;
  auto result = check(options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().kind, ErrorKind::Usage);
}

TEST(ReconstructScan, AMeshIsAdoptedAsM) {
  const Scan sphere = test::makeIcosphere(2);
  auto result = reconstructScan(sphere, test::checked(ReconstructOptions{}));
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->report.method, "input-mesh");
  EXPECT_EQ(result->mesh.triangles, sphere.triangles);
  EXPECT_EQ(result->report.quality.eulerCharacteristic, 2);
}

}  // namespace
}  // namespace apo
