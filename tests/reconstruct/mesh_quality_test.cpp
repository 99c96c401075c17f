#include "reconstruct/mesh_quality.h"

#include "reconstruct/reconstruct.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace apo {
namespace {

Scan twoIcospheres() {
  Scan pair = test::makeIcosphere(1);
  const Scan other = test::makeIcosphere(1);
  const auto offset = static_cast<std::uint32_t>(pair.points.size());
  for (const Vec3f& p : other.points.positions) pair.points.positions.push_back(p + Vec3f(3, 0, 0));
  for (const Triangle& t : other.triangles) pair.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return pair;
}

TEST(MeasureMesh, Icosahedron) {
  const MeshQuality q = measureMesh(test::makeIcosphere(0));
  EXPECT_EQ(q.vertices, 12u);
  EXPECT_EQ(q.triangles, 20u);
  EXPECT_EQ(q.eulerCharacteristic, 2);  // so E = 30
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.boundaryLoops, 0u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
  // Inscribed in the unit sphere: edge 4 / sqrt(10 + 2 sqrt 5), area 5 sqrt(3) edge^2.
  const double edge = 4.0 / std::sqrt(10.0 + 2.0 * std::sqrt(5.0));
  EXPECT_NEAR(q.area, 5.0 * std::sqrt(3.0) * edge * edge, 1e-5);
  // Vertices (0, +-1, +-phi) / |.|: the box is 2 phi / sqrt(1 + phi^2) on each side.
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  EXPECT_NEAR(q.diagonal, std::sqrt(3.0) * 2.0 * phi / std::sqrt(1.0 + phi * phi), 1e-5);
}

TEST(MeasureMesh, TorusHasEulerCharacteristicZero) {
  const MeshQuality q = measureMesh(test::makeTorus(2.0f, 1.0f, 24, 12));
  EXPECT_EQ(q.eulerCharacteristic, 0);
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.boundaryLoops, 0u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);
}

TEST(MeasureMesh, OpenGridHasOneBoundaryLoop) {
  const MeshQuality q = measureMesh(test::makeSquareGrid(8));
  EXPECT_EQ(q.boundaryLoops, 1u);
  EXPECT_EQ(q.eulerCharacteristic, 1);
  EXPECT_EQ(q.components, 1u);
  EXPECT_NEAR(q.area, 1.0, 1e-6);
}

TEST(MeasureMesh, SeparateSpheresAreTwoComponents) {
  const MeshQuality q = measureMesh(twoIcospheres());
  EXPECT_EQ(q.components, 2u);
  EXPECT_EQ(q.eulerCharacteristic, 4);
  EXPECT_EQ(q.boundaryLoops, 0u);
}

TEST(MeasureMesh, BowTieHasOneNonManifoldVertex) {
  Scan bowTie;
  bowTie.points.positions = {{0, 0, 0}, {1, 1, 0}, {1, -1, 0}, {-1, 1, 0}, {-1, -1, 0}};
  bowTie.triangles = {{0, 2, 1}, {0, 3, 4}};
  const MeshQuality q = measureMesh(bowTie);
  EXPECT_EQ(q.nonManifoldVertices, 1u);
  EXPECT_EQ(q.nonManifoldEdges, 0u);
  EXPECT_EQ(q.boundaryLoops, 2u);  // one around each wing, though they touch
  EXPECT_EQ(q.components, 2u);     // sharing a vertex is not sharing an edge
  EXPECT_EQ(q.eulerCharacteristic, 5 - 6 + 2);
}

TEST(MeasureMesh, ThreeTrianglesOnOneEdgeMakeOneNonManifoldEdge) {
  Scan book;
  book.points.positions = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {-1, 0.5f, 0}, {-1, -0.5f, 0}};
  book.triangles = {{0, 1, 2}, {1, 0, 3}, {1, 0, 4}};
  const MeshQuality q = measureMesh(book);
  EXPECT_EQ(q.nonManifoldEdges, 1u);
  EXPECT_EQ(q.nonManifoldVertices, 0u);  // the pages are joined at both ends of the spine
  EXPECT_EQ(q.components, 1u);
  EXPECT_EQ(q.eulerCharacteristic, 5 - 7 + 3);
}

TEST(MeasureMesh, CountsIsolatedPointsAsVerticesButNotInEuler) {
  Scan mesh = test::makeIcosphere(0);
  mesh.points.positions.emplace_back(5, 5, 5);
  const MeshQuality q = measureMesh(mesh);
  EXPECT_EQ(q.vertices, 13u);
  EXPECT_EQ(q.eulerCharacteristic, 2);
}

TEST(TriangleComponents, NumbersInOrderOfFirstTriangle) {
  const Scan pair = twoIcospheres();  // first sphere's triangles, then the second's
  Scan shuffled = pair;
  shuffled.triangles.clear();
  const std::size_t half = pair.triangles.size() / 2;
  for (std::size_t i = 0; i < half; ++i) {
    shuffled.triangles.push_back(pair.triangles[half + i]);
    shuffled.triangles.push_back(pair.triangles[i]);
  }
  const TriangleComponents components = triangleComponents(shuffled);
  ASSERT_EQ(components.count, 2u);
  for (std::size_t i = 0; i < components.ofTriangle.size(); ++i) EXPECT_EQ(components.ofTriangle[i], i % 2) << i;
}

TEST(SampleSurface, SpreadsExactlyCountPointsByArea) {
  Scan mesh;
  // Two triangles in z = 0 with areas 1/2 and 3/2.
  mesh.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {10, 0, 0}, {13, 0, 0}, {10, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  const auto samples = sampleSurface(mesh, 1000);
  ASSERT_EQ(samples.size(), 1000u);
  const auto onFirst = std::count_if(samples.begin(), samples.end(), [](const Vec3f& p) { return p.x() < 5; });
  EXPECT_EQ(onFirst, 250);
  // Every sample lies in its triangle (up to float rounding).
  constexpr float kSlack = 1e-5f;
  for (const Vec3f& p : samples) {
    EXPECT_EQ(p.z(), 0.0f);
    if (p.x() < 5)
      EXPECT_TRUE(p.x() >= -kSlack && p.y() >= -kSlack && p.x() + p.y() <= 1 + kSlack) << p.transpose();
    else
      EXPECT_TRUE(p.x() >= 10 - kSlack && p.y() >= -kSlack && (p.x() - 10) / 3 + p.y() <= 1 + kSlack) << p.transpose();
  }
}

TEST(SampleSurface, IsDeterministicAndUniformOnTheSphere) {
  const Scan sphere = test::makeIcosphere(3);
  const auto first = sampleSurface(sphere, 20000);
  EXPECT_EQ(first, sampleSurface(sphere, 20000));
  // Uniform on a sphere-like surface: the mean is near the centre.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vec3f& p : first) mean += p.cast<double>();
  EXPECT_LT((mean / static_cast<double>(first.size())).norm(), 0.01);
}

}  // namespace
}  // namespace apo
