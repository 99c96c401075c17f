#include "ingest/cleaning.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

namespace apo::cleaning {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

TEST(DropNonFinitePoints, RemovesPointsAndTheirTriangles) {
  Scan mesh = test::squareOfTwoTriangles();
  mesh.points.positions[3] = {kNan, 0, 0};
  EXPECT_EQ(dropNonFinitePoints(mesh), 1u);
  EXPECT_EQ(mesh.points.size(), 3u);
  EXPECT_EQ(mesh.points.intensities, (std::vector<float>{0, 1, 2}));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], (Triangle{0, 1, 2}));
}

TEST(DropNonFinitePoints, CountsInfinityToo) {
  Scan cloud;
  cloud.points.positions = {{1, 2, 3}, {std::numeric_limits<float>::infinity(), 0, 0}, {0, -std::numeric_limits<float>::infinity(), 0}};
  EXPECT_EQ(dropNonFinitePoints(cloud), 2u);
  EXPECT_EQ(cloud.points.positions[0], Vec3f(1, 2, 3));
}

TEST(MergeDuplicatePoints, KeepsFirstAndRepointsTriangles) {
  // An STL-like soup: the square's two triangles with unshared corners.
  Scan soup;
  soup.points.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  soup.points.intensities = {10, 11, 12, 13, 14, 15};
  soup.triangles = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_EQ(mergeDuplicatePoints(soup), 2u);
  EXPECT_EQ(soup.points.size(), 4u);
  EXPECT_EQ(soup.points.intensities, (std::vector<float>{10, 11, 12, 15}));
  EXPECT_EQ(soup.triangles[0], (Triangle{0, 1, 2}));
  EXPECT_EQ(soup.triangles[1], (Triangle{0, 2, 3}));
}

TEST(MergeDuplicatePoints, MatchesBruteForceOnRandomGrid) {
  Scan cloud;
  std::map<std::tuple<float, float, float>, int> distinct;
  for (int i = 0; i < 3000; ++i) {
    const Vec3f p(static_cast<float>((i * 7) % 11), static_cast<float>((i * 13) % 5), static_cast<float>((i * 3) % 7));
    cloud.points.positions.push_back(p);
    distinct[{p.x(), p.y(), p.z()}]++;
  }
  const std::size_t removed = mergeDuplicatePoints(cloud);
  EXPECT_EQ(cloud.points.size(), distinct.size());
  EXPECT_EQ(removed, 3000u - distinct.size());
}

TEST(DropDuplicateTriangles, SameVerticesInAnyOrder) {
  Scan mesh = test::squareOfTwoTriangles();
  mesh.triangles.push_back({2, 0, 1});
  mesh.triangles.push_back({0, 3, 2});  // opposite winding of {0,2,3}
  EXPECT_EQ(dropDuplicateTriangles(mesh), 2u);
  EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}}));
}

TEST(DropDuplicateTriangles, KeepsTheFirstOfEachSetLikeBruteForce) {
  // Corners drawn from 6 vertices: many triangles repeat, in any order of
  // their corners, some degenerate.
  Scan mesh;
  mesh.points.positions.resize(6, Vec3f::Zero());
  std::mt19937 random(5);
  std::uniform_int_distribution<std::uint32_t> vertex(0, 5);
  for (int i = 0; i < 2000; ++i) mesh.triangles.push_back({vertex(random), vertex(random), vertex(random)});
  std::set<Triangle> seen;
  std::vector<Triangle> expected;
  for (const Triangle& t : mesh.triangles) {
    Triangle key = t;
    std::sort(key.begin(), key.end());
    if (seen.insert(key).second) expected.push_back(t);
  }
  EXPECT_EQ(dropDuplicateTriangles(mesh), 2000u - expected.size());
  EXPECT_EQ(mesh.triangles, expected);
  EXPECT_LT(expected.size(), 100u);  // the input did repeat
}

TEST(NormaliseNormals, CountsZeroAndNanNormals) {
  PointSet points;
  points.positions.resize(3, Vec3f::Zero());
  points.normals = {{0, 0, 2}, {0, 0, 0}, {kNan, 0, 0}};
  EXPECT_EQ(normaliseNormals(points), 2u);
  EXPECT_EQ(points.normals[0], Vec3f(0, 0, 1));
}

TEST(VoxelRepresentativeMask, OnePointPerOccupiedVoxelClosestToItsCentroid) {
  std::vector<Vec3f> points;
  for (int i = 0; i < 500; ++i)
    points.emplace_back(std::fmod(i * 0.137f, 3.0f), std::fmod(i * 0.291f, 2.0f), std::fmod(i * 0.053f, 1.0f));
  const double voxel = 0.5;
  const auto keep = voxelRepresentativeMask(points, voxel);

  // Brute force: group by voxel, find the point closest to each centroid.
  const Aabb box = boundingBox(points);
  std::map<std::array<long, 3>, std::vector<std::size_t>> voxels;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d c = ((points[i] - box.min).cast<double>() / voxel).array().floor();
    voxels[{static_cast<long>(c.x()), static_cast<long>(c.y()), static_cast<long>(c.z())}].push_back(i);
  }
  std::size_t keptCount = 0;
  for (char k : keep) keptCount += k ? 1 : 0;
  EXPECT_EQ(keptCount, voxels.size());
  for (const auto& [key, members] : voxels) {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (auto i : members) centroid += points[i].cast<double>();
    centroid /= static_cast<double>(members.size());
    std::size_t best = members[0];
    for (auto i : members)
      if ((points[i].cast<double>() - centroid).squaredNorm() < (points[best].cast<double>() - centroid).squaredNorm()) best = i;
    EXPECT_TRUE(keep[best]) << "voxel representative " << best;
  }
}

}  // namespace
}  // namespace apo::cleaning
