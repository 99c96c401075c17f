// Poisson on noisy virtual scans of a sphere and a torus with analytic
// surfaces: accuracy, closed topology, outward orientation, repeatability.
#include "adapters/cgal/cgal_jobs.h"

#include "tests/reconstruct/mesh_checks.h"

#include <gtest/gtest.h>

namespace apo::cgal_adapter {
namespace {

// CGAL's own Delaunay-ball radius bound (30 spacings): coarse, so fast.
constexpr double kCgalDefaultRadius = 30.0;

const test::ScannedShape kSphere = test::scannedSphere(52);  // about 21K points
const test::ScannedShape kTorus = test::scannedTorus(68);

class PoissonOnScans : public ::testing::TestWithParam<test::ScannedShape> {};

TEST_P(PoissonOnScans, IsAccurateClosedAndOutward) {
  const test::ScannedShape& shape = GetParam();
  const Scan truth = shape.truth();
  const PointSet points = test::scannedPoints(truth, 10, shape.raysPerSide);
  ASSERT_GT(points.size(), 18000u);
  const double spacing = averageSpacing(points.positions, 6).value();

  auto mesh = poissonReconstruct(points, spacing, 0.375, kCgalDefaultRadius, 1);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;

  const double diagonal = boundingBox(truth.points.positions).diagonal();
  EXPECT_LT(test::meanVertexDistance(*mesh, shape.distance) / diagonal, 0.005);
  const test::Topology topology = test::topologyOf(*mesh);
  EXPECT_EQ(topology.vertices, mesh->points.size());  // no unused vertex
  EXPECT_EQ(topology.boundaryEdges, 0u);
  EXPECT_EQ(topology.nonManifoldEdges, 0u);
  EXPECT_EQ(topology.inconsistentEdges, 0u);
  EXPECT_EQ(topology.components, 1u);
  EXPECT_EQ(topology.euler(), shape.euler);
  EXPECT_GT(test::outwardAreaFraction(*mesh, shape.outward), 0.999);
}

INSTANTIATE_TEST_SUITE_P(Shapes, PoissonOnScans, ::testing::Values(kSphere, kTorus),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(PoissonReconstruct, RepeatsExactlyWithTheSameSeed) {
  const PointSet points = test::scannedPoints(test::torusTruth(), 6, 48);
  const double spacing = averageSpacing(points.positions, 6).value();
  auto first = poissonReconstruct(points, spacing, 0.375, kCgalDefaultRadius, 7);
  auto second = poissonReconstruct(points, spacing, 0.375, kCgalDefaultRadius, 7);
  ASSERT_TRUE(first.ok() && second.ok());
  EXPECT_EQ(first->points.positions, second->points.positions);
  EXPECT_EQ(first->triangles, second->triangles);
}

TEST(PoissonReconstruct, ComponentsApartAllFaceOutwards) {
  // The mesh export of CGAL's own poisson_surface_reconstruction_delaunay
  // orients only the component with the topmost triangle.
  PointSet points = test::scannedPoints(test::sphereTruth(), 6, 40);
  const std::size_t count = points.size();
  for (std::size_t i = 0; i < count; ++i) {
    points.positions.push_back(0.5f * points.positions[i] + Vec3f(3.0f, 0.0f, -1.0f));
    points.normals.push_back(points.normals[i]);
  }
  auto mesh = poissonReconstruct(points, averageSpacing(points.positions, 6).value(), 0.375, kCgalDefaultRadius, 1);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  EXPECT_EQ(test::topologyOf(*mesh).components, 2u);
  const auto outward = [](const Vec3f& p) {
    return p.x() < 1.5f ? p.normalized() : Vec3f(p - Vec3f(3.0f, 0.0f, -1.0f)).normalized();
  };
  EXPECT_GT(test::outwardAreaFraction(*mesh, outward), 0.999);
}

TEST(PoissonReconstruct, RefusesPointsWithoutNormalsOrSpacing) {
  PointSet points;
  points.positions = test::fibonacciSpherePoints(500);
  auto noNormals = poissonReconstruct(points, 0.1, 0.375, kCgalDefaultRadius, 1);
  ASSERT_FALSE(noNormals.ok());
  EXPECT_EQ(noNormals.error().kind, ErrorKind::BadInput);
  points.normals = points.positions;
  auto noSpacing = poissonReconstruct(points, 0.0, 0.375, kCgalDefaultRadius, 1);
  ASSERT_FALSE(noSpacing.ok());
  EXPECT_EQ(noSpacing.error().kind, ErrorKind::BadInput);
  auto empty = poissonReconstruct(PointSet{}, 0.1, 0.375, kCgalDefaultRadius, 1);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().kind, ErrorKind::BadInput);
}

}  // namespace
}  // namespace apo::cgal_adapter
