// Scale-space reconstruction on noisy virtual scans of a sphere and a torus
// with analytic surfaces: the triangles come back on the unsmoothed points,
// accurate, manifold and consistently oriented.
#include "adapters/cgal/cgal_jobs.h"

#include "tests/reconstruct/mesh_checks.h"

#include <gtest/gtest.h>

namespace apo::cgal_adapter {
namespace {

const test::ScannedShape kSphere = test::scannedSphere(60);  // about 28K points
const test::ScannedShape kTorus = test::scannedTorus(80);

class ScaleSpaceOnScans : public ::testing::TestWithParam<test::ScannedShape> {};

TEST_P(ScaleSpaceOnScans, IsAccurateManifoldAndOnTheOriginalPoints) {
  const test::ScannedShape& shape = GetParam();
  const PointSet points = test::scannedPoints(shape.truth(), 10, shape.raysPerSide);
  ASSERT_GT(points.size(), 20000u);
  auto mesh = scaleSpaceReconstruct(points.positions, averageSpacing(points.positions, 6).value(), 4.0);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  ASSERT_EQ(mesh->points.positions, points.positions);  // unsmoothed, input order
  test::expectAccurateManifoldMesh(*mesh, points, shape);
}

INSTANTIATE_TEST_SUITE_P(Shapes, ScaleSpaceOnScans, ::testing::Values(kSphere, kTorus),
                         [](const auto& info) { return std::string(info.param.name); });

// Compared up to a few triangles: the advancing-front mesher breaks ties by
// comparing addresses (see cgal_advancing_front_test.cpp).
TEST(ScaleSpaceReconstruct, DefaultScaleIsFourSpacings) {
  const PointSet points = test::scannedPoints(test::torusTruth(), 6, 48);
  const double spacing = averageSpacing(points.positions, 6).value();
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
}  // namespace apo::cgal_adapter
