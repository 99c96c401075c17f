// Advancing front on noisy virtual scans of a sphere and a torus with
// analytic surfaces: accuracy, topology of the main component, consistent
// orientation.
#include "adapters/cgal/cgal_jobs.h"

#include "tests/reconstruct/mesh_checks.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

namespace apo::cgal_adapter {
namespace {

const test::ScannedShape kSphere = test::scannedSphere(60);  // about 28K points
const test::ScannedShape kTorus = test::scannedTorus(80);

class AdvancingFrontOnScans : public ::testing::TestWithParam<test::ScannedShape> {};

TEST_P(AdvancingFrontOnScans, IsAccurateManifoldAndConsistentlyOriented) {
  const test::ScannedShape& shape = GetParam();
  const PointSet points = test::scannedPoints(shape.truth(), 10, shape.raysPerSide);
  ASSERT_GT(points.size(), 20000u);
  auto mesh = advancingFrontReconstruct(points.positions);
  ASSERT_TRUE(mesh.ok()) << mesh.error().message;
  ASSERT_EQ(mesh->points.positions, points.positions);  // vertices are the input points
  test::expectAccurateManifoldMesh(*mesh, points, shape);
}

INSTANTIATE_TEST_SUITE_P(Shapes, AdvancingFrontOnScans, ::testing::Values(kSphere, kTorus),
                         [](const auto& info) { return std::string(info.param.name); });

// Exactly, whatever malloc's heap holds: CGAL breaks ties between candidate
// edges by their records' addresses. A grid of quantised heights (as lidar
// and range scans store them) ties often: without the deterministic heap,
// the two calls below differ (measured: same count, other triangles).
TEST(AdvancingFrontReconstruct, RepeatsExactlyWhateverTheHeapHolds) {
  std::vector<Vec3f> terrain;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) terrain.emplace_back(0.01f * i, 0.01f * j, 0.002f * static_cast<float>((i * 31 + j * 17) % 5));
  auto first = advancingFrontReconstruct(terrain);
  // malloc's heap fragmented between the two: blocks of many sizes, every
  // other one freed.
  std::vector<std::unique_ptr<char[]>> kept;
  for (int i = 0; i < 50000; ++i) {
    auto block = std::make_unique<char[]>(16 + (i * 7919) % 300);
    if (i % 2 == 0) kept.push_back(std::move(block));
  }
  auto second = advancingFrontReconstruct(terrain);
  ASSERT_TRUE(first.ok() && second.ok());
  EXPECT_EQ(first->triangles, second->triangles);
}

TEST(AdvancingFrontReconstruct, TriangulatesAFlatPatch) {
  std::vector<Vec3f> flat;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) flat.emplace_back(0.1f * i, 0.1f * j + 0.01f * i, 0.0f);
  auto patch = advancingFrontReconstruct(flat);
  ASSERT_TRUE(patch.ok()) << patch.error().message;
  EXPECT_EQ(patch->triangles.size(), 2u * 19 * 19);
  const test::Topology topology = test::topologyOf(*patch);
  EXPECT_EQ(topology.components, 1u);
  EXPECT_EQ(topology.inconsistentEdges, 0u);
  EXPECT_EQ(topology.euler(), 1);  // a disc
}

TEST(AdvancingFrontReconstruct, RefusesTooFewPoints) {
  auto few = advancingFrontReconstruct({Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)});
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().kind, ErrorKind::BadInput);
}

}  // namespace
}  // namespace apo::cgal_adapter
