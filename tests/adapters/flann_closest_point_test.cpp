#include "adapters/flann/flann_search.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <thread>

namespace apo {
namespace {

Scan withVertexNormals(Scan mesh) {
  mesh.points.normals = areaWeightedVertexNormals(mesh);
  return mesh;
}

double meanEdgeLength(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  double sum = 0.0;
  for (const Triangle& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) sum += (p[t[(i + 1) % 3]] - p[t[i]]).norm();
  return sum / (3.0 * static_cast<double>(mesh.triangles.size()));
}

// Random points of the mesh's surface (a random triangle, random
// barycentrics) moved by up to maxOffset in a random direction.
std::vector<Vec3f> queriesNear(const Scan& mesh, std::size_t count, float maxOffset, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<std::size_t> triangle(0, mesh.triangles.size() - 1);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> gaussian;
  std::vector<Vec3f> queries;
  for (std::size_t i = 0; i < count; ++i) {
    const Triangle& t = mesh.triangles[triangle(random)];
    float u = unit(random), v = unit(random);
    if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
    const auto& p = mesh.points.positions;
    const Vec3f onSurface = (1.0f - u - v) * p[t[0]] + u * p[t[1]] + v * p[t[2]];
    const Vec3f direction = Vec3f(gaussian(random), gaussian(random), gaussian(random)).normalized();
    queries.push_back(onSurface + maxOffset * unit(random) * direction);
  }
  return queries;
}

std::unique_ptr<ClosestPointFinder> flannFinder(const Scan& detail) {
  auto finder = makeFlannClosestPoint(detail);
  if (!finder.ok()) ADD_FAILURE() << finder.error().message;
  return finder.ok() ? std::move(finder).value() : nullptr;
}

// FLANN against all triangles for queries within `offsetInEdges` mean edge
// lengths of the surface: the same distance (1e-5: float against double) and
// the same interpolated normal. Where two triangles tie (on the bisector of a
// concave edge) the answers may be two points at the same distance, whose
// normals differ by up to the offset times the curvature: a looser tolerance
// for those few. Farther away the closest triangle may have no corner among
// the nearest vertices (see IsExactOnlyOnTheTrianglesAroundTheNearestVertices);
// on these even meshes that did not happen up to 10 edge lengths away.
void expectMatchesBruteForce(const Scan& mesh, float offsetInEdges, std::uint32_t seed) {
  const auto finder = flannFinder(mesh);
  ASSERT_TRUE(finder);
  const test::BruteForceClosestPoint bruteForce(mesh);
  const float maxOffset = offsetInEdges * static_cast<float>(meanEdgeLength(mesh));
  int samePoint = 0;
  const std::vector<Vec3f> queries = queriesNear(mesh, 3000, maxOffset, seed);
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const Vec3f& q = queries[i];
    const SurfacePoint found = finder->closest(q).value(), expected = bruteForce.closest(q).value();
    ASSERT_NEAR((found.position - q).norm(), (expected.position - q).norm(), 1e-5f) << "query " << i;
    EXPECT_NEAR(found.normal.norm(), 1.0f, 1e-5f) << "query " << i;
    EXPECT_GT(found.normal.dot(expected.normal), 0.999f) << "query " << i;
    if ((found.position - expected.position).norm() < 1e-5f) {
      ++samePoint;
      EXPECT_GT(found.normal.dot(expected.normal), 1.0f - 1e-5f) << "query " << i;
    }
  }
  EXPECT_GT(samePoint, 2900);  // ties are rare
}

TEST(FlannClosestPoint, MeshMatchesBruteForceNearAnIcosphere) {
  expectMatchesBruteForce(withVertexNormals(test::makeIcosphere(3)), 3.0f, 1);
}

TEST(FlannClosestPoint, MeshMatchesBruteForceNearATorus) {
  // Triangles twice as long around the ring as across it, and a concave inner side.
  expectMatchesBruteForce(withVertexNormals(test::makeTorus(1.0f, 0.35f, 48, 24)), 3.0f, 2);
}

// A 20 x 20 triangle at z = 0 and a dense 1 x 1 grid of small triangles at
// z = 2 above its middle. All normals +z.
Scan bigTriangleUnderADensePatch() {
  Scan mesh;
  auto& p = mesh.points.positions;
  p = {{-10, -10, 0}, {10, -10, 0}, {0, 10, 0}};
  mesh.triangles = {{0, 1, 2}};
  constexpr int kSide = 10;
  for (int i = 0; i <= kSide; ++i)
    for (int j = 0; j <= kSide; ++j) p.emplace_back(-0.5f + 1.0f * i / kSide, -0.5f + 1.0f * j / kSide, 2.0f);
  auto vertex = [](int i, int j) { return static_cast<std::uint32_t>(3 + i * (kSide + 1) + j); };
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j) {
      mesh.triangles.push_back({vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1)});
      mesh.triangles.push_back({vertex(i, j), vertex(i + 1, j + 1), vertex(i, j + 1)});
    }
  mesh.points.normals.assign(p.size(), Vec3f::UnitZ());
  return mesh;
}

