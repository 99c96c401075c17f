#include "ingest/ingest.h"

#include "core/file_io.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <array>
#include <random>
#include <string>
#include <string_view>
#include <utility>
#include <vector>


namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string sphereXyz(std::size_t count) {
  std::string text = "# points on the unit sphere\n";
  for (const Vec3f& p : test::fibonacciSpherePoints(count)) text += fmt::format("{} {} {}\n", p.x(), p.y(), p.z());
  return text;
}

std::size_t removedBy(const IngestReport& report, const std::string& step) {
  for (const auto& s : report.steps)
    if (s.name == step) return s.removed;
  return ~std::size_t{0};
}

TEST(IngestScan, PointCloudIsCleanedAndGetsOutwardNormals) {
  const fs::path path = test::freshTempDir() / "sphere.xyz";
  std::string text = sphereXyz(3000) + "nan 0 0\n0 inf 0\n";  // two non-finite rows
  const auto first = test::fibonacciSpherePoints(3000);
  for (int i = 0; i < 5; ++i) text += fmt::format("{} {} {}\n", first[i].x(), first[i].y(), first[i].z());
  test::writeBytes(path, text);
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const IngestReport& report = result->report;
  EXPECT_EQ(report.format, "xyz");
  EXPECT_FALSE(report.isMesh);
  EXPECT_EQ(removedBy(report, "drop_non_finite"), 2u);
  EXPECT_EQ(removedBy(report, "merge_duplicate_points"), 5u);
  EXPECT_EQ(report.pointsOut, 3000u);
  EXPECT_EQ(report.normalsSource, "estimated");
  EXPECT_EQ(report.normalOrientation, "propagation");
  EXPECT_EQ(report.inputSha256, sha256OfBytes(text));
  const auto& points = result->scan.points;
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_GT(points.normals[i].dot(points.positions[i]), 0.9f) << i;
}

// A depth frame seen from the origin down +z: a ball of radius 0.5 at
// z = 3 in front of a wall at z = 5 that fills only part of the view (other
// pixels have no return), as an organised PCD. Ground truth by ray casting
// in closed form.
struct DepthFrame {
  std::string pcd;
  std::size_t missing = 0;
  // Lone pixels without a return on the wall (stereo matching fails on
  // single pixels): each one's four neighbours, up, right, down, left.
  std::vector<std::array<Vec3f, 4>> loneHoles;
};
DepthFrame ballBeforeAWall(int width, int height) {
  DepthFrame frame;
  frame.pcd = fmt::format("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {}\nHEIGHT {}\n"
                          "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA ascii\n",
                          width, height, width * height);
  const Eigen::Vector3d centre(0.0, 0.0, 3.0);
  std::vector<Eigen::Vector3d> hits(static_cast<std::size_t>(width * height));
  std::vector<char> onWall(hits.size(), 0);
  for (int row = 0; row < height; ++row)
    for (int column = 0; column < width; ++column) {
      const Eigen::Vector3d ray =
          Eigen::Vector3d((column - width / 2.0) / width, (row - height / 2.0) / width, 1.0).normalized();
      const double along = ray.dot(centre), gap = along * along - (centre.squaredNorm() - 0.25);
      Eigen::Vector3d& hit = hits[static_cast<std::size_t>(row * width + column)];
      if (gap >= 0.0) hit = (along - std::sqrt(gap)) * ray;
      else hit = (5.0 / ray.z()) * ray;
      if (gap < 0.0 && std::abs(hit.x()) > 1.5) hit.setConstant(std::nan(""));
      onWall[static_cast<std::size_t>(row * width + column)] = gap < 0.0 && hit.allFinite();
    }
  const auto at = [&](int row, int column) { return static_cast<std::size_t>(row * width + column); };
  for (int row = 4; row + 1 < height; row += 9)
    for (int column = 5; column + 1 < width; column += 11)
      if (onWall[at(row, column)] && onWall[at(row - 1, column)] && onWall[at(row, column + 1)] &&
          onWall[at(row + 1, column)] && onWall[at(row, column - 1)]) {
        frame.loneHoles.push_back({hits[at(row - 1, column)].cast<float>(), hits[at(row, column + 1)].cast<float>(),
                                   hits[at(row + 1, column)].cast<float>(), hits[at(row, column - 1)].cast<float>()});
        hits[at(row, column)].setConstant(std::nan(""));
      }
  for (const Eigen::Vector3d& hit : hits) {
    if (!hit.allFinite()) {
      frame.pcd += "nan nan nan\n";
      ++frame.missing;
    } else {
      frame.pcd += fmt::format("{} {} {}\n", hit.x(), hit.y(), hit.z());
    }
  }
  return frame;
}

