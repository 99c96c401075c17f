#include "core/geometry.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

namespace apo {
namespace {

TEST(BoundingBox, SpansAllPoints) {
  const Aabb box = boundingBox({{1, 2, 3}, {-1, 5, 0}, {0, 0, 4}});
  EXPECT_EQ(box.min, Vec3f(-1, 0, 0));
  EXPECT_EQ(box.max, Vec3f(1, 5, 4));
  EXPECT_FLOAT_EQ(box.diagonal(), std::sqrt(4.0f + 25.0f + 16.0f));
}

TEST(BoundingBox, EmptyHasZeroDiagonal) {
  const Aabb box = boundingBox({});
  EXPECT_TRUE(box.empty());
  EXPECT_EQ(box.diagonal(), 0.0f);
}

TEST(Scan, IsAMeshOnlyWithTriangles) {
  Scan scan;
  scan.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_FALSE(scan.isMesh());
  scan.triangles.push_back({0, 1, 2});
  EXPECT_TRUE(scan.isMesh());
}

Vec3f centreOf(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
}

TEST(FaceOrderSpread, NeighboursInTheListAreAboutAnEdgeApartShuffledOnesFarApart) {
  Scan grid = test::makeSquareGrid(40);  // 3,200 triangles, row by row: every consecutive pair is measured
  // Brute force: the median over all consecutive pairs, over the mean edge
  // of the pairs' first triangles (each 1, 1 and sqrt 2 squares' sides of 1/40).
  const auto bruteForce = [](const Scan& mesh) {
    std::vector<double> steps;
    for (std::size_t i = 0; i + 1 < mesh.triangles.size(); ++i)
      steps.push_back((centreOf(mesh, mesh.triangles[i + 1]) - centreOf(mesh, mesh.triangles[i])).cast<double>().norm());
    std::sort(steps.begin(), steps.end());
    return steps[steps.size() / 2] / ((2.0 + std::sqrt(2.0)) / 3.0 / 40.0);
  };
  EXPECT_NEAR(faceOrderSpread(grid), bruteForce(grid), 1e-6);
  EXPECT_LT(faceOrderSpread(grid), 1.0);
  std::shuffle(grid.triangles.begin(), grid.triangles.end(), std::mt19937(3));
  EXPECT_NEAR(faceOrderSpread(grid), bruteForce(grid), 1e-6);
  EXPECT_GT(faceOrderSpread(grid), 10.0) << "a random pair of a 40 x 40 grid lies about 20 squares apart";
  Scan one = test::makeSquareGrid(1);
  one.triangles.pop_back();
  EXPECT_EQ(faceOrderSpread(one), 0.0);
}

// The Morton code of a point's cell in a 1024-cell grid over the unit
// square (z = 0), bit by bit (x's bit above y's above z's).
std::uint64_t mortonByBits(const Vec3f& p) {
  const auto cell = [&](float x) { return static_cast<std::uint32_t>(std::min(x * 1024.0f, 1023.0f)); };
  const std::array<std::uint32_t, 3> c = {cell(p.x()), cell(p.y()), 0u};
  std::uint64_t code = 0;
  for (int bit = 9; bit >= 0; --bit)
    for (int axis = 0; axis < 3; ++axis) code = code << 1 | ((c[axis] >> bit) & 1u);
  return code;
}

TEST(TrianglesInMortonOrder, APermutationSortedByTheCentresCodesTiesInTheListsOrder) {
  Scan grid = test::makeSquareGrid(40);
  std::shuffle(grid.triangles.begin(), grid.triangles.end(), std::mt19937(5));
  // Two triangles with the same centre, in this order: they must stay so.
  grid.triangles.push_back({0, 1, 42});
  grid.triangles.push_back({42, 0, 1});
  const std::vector<Triangle> sorted = trianglesInMortonOrder(grid);
  std::vector<Triangle> given = grid.triangles, got = sorted;
  std::sort(given.begin(), given.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, given) << "every triangle once";
  for (std::size_t i = 0; i + 1 < sorted.size(); ++i)
    ASSERT_LE(mortonByBits(centreOf(grid, sorted[i])), mortonByBits(centreOf(grid, sorted[i + 1]))) << i;
  const auto first = std::find(sorted.begin(), sorted.end(), Triangle{0, 1, 42});
  const auto second = std::find(sorted.begin(), sorted.end(), Triangle{42, 0, 1});
  EXPECT_LT(first, second);
  EXPECT_LT(faceOrderSpread(Scan{grid.points, sorted}), 2.0);
}

TEST(AreaWeightedVertexNormals, OctahedronVerticesPointOutwards) {
  Scan octahedron;
  octahedron.points.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  octahedron.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  const auto normals = areaWeightedVertexNormals(octahedron);
  for (std::size_t i = 0; i < normals.size(); ++i)
    EXPECT_NEAR((normals[i] - octahedron.points.positions[i]).norm(), 0.0f, 1e-6f) << i;
  // Eight equilateral faces of side sqrt(2).
  EXPECT_NEAR(surfaceArea(octahedron), 8 * std::sqrt(3.0) / 4 * 2, 1e-6);
}

TEST(AddVertexNormalsIfMissing, MeshWithoutOnePerVertexGetsAreaWeightedNormalsOthersKeepTheirs) {
  Scan octahedron;
  octahedron.points.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  octahedron.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (const std::size_t given : {std::size_t{0}, std::size_t{2}}) {  // none, or too few
    Scan mesh = octahedron;
    mesh.points.normals.assign(given, Vec3f::UnitX());
    addVertexNormalsIfMissing(mesh);
    ASSERT_EQ(mesh.points.normals.size(), 6u) << given;
    for (std::size_t i = 0; i < 6; ++i)  // a regular octahedron's vertex normals point along its vertices
      EXPECT_NEAR((mesh.points.normals[i] - mesh.points.positions[i]).norm(), 0.0f, 1e-6f) << given << " " << i;
  }
  Scan own = octahedron;
  own.points.normals.assign(6, Vec3f::UnitX());
  addVertexNormalsIfMissing(own);
  EXPECT_EQ(own.points.normals, std::vector<Vec3f>(6, Vec3f::UnitX())) << "a mesh's own normals are kept";
  Scan points = octahedron;
  points.triangles.clear();
  addVertexNormalsIfMissing(points);
  EXPECT_TRUE(points.points.normals.empty()) << "points get no normals from faces they do not have";
}

// Two triangles sharing a vertex (one piece), a separate triangle (another),
// and a vertex in no triangle.
TEST(MeshPieces, TrianglesSharingAVertexAreOnePiece) {
  Scan mesh;
  mesh.points.positions.assign(8, Vec3f::Zero());
  mesh.triangles = {{5, 6, 7}, {0, 1, 2}, {2, 3, 4}};
  const MeshPieces pieces = meshPieces(mesh);
  EXPECT_EQ(pieces.count, 2u);
  EXPECT_EQ(pieces.ofTriangle, (std::vector<std::uint32_t>{0, 1, 1}));  // in the order of first triangles
  EXPECT_EQ(pieces.ofVertex, (std::vector<std::uint32_t>{1, 1, 1, 1, 1, 0, 0, 0}));
  mesh.points.positions.emplace_back(Vec3f::Zero());
  EXPECT_EQ(meshPieces(mesh).ofVertex.back(), MeshPieces::kNoPiece);
}

// Unit length, spread: every direction of a dense check set has a lattice
// direction within a few degrees, and the mean is near zero.
TEST(FibonacciDirections, UnitAndEvenlySpread) {
  const std::vector<Vec3f> directions = fibonacciDirections(64);
  ASSERT_EQ(directions.size(), 64u);
  Vec3f sum = Vec3f::Zero();
  for (const Vec3f& d : directions) {
    EXPECT_NEAR(d.norm(), 1.0f, 1e-6f);
    sum += d;
  }
  EXPECT_LT(sum.norm() / 64.0f, 0.02f);
  for (const Vec3f& probe : {Vec3f(1, 0, 0), Vec3f(0, -1, 0), Vec3f(0, 0, 1), Vec3f(0.6f, 0.0f, -0.8f)}) {
    float best = -1.0f;
    for (const Vec3f& d : directions) best = std::max(best, d.dot(probe));
    EXPECT_GT(best, std::cos(20.0f * 3.14159265f / 180.0f));  // 64 directions: about 14 degrees apart
  }
  EXPECT_EQ(fibonacciDirections(64), directions);
}

}  // namespace
}  // namespace apo