// The search is exact only on the triangles around the nearest vertices: a
// query over the middle of a big triangle whose corners are all farther than
// another patch's vertices gets a point of that patch. The answer is always a
// point of the mesh, so it is never nearer than the truth.
TEST(FlannClosestPoint, IsExactOnlyOnTheTrianglesAroundTheNearestVertices) {
  const Scan mesh = bigTriangleUnderADensePatch();
  const auto finder = flannFinder(mesh);
  ASSERT_TRUE(finder);
  const test::BruteForceClosestPoint bruteForce(mesh);
  const Vec3f overTheBigTriangle(3.0f, 0.0f, 0.1f);
  EXPECT_NEAR((bruteForce.closest(overTheBigTriangle).value().position - overTheBigTriangle).norm(), 0.1f, 1e-6f);
  EXPECT_FLOAT_EQ(finder->closest(overTheBigTriangle).value().position.z(), 2.0f);  // on the patch, 3.1 away
  for (const Vec3f& unitQuery : test::randomCubePoints(1000, 3)) {
    const Vec3f q = 5.0f * unitQuery;
    const float found = (finder->closest(q).value().position - q).norm(), truth = (bruteForce.closest(q).value().position - q).norm();
    EXPECT_GE(found, truth - 1e-5f);
  }
}

TEST(FlannClosestPoint, ProjectsOntoATriangleAndInterpolatesItsNormals) {
  Scan triangle;
  triangle.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.points.normals = {Vec3f::UnitZ(), Vec3f::UnitX(), Vec3f::UnitY()};
  triangle.triangles = {{0, 1, 2}};
  const auto finder = flannFinder(triangle);
  ASSERT_TRUE(finder);
  const SurfacePoint inside = finder->closest(Vec3f(0.25f, 0.5f, 2.0f)).value();
  EXPECT_TRUE(inside.position.isApprox(Vec3f(0.25f, 0.5f, 0.0f)));
  EXPECT_TRUE(inside.normal.isApprox(Vec3f(0.25f, 0.5f, 0.25f).normalized()));
  const SurfacePoint corner = finder->closest(Vec3f(2.0f, -1.0f, 1.0f)).value();  // beyond vertex 1
  EXPECT_TRUE(corner.position.isApprox(Vec3f(1, 0, 0)));
  EXPECT_TRUE(corner.normal.isApprox(Vec3f::UnitX()));
  const SurfacePoint edge = finder->closest(Vec3f(0.5f, -1.0f, 0.0f)).value();  // beside edge 0-1
  EXPECT_TRUE(edge.position.isApprox(Vec3f(0.5f, 0, 0)));
  EXPECT_TRUE(edge.normal.isApprox(Vec3f(1, 0, 1).normalized()));
}

