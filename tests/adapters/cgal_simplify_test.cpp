#include "adapters/cgal/cgal_jobs.h"

#include "reconstruct/reconstruct.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>
#include <set>
#include <utility>

namespace apo::cgal_adapter {
namespace {

// Edge length of a 500-face triangulation of the unit sphere with equal
// equilateral triangles (area 4 pi / 500 = sqrt(3)/4 edge^2), and the
// sagitta of a chord of that length, edge^2 / 8 = 0.0073: how far such a mesh
// must stray from the sphere. Edge collapse makes unequal triangles and QEM
// puts vertices slightly outside the sphere (where tangent planes meet), so
// the tests allow a small multiple of it.
const double kEdge500 = std::sqrt(4.0 * std::numbers::pi / 500.0 * 4.0 / std::sqrt(3.0));
const double kSagitta500 = kEdge500 * kEdge500 / 8.0;

Scan simplified(const Scan& mesh, std::uint64_t target, CollapseCost policy) {
  auto result = edgeCollapse(mesh, target, policy);
  EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error().message);
  return result.ok() ? std::move(result->mesh) : Scan{};
}

double triangleArea(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  const Eigen::Vector3d a = p[t[0]].cast<double>(), b = p[t[1]].cast<double>(), c = p[t[2]].cast<double>();
  return 0.5 * (b - a).cross(c - a).norm();
}

void expectNoDegenerateTriangle(const Scan& mesh) {
  for (const Triangle& t : mesh.triangles) {
    EXPECT_TRUE(t[0] != t[1] && t[1] != t[2] && t[2] != t[0]);
    EXPECT_GT(triangleArea(mesh, t), 0.0);
  }
}

// Largest distance to the unit sphere over the vertices and over points
// spread on every triangle (corners, edge midpoints, centroid).
double farthestFromUnitSphere(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  double farthest = 0.0;
  for (const Triangle& t : mesh.triangles) {
    const Eigen::Vector3d a = p[t[0]].cast<double>(), b = p[t[1]].cast<double>(), c = p[t[2]].cast<double>();
    for (const Eigen::Vector3d& q : {a, b, c, Eigen::Vector3d((a + b) / 2), Eigen::Vector3d((b + c) / 2),
                                     Eigen::Vector3d((c + a) / 2), Eigen::Vector3d((a + b + c) / 3)})
      farthest = std::max(farthest, std::abs(q.norm() - 1.0));
  }
  return farthest;
}

bool byteIdentical(const Scan& a, const Scan& b) {
  return a.points.size() == b.points.size() && a.triangles.size() == b.triangles.size() &&
         std::memcmp(a.points.positions.data(), b.points.positions.data(), a.points.size() * sizeof(Vec3f)) == 0 &&
         std::memcmp(a.triangles.data(), b.triangles.data(), a.triangles.size() * sizeof(Triangle)) == 0;
}

using PositionKey = std::array<float, 3>;
PositionKey key(const Vec3f& p) { return {p.x(), p.y(), p.z()}; }

// Border edges (one incident triangle) as pairs of positions, so that meshes
// with different vertex numbering can be compared.
std::set<std::pair<PositionKey, PositionKey>> borderEdges(const Scan& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const Triangle& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) ++uses[std::minmax(t[c], t[(c + 1) % 3])];
  std::set<std::pair<PositionKey, PositionKey>> border;
  for (const auto& [edge, count] : uses)
    if (count == 1)
      border.insert(std::minmax(key(mesh.points.positions[edge.first]), key(mesh.points.positions[edge.second])));
  return border;
}

void expectClosedSphereTopology(const Scan& mesh) {
  const MeshQuality quality = measureMesh(mesh);
  EXPECT_EQ(quality.boundaryLoops, 0u);
  EXPECT_EQ(quality.nonManifoldEdges, 0u);
  EXPECT_EQ(quality.nonManifoldVertices, 0u);
  EXPECT_EQ(quality.components, 1u);
  EXPECT_EQ(quality.eulerCharacteristic, 2);
}

class SimplifyIcosphere : public ::testing::TestWithParam<CollapseCost> {};

TEST_P(SimplifyIcosphere, ReachesTheTargetCloseToTheSphere) {
  const Scan dense = test::makeIcosphere(6);
  ASSERT_EQ(dense.triangles.size(), 81920u);
  const Scan coarse = simplified(dense, 500, GetParam());
  EXPECT_LE(coarse.triangles.size(), 500u);
  EXPECT_GE(coarse.triangles.size(), 495u);
  expectNoDegenerateTriangle(coarse);
  expectClosedSphereTopology(coarse);
  // Measured: 1.65 sagittas (Garland-Heckbert), 1.9 (Lindstrom-Turk).
  EXPECT_LT(farthestFromUnitSphere(coarse), 3.0 * kSagitta500);
}