// Whether `mesh` has an edge between the vertices nearest to a and b.
bool hasEdgeBetween(const Scan& mesh, const Vec3f& a, const Vec3f& b) {
  const auto nearest = [&](const Vec3f& q) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < mesh.points.size(); ++i)
      if ((mesh.points.positions[i] - q).squaredNorm() < (mesh.points.positions[best] - q).squaredNorm()) best = i;
    return static_cast<std::uint32_t>(best);
  };
  const std::uint32_t i = nearest(a), j = nearest(b);
  return std::any_of(mesh.triangles.begin(), mesh.triangles.end(), [&](const Triangle& t) {
    const auto has = [&](std::uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; };
    return has(i) && has(j);
  });
}

TEST(IngestScan, ADepthFrameIsTriangulatedOnItsGridAndCutAtDepthJumps) {
  const fs::path path = test::freshTempDir() / "frame.pcd";
  const DepthFrame frame = ballBeforeAWall(80, 60);
  test::writeBytes(path, frame.pcd);
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const IngestReport& report = result->report;
  const Scan& mesh = result->scan;
  EXPECT_TRUE(report.isMesh);
  ASSERT_TRUE(report.gridMesh.made);
  EXPECT_EQ(report.gridMesh.width, 80u);
  EXPECT_EQ(report.gridMesh.height, 60u);
  EXPECT_EQ(report.gridMesh.missing, frame.missing);
  EXPECT_GT(frame.missing, 0u);
  EXPECT_EQ(removedBy(report, "drop_non_finite"), frame.missing);
  EXPECT_EQ(report.gridMesh.sensorSource, "origin");  // PCL's default VIEWPOINT: the camera's frame
  EXPECT_NEAR(report.gridMesh.angularStep, 1.0 / 80.0, 0.1 / 80.0);
  EXPECT_EQ(report.gridMesh.maxEdgeInSpacings, 4.0);  // a clean frame: the floor
  EXPECT_GT(report.gridMesh.refused, 0u);  // the ball's silhouette against the wall
  EXPECT_EQ(report.normalsSource, "estimated");
  EXPECT_EQ(report.normalOrientation, "viewpoint");
  EXPECT_FALSE(report.faceOrientation.checked);
  EXPECT_FALSE(report.meshInput.checked);
  // No triangle joins the ball to the wall; every one faces the sensor.
  const auto onBall = [](const Vec3f& p) { return std::abs((p - Vec3f(0, 0, 3)).norm() - 0.5f) < 1e-3f; };
  ASSERT_EQ(mesh.triangles.size(), report.gridMesh.triangles);
  for (const Triangle& t : mesh.triangles) {
    const auto& p = mesh.points.positions;
    EXPECT_TRUE((onBall(p[t[0]]) == onBall(p[t[1]])) && (onBall(p[t[1]]) == onBall(p[t[2]])));
    EXPECT_LT((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(p[t[0]]), 0.0f);
  }
  // Normals fitted over pixel neighbourhoods, facing the sensor: the ball's
  // radial within a few degrees away from its rim, the wall's -z.
  for (std::size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3f& p = mesh.points.positions[i];
    const Vec3f& n = mesh.points.normals[i];
    EXPECT_LT(n.dot(p.normalized()), 0.0f) << i;
    const Vec3f radial = (p - Vec3f(0, 0, 3)).normalized();
    if (onBall(p) && radial.z() < -0.5f) {
      EXPECT_GT(n.dot(radial), 0.99f) << i;
    }
    if (std::abs(p.z() - 5.0f) < 1e-3f && std::hypot(p.x(), p.y()) > 1.0f) {
      EXPECT_GT(-n.z(), 0.999f) << i;
    }
  }
  // A lone pixel without a return leaves only its own diamond open: each of
  // the four cells around it gets the triangle of its three other corners.
  ASSERT_GE(frame.loneHoles.size(), 10u);
  for (const auto& around : frame.loneHoles)
    for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(hasEdgeBetween(mesh, around[k], around[(k + 1) % 4])) << k;
  const auto json = nlohmann::json::parse(ingestReportJson(report));
  EXPECT_EQ(json["grid_mesh"]["pixels_without_return"], frame.missing);
  EXPECT_EQ(json["grid_mesh"]["triangles"], mesh.triangles.size());

  IngestOptions asPoints;
  asPoints.triangulateGrid = false;
  auto points = ingestScan(path, test::checked(asPoints));
  ASSERT_TRUE(points.ok()) << points.error().message;
  EXPECT_FALSE(points->report.isMesh);
  EXPECT_FALSE(points->report.gridMesh.made);
  EXPECT_TRUE(nlohmann::json::parse(ingestReportJson(points->report))["grid_mesh"].is_null());
}

// A noisy stereo frame of a floor seen at grazing angles (down to 9 degrees): its
// neighbour distances spread far beyond 4 ray spacings without any depth
// jump. The jump test rises with that spread (measured from the frame), so
// the floor stays one surface instead of a sieve.
TEST(IngestScan, ANoisyGrazingFrameIsNotCutIntoASieve) {
  constexpr int width = 80, height = 60;
  const Eigen::Vector3d normal = Eigen::Vector3d(0.0, -0.88, 0.47).normalized();
  std::mt19937 random(7);
  std::uniform_real_distribution<double> noise(-1.0, 1.0);
  std::vector<Eigen::Vector3d> hits;
  std::string pcd = fmt::format("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {}\nHEIGHT {}\n"
                                "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA ascii\n",
                                width, height, width * height);
  for (int row = 0; row < height; ++row)
    for (int column = 0; column < width; ++column) {
      const Eigen::Vector3d ray =
          Eigen::Vector3d((column - width / 2.0) / width, (row - height / 2.0) / width, 1.0).normalized();
      const double range = 3.0 * normal.z() / ray.dot(normal);  // the plane through (0, 0, 3)
      hits.push_back(range * (1.0 + 0.003 * noise(random)) * ray);
      pcd += fmt::format("{} {} {}\n", hits.back().x(), hits.back().y(), hits.back().z());
    }
  // Independently: the cells a fixed 4-spacing test would cut.
  std::size_t overFour = 0, cells = 0;
  for (int row = 0; row + 1 < height; ++row)
    for (int column = 0; column + 1 < width; ++column, ++cells) {
      const auto& a = hits[row * width + column];
      const auto& d = hits[(row + 1) * width + column + 1];
      const double spacing = (1.0 / width) * (0.5 * (a + d)).norm();
      if ((a - d).norm() > 4.0 * spacing || (a - hits[(row + 1) * width + column]).norm() > 4.0 * spacing) ++overFour;
    }
  ASSERT_GT(overFour, cells / 25) << overFour;
  const fs::path path = test::freshTempDir() / "floor.pcd";
  test::writeBytes(path, pcd);
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const auto& grid = result->report.gridMesh;
  ASSERT_TRUE(grid.made);
  EXPECT_GT(grid.maxEdgeInSpacings, 4.0);
  EXPECT_LE(grid.maxEdgeInSpacings, 10.0);
  EXPECT_LT(grid.refused, grid.candidates / 100) << grid.maxEdgeInSpacings;
  EXPECT_EQ(nlohmann::json::parse(ingestReportJson(result->report))["grid_mesh"]["max_edge_in_spacings"],
            grid.maxEdgeInSpacings);
}

TEST(IngestScan, MeshSoupIsWeldedAndGetsFaceNormals) {
  // Two triangles of a square as an unwelded soup plus a degenerate and a
  // duplicate triangle and an unused vertex.
  const fs::path path = test::freshTempDir() / "square.off";
  test::writeBytes(path,
                   "OFF\n8 4 0\n0 0 0\n1 0 0\n1 1 0\n0 0 0\n1 1 0\n0 1 0\n5 5 5\n2 0 0\n"
                   "3 0 1 2\n3 3 4 5\n3 0 1 7\n3 2 0 1\n");
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const IngestReport& report = result->report;
  EXPECT_TRUE(report.isMesh);
  EXPECT_EQ(removedBy(report, "merge_duplicate_vertices"), 2u);
  EXPECT_EQ(removedBy(report, "drop_degenerate_triangles"), 1u);
  EXPECT_EQ(removedBy(report, "drop_duplicate_triangles"), 1u);
  EXPECT_EQ(removedBy(report, "drop_unreferenced_vertices"), 2u);
  EXPECT_EQ(report.pointsOut, 4u);
  EXPECT_EQ(report.trianglesOut, 2u);
  EXPECT_EQ(report.normalsSource, "computed_from_faces");
  for (const Vec3f& n : result->scan.points.normals) EXPECT_NEAR(n.z(), 1.0f, 1e-6f);
}

// Ingests `bytes` written to a fresh file `name`; the error's message, after
// checking that it is BadInput naming the file.
std::string badInputMessage(const std::string& name, std::string_view bytes) {
  const fs::path path = test::freshTempDir() / name;
  test::writeBytes(path, bytes);
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  if (result.ok()) return "<ingest succeeded>";
  EXPECT_EQ(result.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(result.error().message, HasSubstr(path.string()));
  return result.error().message;
}

TEST(IngestScan, AllNonFiniteIsBadInput) {
  EXPECT_THAT(badInputMessage("nan.xyz", "nan 0 0\n0 nan 0\ninf 1 1\n"),
              HasSubstr("all 3 points have non-finite coordinates"));
}

// The 8 corners of a cube (CGAL's points_3/cube.xyz): no neighbourhood is a
// surface, so no normal can be estimated and the scan empties; the message
// says which step emptied it.
TEST(IngestScan, AScanEmptiedByCleaningSaysWhichStepEmptiedIt) {
  const std::string message =
      badInputMessage("cube.xyz", "-1 -1 -1\n-1 1 -1\n1 1 -1\n1 -1 -1\n-1 -1 1\n-1 1 1\n1 1 1\n1 -1 1\n");
  EXPECT_THAT(message, HasSubstr("no point remains after cleaning"));
  EXPECT_THAT(message, HasSubstr("drop_points_without_normal removed the last 8"));
}

TEST(IngestScan, VoxelAndOutlierOptionsAreReported) {
  const fs::path path = test::freshTempDir() / "sphere.xyz";
  test::writeBytes(path, sphereXyz(4000) + "30 30 30\n");  // one far outlier
  IngestOptions options;
  options.removeOutliers = true;
  options.voxelSize = 0.2;
  auto result = ingestScan(path, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_GE(removedBy(result->report, "remove_statistical_outliers"), 1u);
  for (const Vec3f& p : result->scan.points.positions) EXPECT_LT(p.norm(), 1.01f);
  EXPECT_GT(removedBy(result->report, "voxel_downsample"), 3000u);
}

TEST(IngestScan, SensorPositionOverridesOrientation) {
  const fs::path path = test::freshTempDir() / "sphere.xyz";
  test::writeBytes(path, sphereXyz(2000));
  IngestOptions options;
  options.sensorPosition = Vec3f::Zero();  // as if scanned from inside
  auto result = ingestScan(path, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->report.normalOrientation, "viewpoint");
  const auto& points = result->scan.points;
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_LT(points.normals[i].dot(points.positions[i]), -0.9f) << i;
}

// A synthetic aerial tile in UTM metres (100 m square, gentle hills) as a
// PCD with double fields, and its true upward normals.
struct TerrainTile {
  std::vector<std::array<double, 3>> points;
  std::vector<Vec3f> up;
};

TerrainTile utmTerrainTile() {
  constexpr double kEast = 512000.0, kNorth = 5402000.0, kHeight = 310.0;
  TerrainTile tile;
  std::mt19937 random(5);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  for (int i = 0; i < 160; ++i)
    for (int j = 0; j < 160; ++j) {
      const double x = i * 0.625 + jitter(random), y = j * 0.625 + jitter(random);
      const double z = 3.0 * std::sin(x / 15.0) * std::cos(y / 20.0) + 0.04 * x;
      const double dzdx = 0.2 * std::cos(x / 15.0) * std::cos(y / 20.0) + 0.04;
      const double dzdy = -0.15 * std::sin(x / 15.0) * std::sin(y / 20.0);
      tile.points.push_back({kEast + x, kNorth + y, kHeight + z});
      tile.up.push_back(Vec3f(static_cast<float>(-dzdx), static_cast<float>(-dzdy), 1.0f).normalized());
    }
  return tile;
}

std::string terrainPcd(const TerrainTile& tile, const std::string& viewpoint) {
  std::string text = fmt::format(
      "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {}\nHEIGHT 1\nVIEWPOINT {}\nPOINTS {}\n"
      "DATA ascii\n",
      tile.points.size(), viewpoint, tile.points.size());
  for (const auto& p : tile.points) text += fmt::format("{:.3f} {:.3f} {:.3f}\n", p[0], p[1], p[2]);
  return text;
}

// Ingests the tile with `viewpoint`: the report, and how many normals point
// into the ground (against the truth, matched by position).
std::pair<IngestReport, std::size_t> ingestTerrain(const std::string& viewpoint) {
  const TerrainTile tile = utmTerrainTile();
  const fs::path path = test::freshTempDir() / "tile.pcd";
  test::writeBytes(path, terrainPcd(tile, viewpoint));
  IngestOptions options;
  options.mergeDuplicates = false;  // points and truth stay in step
  auto result = ingestScan(path, test::checked(options));
  EXPECT_TRUE(result.ok()) << result.error().message;
  if (!result.ok()) return {};
  const Scan& scan = result->scan;
  EXPECT_EQ(scan.points.size(), tile.points.size());
  std::size_t flipped = 0;
  for (std::size_t i = 0; i < scan.points.size(); ++i) flipped += scan.points.normals[i].dot(tile.up[i]) < 0.0f;
  return {result->report, flipped};
}

TEST(SensorPositions, PcdsDefaultViewpointOnAUtmTileIsNotASensor) {
  const auto [report, flipped] = ingestTerrain("0 0 0 1 0 0 0");
  EXPECT_EQ(report.sensor.source, "pcd_default_viewpoint");
  EXPECT_THAT(report.sensor.refused, HasSubstr("zero of the file's georeferenced coordinates"));
  EXPECT_EQ(report.normalOrientation, "propagation");
  EXPECT_EQ(flipped, 0u);
}

TEST(SensorPositions, TheZeroOfGeoreferencedCoordinatesIsNotASensor) {
  const auto [report, flipped] = ingestTerrain("0 0 0 0 1 0 0");  // not PCL's default rotation
  EXPECT_THAT(report.sensor.refused, HasSubstr("zero of the file's georeferenced coordinates"));
  EXPECT_EQ(report.normalOrientation, "propagation");
  EXPECT_EQ(flipped, 0u);
}

TEST(SensorPositions, APositionBelowAnAerialTilesTopIsNotASensor) {
  const auto [report, flipped] = ingestTerrain("512050 5402050 250 1 0 0 0");
  EXPECT_THAT(report.sensor.refused, HasSubstr("lower than the top"));
  EXPECT_EQ(flipped, 0u);
}

TEST(SensorPositions, ATrueSensorAboveTheTileIsUsedAndAgrees) {
  const auto [report, flipped] = ingestTerrain("512050 5402050 1310 1 0 0 0");
  EXPECT_EQ(report.sensor.source, "viewpoint");
  EXPECT_TRUE(report.sensor.refused.empty()) << report.sensor.refused;
  ASSERT_TRUE(report.sensor.checked);
  EXPECT_TRUE(report.sensor.kept);
  EXPECT_EQ(report.sensor.disagreeing, 0u);
  EXPECT_EQ(report.normalOrientation, "viewpoint");
  EXPECT_EQ(flipped, 0u);
}

// Real PCD files with PCL's default VIEWPOINT: the table scene was taken
// from the origin (its normals agree with propagation on 95% of the points,
// and 97% are in sight of it); the bunny's origin lies under it, hiding a
// third of its points: refused, propagation kept.
TEST(SensorPositions, PcdsDefaultViewpointIsUsedOnlyWhereThePointsConfirmIt) {
  auto bunny = ingestScan(test::datasetPath("pcl/bun0.pcd"), test::checked(IngestOptions{}));
  ASSERT_TRUE(bunny.ok()) << bunny.error().message;
  EXPECT_EQ(bunny->report.sensor.source, "pcd_default_viewpoint");
  EXPECT_TRUE(bunny->report.sensor.checked);
  EXPECT_FALSE(bunny->report.sensor.kept);
  EXPECT_GT(bunny->report.sensor.hidden, bunny->report.sensor.sampledForSight / 5);
  EXPECT_EQ(bunny->report.normalOrientation, "propagation");
}

TEST(IngestScan, BadOptionIsAUsageError) {
  IngestOptions options;
  options.voxelSize = -1;
  auto result = check(options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().kind, ErrorKind::Usage);
}

TEST(WriteIngestOutputs, WritesPlyAndJsonThatReadBack) {
  const fs::path dir = test::freshTempDir();
  const fs::path input = dir / "in.xyz";
  test::writeBytes(input, sphereXyz(500));
  auto result = ingestScan(input, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok());
  ASSERT_TRUE(writeIngestOutputs(dir / "out", *result).ok());
  auto ply = readScan(dir / "out" / "scan.ply");
  ASSERT_TRUE(ply.ok()) << ply.error().message;
  EXPECT_EQ(ply->points.positions, result->scan.points.positions);
  EXPECT_EQ(ply->points.normals, result->scan.points.normals);
  const auto json = nlohmann::json::parse(*readFileBytes(dir / "out" / "ingest.json"));
  EXPECT_EQ(json["format_version"], 1);
  EXPECT_EQ(json["input"]["sha256"], sha256OfBytes(sphereXyz(500)));
  EXPECT_EQ(json["counts"]["points_out"], 500);
  EXPECT_EQ(json["normals"]["source"], "estimated");
  EXPECT_NEAR(json["bounding_box"]["diagonal"].get<double>(), 2.0 * std::sqrt(3.0), 0.05);
  EXPECT_TRUE(json["cleaning"].is_array());
}

// PCL's default VIEWPOINT, confirmed by the points (SensorPositions above).
// Normals seen squarely face it; grazing ones follow their squarely seen
// neighbours, and a few of those (1.6%) lean just past the line of sight.
TEST(IngestScan, RealLaserScanTableSceneOrientsTowardsItsViewpoint) {
  const fs::path path = test::datasetPath("pcl/table_scene_lms400.pcd");
  auto result = ingestScan(path, test::checked(IngestOptions{}));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const IngestReport& report = result->report;
  EXPECT_EQ(report.pointsIn, 460400u);
  EXPECT_EQ(report.normalsSource, "estimated");
  EXPECT_EQ(report.normalOrientation, "viewpoint");
  EXPECT_GT(report.pointsOut, 400000u);
  const auto& points = result->scan.points;
  std::size_t sampled = 0, away = 0, squarelyAway = 0;
  for (std::size_t i = 0; i < points.size(); i += 97) {
    EXPECT_NEAR(points.normals[i].norm(), 1.0f, 1e-4f);
    const Vec3f toSensor = (report.viewpoint.origin - points.positions[i]).normalized();
    ++sampled;
    away += points.normals[i].dot(toSensor) < 0.0f;
    squarelyAway += points.normals[i].dot(toSensor) < -0.3f;
  }
  EXPECT_LT(away, sampled / 40);
  EXPECT_EQ(squarelyAway, 0u);
}

}  // namespace
}  // namespace apo