// On a closed mesh a wrong vertex or edge case can hide behind a neighbour
// that gets the same point right; a lone triangle exposes every region.
TEST(FlannClosestPoint, LoneTriangleMatchesBruteForceInEveryRegion) {
  Scan triangle;
  triangle.points.positions = {{0.1f, -0.3f, 0.2f}, {0.9f, 0.1f, -0.1f}, {-0.2f, 0.7f, 0.3f}};
  triangle.points.normals = {Vec3f(0, 0, 1), Vec3f(0.6f, 0, 0.8f), Vec3f(0, -0.6f, 0.8f)};
  triangle.triangles = {{0, 1, 2}};
  const auto finder = flannFinder(triangle);
  ASSERT_TRUE(finder);
  const test::BruteForceClosestPoint bruteForce(triangle);
  for (const Vec3f& unitQuery : test::randomCubePoints(3000, 10)) {
    const Vec3f q = 2.0f * unitQuery;
    const SurfacePoint found = finder->closest(q).value(), expected = bruteForce.closest(q).value();
    ASSERT_TRUE(found.position.isApprox(expected.position, 1e-5f)) << q.transpose();
    ASSERT_GT(found.normal.dot(expected.normal), 1.0f - 1e-5f) << q.transpose();
  }
}

TEST(FlannClosestPoint, OppositeVertexNormalsFallBackToTheFaceNormal) {
  Scan triangle;
  triangle.points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.points.normals = {Vec3f::UnitZ(), -Vec3f::UnitZ(), Vec3f::UnitZ()};
  triangle.triangles = {{0, 1, 2}};
  const auto finder = flannFinder(triangle);
  ASSERT_TRUE(finder);
  const SurfacePoint midEdge = finder->closest(Vec3f(0.5f, -1.0f, 0.0f)).value();
  EXPECT_TRUE(midEdge.normal.isApprox(Vec3f::UnitZ()));
}

TEST(FlannClosestPoint, DegenerateTrianglesAreTheirEdges) {
  Scan mesh;
  mesh.points.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {3, 3, 3}};
  mesh.points.normals.assign(5, Vec3f::UnitZ());
  mesh.triangles = {{0, 1, 2}, {3, 3, 4}, {0, 1, 3}};  // collinear; a repeated corner; a proper one
  const auto finder = flannFinder(mesh);
  ASSERT_TRUE(finder);
  const test::BruteForceClosestPoint bruteForce(mesh);
  for (const Vec3f& unitQuery : test::randomCubePoints(500, 4)) {
    const Vec3f q = 2.0f * unitQuery + Vec3f(1, 1, 1);
    const SurfacePoint found = finder->closest(q).value();
    ASSERT_TRUE(found.position.allFinite() && found.normal.allFinite());
    EXPECT_NEAR((found.position - q).norm(), (bruteForce.closest(q).value().position - q).norm(), 1e-5f);
  }
}

TEST(FlannClosestPoint, PointsGiveExactlyTheNearestPoint) {
  Scan cloud;
  cloud.points.positions = test::randomCubePoints(2000, 5);
  for (const Vec3f& p : test::randomCubePoints(2000, 6)) cloud.points.normals.push_back(p.normalized());
  const auto finder = flannFinder(cloud);
  ASSERT_TRUE(finder);
  const test::BruteForceClosestPoint bruteForce(cloud);
  for (const Vec3f& unitQuery : test::randomCubePoints(3000, 7)) {
    const Vec3f q = 1.2f * unitQuery;
    const SurfacePoint found = finder->closest(q).value(), expected = bruteForce.closest(q).value();
    ASSERT_EQ(found.position, expected.position);
    ASSERT_EQ(found.normal, expected.normal);
  }
}