TEST_P(SimplifyIcosphere, RepeatsByteForByte) {
  const Scan dense = test::makeIcosphere(5);
  const Scan first = simplified(dense, 500, GetParam());
  const Scan second = simplified(dense, 500, GetParam());
  ASSERT_FALSE(first.triangles.empty());
  EXPECT_TRUE(byteIdentical(first, second));
}

TEST_P(SimplifyIcosphere, KeepsTheBorderOfAnOpenHemisphere) {
  const Scan sphere = test::makeIcosphere(4);
  Scan hemisphere;
  hemisphere.points = sphere.points;
  for (const Triangle& t : sphere.triangles) {
    const auto& p = sphere.points.positions;
    if ((p[t[0]] + p[t[1]] + p[t[2]]).z() > 0.0f) hemisphere.triangles.push_back(t);
  }
  const Scan coarse = simplified(hemisphere, 300, GetParam());
  EXPECT_LE(coarse.triangles.size(), 300u);
  EXPECT_GE(coarse.triangles.size(), 297u);
  expectNoDegenerateTriangle(coarse);
  EXPECT_EQ(measureMesh(coarse).boundaryLoops, 1u);
  const auto border = borderEdges(hemisphere);
  EXPECT_GT(border.size(), 50u);
  EXPECT_EQ(borderEdges(coarse), border);
}

INSTANTIATE_TEST_SUITE_P(Policies, SimplifyIcosphere,
                         ::testing::Values(CollapseCost::GarlandHeckbert, CollapseCost::LindstromTurk),
                         [](const auto& info) { return info.param == CollapseCost::GarlandHeckbert ? "GarlandHeckbert" : "LindstromTurk"; });

// A finely triangulated plane that is not axis-aligned: with CGAL's own
// Garland-Heckbert placement, rounding noise sends points far along the plane
// and the collapse stalls (7,200 faces stopped at 1,562; CGAL issue 8988).
TEST(EdgeCollapse, SimplifiesATiltedPlaneGridWithGarlandHeckbert) {
  constexpr int n = 60;
  Scan grid;
  const Vec3f u(1.0f, 0.0f, 0.3f), v(0.0f, 0.6f, 0.8f);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) grid.points.positions.push_back((u * i + v * j) / n);
  const auto id = [](int i, int j) { return static_cast<std::uint32_t>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      grid.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      grid.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  const Scan coarse = simplified(grid, 500, CollapseCost::GarlandHeckbert);
  EXPECT_LE(coarse.triangles.size(), 500u);
  EXPECT_GE(coarse.triangles.size(), 495u);
  expectNoDegenerateTriangle(coarse);
  const Eigen::Vector3f normal = u.cross(v).normalized();
  for (const Vec3f& p : coarse.points.positions) EXPECT_NEAR(normal.dot(p), 0.0f, 1e-5f);
}

// Inherited quadrics replace a vertex's own planes: told that each vertex of
// a unit icosphere stands for the tangent planes of a sphere of radius 1.2
// (as many as its own faces), the collapses place their vertices on that
// sphere; without them, on the unit sphere. (Adding instead of replacing
// would land halfway.)
TEST(EdgeCollapse, InheritedQuadricsReplaceTheVerticesOwnPlanes) {
  const Scan dense = test::makeIcosphere(4);
  std::vector<int> facesAround(dense.points.size(), 0);
  for (const Triangle& t : dense.triangles)
    for (std::uint32_t v : t) ++facesAround[v];
  std::vector<Eigen::Matrix4d> inherited;
  for (std::size_t v = 0; v < dense.points.size(); ++v) {
    Eigen::Vector4d plane;
    plane << dense.points.positions[v].cast<double>().normalized(), -1.2;
    inherited.push_back(facesAround[v] * plane * plane.transpose());
  }
  const auto medianRadius = [](const Scan& mesh) {
    std::vector<float> radii;
    for (const Vec3f& p : mesh.points.positions) radii.push_back(p.norm());
    std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
    return radii[radii.size() / 2];
  };
  const Scan inheriting = edgeCollapse(dense, 300, CollapseCost::GarlandHeckbert, {}, inherited).value().mesh;
  EXPECT_NEAR(medianRadius(inheriting), 1.2f, 0.03f);
  const Scan own = edgeCollapse(dense, 300, CollapseCost::GarlandHeckbert).value().mesh;
  EXPECT_NEAR(medianRadius(own), 1.0f, 0.03f);
  EXPECT_FALSE(edgeCollapse(dense, 300, CollapseCost::GarlandHeckbert, {}, {Eigen::Matrix4d::Zero()}).ok());
}

