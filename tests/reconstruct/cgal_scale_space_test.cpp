// Scale-space reconstruction on noisy virtual scans of a sphere and a torus
// with analytic surfaces: the triangles come back on the unsmoothed points,
// accurate, manifold and consistently oriented.
#include "reconstruct/cgal_adapters.h"

#include "tests/reconstruct/mesh_checks.h"

#include <gtest/gtest.h>

namespace apo::cgal {
namespace {

struct Shape {
  const char* name;
  Scan (*truth)();
  float (*distance)(const Vec3f&);
  Vec3f (*outward)(const Vec3f&);
  int raysPerSide;  // 10 views: about 28K points on either shape
  std::int64_t euler;
};

const Shape kSphere{"sphere", test::sphereTruth, test::distanceToUnitSphere, test::sphereOutward, 60, 2};
const Shape kTorus{"torus", test::torusTruth, test::distanceToTestTorus, test::torusOutward, 80, 0};

class ScaleSpaceOnScans : public ::testing::TestWithParam<Shape> {};

TEST_P(ScaleSpaceOnScans, IsAccurateManifoldAndOnTheOriginalPoints) {
  const Shape& shape = GetParam();
  const Scan truth = shape.truth();
  const PointSet points = test::scannedPoints(truth, 10, shape.raysPerSide);
  ASSERT_GT(points.size(), 20000u);

  auto mesh = scaleSpaceReconstruct(points.positions, averageSpacing(points.positions, 6), 4.0);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  ASSERT_EQ(mesh->points.positions, points.positions);  // unsmoothed, input order

  const Scan main = test::largestComponent(*mesh);
  const test::Topology all = test::topologyOf(*mesh), topology = test::topologyOf(main);
  EXPECT_GT(static_cast<double>(topology.triangles), 0.99 * static_cast<double>(all.triangles));
  EXPECT_GT(static_cast<double>(topology.vertices), 0.99 * static_cast<double>(points.size()));

  const double diagonal = boundingBox(truth.points.positions).diagonal();
  EXPECT_LT(test::meanVertexDistance(main, shape.distance) / diagonal, 0.005);
  EXPECT_EQ(topology.nonManifoldEdges, 0u);
  EXPECT_EQ(topology.inconsistentEdges, 0u);
  EXPECT_LE(topology.boundaryEdges, 0.002 * static_cast<double>(topology.edges));
  if (topology.boundaryEdges == 0) {
    EXPECT_EQ(topology.euler(), shape.euler);
  }
  const double outward = test::outwardAreaFraction(main, shape.outward);
  EXPECT_TRUE(outward > 0.999 || outward < 0.001) << outward;
}

INSTANTIATE_TEST_SUITE_P(Shapes, ScaleSpaceOnScans, ::testing::Values(kSphere, kTorus),
                         [](const auto& info) { return std::string(info.param.name); });

// Compared up to a few triangles: the advancing-front mesher breaks ties by
// comparing addresses (see cgal_advancing_front_test.cpp).
TEST(ScaleSpaceReconstruct, DefaultScaleIsFourSpacings) {
  const PointSet points = test::scannedPoints(test::torusTruth(), 6, 48);
  const double spacing = averageSpacing(points.positions, 6);
  auto byDefault = scaleSpaceReconstruct(points.positions, spacing, 0.0);
  auto four = scaleSpaceReconstruct(points.positions, spacing, 4.0);
  auto two = scaleSpaceReconstruct(points.positions, spacing, 2.0);
  ASSERT_TRUE(byDefault.ok() && four.ok() && two.ok());
  EXPECT_LE(test::trianglesMissingFrom(*byDefault, *four), four->triangles.size() / 1000);
  EXPECT_GT(test::trianglesMissingFrom(*two, *four), four->triangles.size() / 30);  // the scale matters
}

TEST(ScaleSpaceReconstruct, RefusesTooFewPointsOrNoSpacing) {
  auto few = scaleSpaceReconstruct({Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}, 0.5, 4.0);
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().kind, ErrorKind::BadInput);
  auto noSpacing = scaleSpaceReconstruct(test::fibonacciSpherePoints(500), 0.0, 4.0);
  ASSERT_FALSE(noSpacing.ok());
  EXPECT_EQ(noSpacing.error().kind, ErrorKind::BadInput);
}

}  // namespace
}  // namespace apo::cgal