TEST(FlannClosestPoint, ConcurrentQueriesMatchSequentialOnes) {
  const Scan sphere = withVertexNormals(test::makeIcosphere(3));
  const auto finder = flannFinder(sphere);
  ASSERT_TRUE(finder);
  const std::vector<Vec3f> queries = queriesNear(sphere, 5000, 0.3f, 8);
  std::vector<SurfacePoint> sequential;
  for (const Vec3f& q : queries) sequential.push_back(finder->closest(q).value());
  std::vector<std::vector<SurfacePoint>> perThread(3);
  std::vector<std::thread> threads;
  for (auto& answers : perThread)
    threads.emplace_back([&] {
      for (const Vec3f& q : queries) answers.push_back(finder->closest(q).value());
    });
  for (auto& thread : threads) thread.join();
  for (const auto& answers : perThread)
    for (std::size_t i = 0; i < queries.size(); ++i) {
      ASSERT_EQ(answers[i].position, sequential[i].position) << "query " << i;
      ASSERT_EQ(answers[i].normal, sequential[i].normal) << "query " << i;
    }
}

TEST(FlannClosestPoint, BuiltOnDemandFromManyThreadsItAnswersLikeTheEagerOne) {
  const Scan sphere = withVertexNormals(test::makeIcosphere(3));
  const auto eager = flannFinder(sphere);
  auto onDemand = makeFlannClosestPointOnDemand(sphere);
  ASSERT_TRUE(eager && onDemand.ok());
  const std::vector<Vec3f> queries = queriesNear(sphere, 2000, 0.3f, 9);
  // The first queries race to build the tree.
  std::vector<std::vector<SurfacePoint>> perThread(3);
  std::vector<std::thread> threads;
  for (auto& answers : perThread)
    threads.emplace_back([&] {
      for (const Vec3f& q : queries) answers.push_back((*onDemand)->closest(q).value());
    });
  for (auto& thread : threads) thread.join();
  for (const auto& answers : perThread)
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const SurfacePoint expected = eager->closest(queries[i]).value();
      ASSERT_EQ(answers[i].position, expected.position) << "query " << i;
      ASSERT_EQ(answers[i].normal, expected.normal) << "query " << i;
    }
}

TEST(FlannClosestPoint, RefusesAnEmptyDetailAndMissingNormals) {
  auto refusal = [](const Scan& detail) {
    auto finder = makeFlannClosestPoint(detail);
    if (finder.ok()) return std::string("accepted");
    EXPECT_EQ(finder.error().kind, ErrorKind::BadInput);
    return finder.error().message;
  };
  EXPECT_NE(refusal(Scan{}).find("empty"), std::string::npos);
  Scan mesh = test::makeIcosphere(1);
  EXPECT_NE(refusal(mesh).find("normal"), std::string::npos);
  Scan cloud;
  cloud.points.positions = test::randomCubePoints(10, 9);
  EXPECT_NE(refusal(cloud).find("normal"), std::string::npos);
  mesh = withVertexNormals(mesh);
  mesh.triangles.push_back({0, 1, static_cast<std::uint32_t>(mesh.points.size())});
  EXPECT_NE(refusal(mesh).find("triangle"), std::string::npos);
}

// ---- Disc radii ----------------------------------------------------------------

// Mean distance to the k nearest other points, by sorting all distances.
float bruteForceSpacing(const std::vector<Vec3f>& points, std::size_t i, std::size_t k) {
  std::vector<double> distances;
  for (std::size_t j = 0; j < points.size(); ++j)
    if (j != i) distances.push_back((points[j] - points[i]).cast<double>().norm());
  std::partial_sort(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(k), distances.end());
  double sum = 0.0;
  for (std::size_t j = 0; j < k; ++j) sum += distances[j];
  return static_cast<float>(sum / static_cast<double>(k));
}

// The radius is 1.0 x the mean 6-NN distance (the factor's reasoning is in
// adapters/flann/flann_search.cpp).
constexpr float kFactor = 1.0f;