// Two icospheres touching at one shared vertex: orient_polygon_soup splits it.
TEST(EdgeCollapse, SplitsAVertexSharedByTwoSpheres) {
  const Scan sphere = test::makeIcosphere(2);
  Scan pair = sphere;
  const Vec3f touch = sphere.points.positions[0];
  const auto offset = static_cast<std::uint32_t>(sphere.points.size());
  // The mirror image through `touch` meets the first sphere there only.
  for (const Vec3f& p : sphere.points.positions) pair.points.positions.push_back(2.0f * touch - p);
  const auto second = [&](std::uint32_t i) { return i == 0 ? 0u : i + offset; };
  for (const Triangle& t : sphere.triangles) pair.triangles.push_back({second(t[0]), second(t[2]), second(t[1])});
  ASSERT_EQ(measureMesh(pair).nonManifoldVertices, 1u);

  auto result = edgeCollapse(pair, 200, CollapseCost::GarlandHeckbert);
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->repairedVertices, 1u);
  EXPECT_EQ(result->mesh.triangles.size(), 200u);
  expectNoDegenerateTriangle(result->mesh);
  const MeshQuality quality = measureMesh(result->mesh);
  EXPECT_EQ(quality.components, 2u);
  EXPECT_EQ(quality.nonManifoldVertices, 0u);
  EXPECT_EQ(quality.eulerCharacteristic, 4);
}

TEST(EdgeCollapse, RepairsThreeTrianglesOnOneEdge) {
  Scan book;
  book.points.positions = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {-1, 0.5f, 0}, {-1, -0.5f, 0}};
  book.triangles = {{0, 1, 2}, {1, 0, 3}, {1, 0, 4}};
  auto result = edgeCollapse(book, 2, CollapseCost::LindstromTurk);
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_GT(result->repairedVertices, 0u);
  EXPECT_EQ(result->mesh.triangles.size(), 3u);  // all border: nothing may collapse
  EXPECT_EQ(measureMesh(result->mesh).nonManifoldEdges, 0u);
}

// Ingest drops triangles with a repeated index or exactly zero area, but a
// vertex can still sit on another's position; whatever survives the collapse
// is removed afterwards.
TEST(EdgeCollapse, LeavesNoDegenerateTriangle) {
  constexpr int n = 6;
  Scan grid;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) grid.points.positions.emplace_back(float(i), float(j), float((i * j) % 3) * 0.1f);
  const auto id = [](int i, int j) { return static_cast<std::uint32_t>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      grid.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      grid.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  grid.points.positions[id(3, 3)] = grid.points.positions[id(3, 4)];
  for (const std::uint64_t target : {1000u, 40u}) {
    const Scan result = simplified(grid, target, CollapseCost::GarlandHeckbert);
    EXPECT_LE(result.triangles.size(), std::min<std::size_t>(target, grid.triangles.size() - 2));
    expectNoDegenerateTriangle(result);
  }
}

TEST(EdgeCollapse, RefusesBadInput) {
  Scan mesh = test::makeIcosphere(1);
  EXPECT_EQ(edgeCollapse(mesh, 0, CollapseCost::GarlandHeckbert).error().kind, ErrorKind::Usage);
  mesh.triangles.push_back({0, 1, 999});
  EXPECT_EQ(edgeCollapse(mesh, 20, CollapseCost::GarlandHeckbert).error().kind, ErrorKind::BadInput);
  mesh.triangles.pop_back();
  mesh.points.positions[3].x() = std::nanf("");
  EXPECT_EQ(edgeCollapse(mesh, 20, CollapseCost::GarlandHeckbert).error().kind, ErrorKind::BadInput);
  Scan flat;
  flat.points.positions = {{0, 0, 0}, {1, 0, 0}};
  flat.triangles = {{0, 1, 1}};
  EXPECT_EQ(edgeCollapse(flat, 1, CollapseCost::GarlandHeckbert).error().kind, ErrorKind::BadInput);
}

}  // namespace
}  // namespace apo::cgal_adapter