TEST(DiscRadii, FollowTheSpacingOfAFibonacciSphere) {
  PointSet sphere;
  sphere.positions = test::fibonacciSpherePoints(5000);
  const std::vector<float> radii = discRadii(sphere).value();
  ASSERT_EQ(radii.size(), sphere.size());
  // n points share 4 pi: the spacing is about sqrt(4 pi / n) (1.07 times that
  // for a perfect hexagonal lattice, whose 6 neighbours are all at the spacing).
  const float spacing = std::sqrt(4.0f * std::numbers::pi_v<float> / 5000.0f);
  for (std::size_t i = 0; i < radii.size(); ++i) EXPECT_NEAR(radii[i], kFactor * spacing, 0.2f * spacing) << "point " << i;
}

TEST(DiscRadii, MatchBruteForceAcrossSearchBatches) {
  PointSet sphere;
  sphere.positions = test::fibonacciSpherePoints(70000);  // more than one batch of 65536 queries
  const std::vector<float> radii = discRadii(sphere).value();
  ASSERT_EQ(radii.size(), sphere.size());
  for (std::size_t i = 0; i < sphere.size(); i += 997)
    EXPECT_NEAR(radii[i], kFactor * bruteForceSpacing(sphere.positions, i, 6), 1e-5f * radii[i]) << "point " << i;
  EXPECT_NEAR(radii.back(), kFactor * bruteForceSpacing(sphere.positions, sphere.size() - 1, 6), 1e-5f * radii.back());
}

TEST(DiscRadii, SmallCloudsUseTheNeighboursTheyHave) {
  PointSet triangle;
  triangle.positions = {{0, 0, 0}, {1, 0, 0}, {0.5f, std::sqrt(3.0f) / 2, 0}};  // equilateral, side 1
  for (float r : discRadii(triangle).value()) EXPECT_NEAR(r, kFactor * 1.0f, 1e-6f);
  PointSet pair;
  pair.positions = {{0, 0, 0}, {0, 0, 2}};
  for (float r : discRadii(pair).value()) EXPECT_NEAR(r, kFactor * 2.0f, 1e-6f);
  PointSet single;
  single.positions = {{1, 2, 3}};
  EXPECT_EQ(discRadii(single).value(), std::vector<float>{0.0f});  // no spacing
  EXPECT_TRUE(discRadii(PointSet{}).value().empty());
}

// The bake's points search: the radii and the nearest point from one tree,
// checked against brute force; a single point and missing normals.
TEST(FlannPointsSearch, RadiiAndNearestPointMatchBruteForce) {
  Scan cloud;
  cloud.points.positions = test::randomCubePoints(3000, 8);
  for (const Vec3f& p : test::randomCubePoints(3000, 9)) cloud.points.normals.push_back(p.normalized());
  const auto search = makeFlannPointsSearch(cloud.points);
  ASSERT_TRUE(search.ok()) << search.error().message;
  ASSERT_EQ(search->radii.size(), cloud.points.size());
  for (std::size_t i = 0; i < cloud.points.size(); i += 37)
    EXPECT_NEAR(search->radii[i], kFactor * bruteForceSpacing(cloud.points.positions, i, 6), 1e-5f * search->radii[i]);
  const test::BruteForceClosestPoint bruteForce(cloud);
  for (const Vec3f& unitQuery : test::randomCubePoints(500, 10)) {
    const Vec3f q = 1.2f * unitQuery;
    ASSERT_EQ(search->closest->closest(q).value().position, bruteForce.closest(q).value().position);
  }
  Scan single;
  single.points.positions = {{1, 2, 3}};
  single.points.normals = {{0, 0, 1}};
  const auto one = makeFlannPointsSearch(single.points);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->radii, std::vector<float>{0.0f});
  EXPECT_EQ(one->closest->closest({0, 0, 0}).value().position, Vec3f(1, 2, 3));
  single.points.normals.clear();
  EXPECT_FALSE(makeFlannPointsSearch(single.points).ok());
}

}  // namespace
}  // namespace apo
