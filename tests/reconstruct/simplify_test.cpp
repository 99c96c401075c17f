#include "reconstruct/reconstruct.h"

#include "ingest/ingest.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

// For n equal-area triangles on the unit sphere, the sagitta of one
// triangle's circumcircle: how far a flat face sits inside the sphere.
double sagittaOfSphereTriangles(double n) {
  const double edge = std::sqrt(4.0 * std::numbers::pi / n * 4.0 / std::sqrt(3.0));
  const double circumradius = edge / std::sqrt(3.0);
  return 1.0 - std::sqrt(1.0 - circumradius * circumradius);
}

TEST(SimplifyMesh, DenseSphereTo500FacesStaysOnTheSphere) {
  const Scan dense = test::makeIcosphere(6);  // 81,920 faces
  SimplifyOptions options;
  options.targetFaces = 500;
  auto result = simplifyMesh(dense, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const Scan& m = result->mesh;
  EXPECT_NEAR(static_cast<double>(m.triangles.size()), 500.0, 5.0);
  EXPECT_EQ(result->report.quality.eulerCharacteristic, 2);
  EXPECT_EQ(result->report.quality.boundaryLoops, 0u);
  // A quadric-optimal vertex balances the planes of the faces around it,
  // which sag inside the sphere by up to a sagitta: vertices move outwards
  // by less than that. Faces sag inwards by about the sagitta of 500 faces,
  // less than twice that with uneven sizes.
  const double sagitta = sagittaOfSphereTriangles(500);
  for (const Vec3f& p : m.points.positions) EXPECT_NEAR(p.norm(), 1.0, sagitta);
  const double bound = 2.0 * sagitta;
  const double diagonal = 2.0 * std::sqrt(3.0);
  EXPECT_LT(result->report.hausdorff * diagonal, bound);
  EXPECT_GT(result->report.hausdorff, 0.0);
  EXPECT_EQ(result->report.quickPassFaces, 0u);  // 81,920 faces: CGAL alone
}

// Above 200,000 faces meshoptimizer's collapses first bring M to 100,000,
// then CGAL's finish: the result keeps the guarantees of CGAL alone.
TEST(SimplifyMesh, ALargeMeshGoesThroughTheQuickPassAndStaysOnTheSphere) {
  const Scan dense = test::makeIcosphere(7);  // 327,680 faces
  SimplifyOptions options;
  options.targetFaces = 500;
  auto result = simplifyMesh(dense, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_LE(result->report.quickPassFaces, kQuickCollapseFaces);
  EXPECT_GT(result->report.quickPassFaces, kQuickCollapseFaces * 9 / 10);
  EXPECT_LT(result->report.quickPassError, 1e-3);
  const Scan& m = result->mesh;
  EXPECT_NEAR(static_cast<double>(m.triangles.size()), 500.0, 5.0);
  EXPECT_EQ(result->report.quality.eulerCharacteristic, 2);
  EXPECT_EQ(result->report.quality.boundaryLoops, 0u);
  // The price of speed, measured (docs/benchmarks.md, "Raw acquisitions"):
  // CGAL's quadrics start from the 100,000-face mesh, not the sphere's own
  // faces, and the folds removed leave small patches CGAL re-closes, so m
  // sits farther from the sphere than with CGAL alone: vertices within 2
  // sagittas instead of one, the Hausdorff distance within 3 instead of 2
  // (measured 1.6 and 2.4).
  const double sagitta = sagittaOfSphereTriangles(500);
  for (const Vec3f& p : m.points.positions) EXPECT_NEAR(p.norm(), 1.0, 2.0 * sagitta);
  EXPECT_LT(result->report.hausdorff * 2.0 * std::sqrt(3.0), 3.0 * sagitta);
  EXPECT_THAT(simplifyReportJson(result->report), HasSubstr("\"library\": \"meshoptimizer\""));
}

TEST(SimplifyMesh, SameOptionsGiveByteIdenticalFiles) {
  const Scan dense = test::makeIcosphere(5);
  SimplifyOptions options;
  options.targetFaces = 700;
  const fs::path dir = test::freshTempDir();
  for (const char* name : {"a.ply", "b.ply"}) {
    auto result = simplifyMesh(dense, test::checked(options));
    ASSERT_TRUE(result.ok());
    ASSERT_TRUE(writePly(dir / name, result->mesh).ok());
  }
  EXPECT_EQ(test::runCommand("cmp " + (dir / "a.ply").string() + " " + (dir / "b.ply").string()).exitCode, 0);
}

TEST(SimplifyMesh, RatioAndLindstromTurk) {
  SimplifyOptions options;
  options.ratio = 0.1;
  options.policy = SimplifyPolicy::LindstromTurk;
  auto result = simplifyMesh(test::makeIcosphere(4), test::checked(options));  // 5,120 faces
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->report.targetFaces, 512u);
  EXPECT_NEAR(static_cast<double>(result->report.facesOut), 512.0, 5.2);
  EXPECT_EQ(result->report.policy, "lindstrom-turk");
}

// 5,120 faces to 512: the collapses report each percent of the 4,608 faces
// to remove, rising, then the end; the result is the same as without.
TEST(SimplifyMesh, ReportsRisingProgressAndTheSameMesh) {
  SimplifyOptions options;
  options.targetFaces = 512;
  std::vector<double> fractions;
  auto watched = simplifyMesh(test::makeIcosphere(4), test::checked(options), [&](double f) { fractions.push_back(f); });
  auto plain = simplifyMesh(test::makeIcosphere(4), test::checked(options));
  ASSERT_TRUE(watched.ok() && plain.ok());
  EXPECT_EQ(watched->mesh.triangles, plain->mesh.triangles);
  ASSERT_GE(fractions.size(), 50u);  // a report per percent of the collapses, at most 101 and the end
  EXPECT_LE(fractions.size(), 102u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_GE(fractions.front(), 0.0);
  EXPECT_EQ(fractions.back(), 1.0);
}

TEST(SimplifyMesh, TargetNotBelowInputKeepsTheMeshAndSaysSo) {
  SimplifyOptions options;
  options.targetFaces = 100000;
  const Scan sphere = test::makeIcosphere(2);
  auto result = simplifyMesh(sphere, test::checked(options));
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->mesh.triangles, sphere.triangles);
  EXPECT_THAT(result->report.policy, HasSubstr("target not below input"));
}

TEST(SimplifyMesh, PointCloudAndBadTargetsAreRefused) {
  Scan cloud;
  cloud.points.positions = {{0, 0, 0}};
  EXPECT_EQ(simplifyMesh(cloud, test::checked(SimplifyOptions{})).error().kind, ErrorKind::BadInput);
  SimplifyOptions options;
  options.targetFaces = 2;
  EXPECT_EQ(check(options).error().kind, ErrorKind::Usage);
  options = {};
  options.ratio = 1.5;
  EXPECT_EQ(check(options).error().kind, ErrorKind::Usage);
}

TEST(SimplifyMesh, NonManifoldInputIsRepairedNotFatal) {
  // Two icospheres glued at one shared vertex: a non-manifold vertex.
  Scan a = test::makeIcosphere(3);
  const Scan b = test::makeIcosphere(3);
  const auto offset = static_cast<std::uint32_t>(a.points.size());
  const Vec3f shift = a.points.positions[0] - (-b.points.positions[0]);
  for (const Vec3f& p : b.points.positions) a.points.positions.push_back(-p + shift);
  for (Triangle t : b.triangles) {
    for (auto& v : t) v = v == 0 ? 0 : v + offset;
    a.triangles.push_back({t[0], t[2], t[1]});  // mirrored: keep outward winding
  }
  SimplifyOptions options;
  options.targetFaces = 400;
  auto result = simplifyMesh(a, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_NEAR(static_cast<double>(result->report.facesOut), 400.0, 4.0);
}

// A height field z = h(x, y) over the unit square, `cells` x `cells` squares
// of two triangles each; the squares for which `punch` holds are left out.
template <class Height, class Punch>
Scan heightFieldGrid(int cells, Height h, Punch punch) {
  Scan grid;
  const auto index = [cells](int i, int j) { return static_cast<std::uint32_t>(j * (cells + 1) + i); };
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      const float x = static_cast<float>(i) / static_cast<float>(cells), y = static_cast<float>(j) / static_cast<float>(cells);
      grid.points.positions.emplace_back(x, y, h(x, y));
    }
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      if (punch(i, j)) continue;
      grid.triangles.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
      grid.triangles.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
    }
  return grid;
}

TEST(SimplifyMesh, BordersAreKeptWhenTheyFitTheTarget) {
  // 800 faces and an 80-edge border, to 300 faces: every border vertex of m
  // is still on the square's edge.
  const Scan grid = heightFieldGrid(20, [](float x, float y) { return 0.1f * x * y; }, [](int, int) { return false; });
  SimplifyOptions options;
  options.targetFaces = 300;
  auto result = simplifyMesh(grid, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_NEAR(static_cast<double>(result->report.facesOut), 300.0, 3.0);
  EXPECT_FALSE(result->report.bordersCollapsed);
  EXPECT_EQ(result->report.quality.boundaryLoops, 1u);
  int onEdge = 0;
  for (const Vec3f& p : result->mesh.points.positions)
    onEdge += (p.x() == 0.0f || p.x() == 1.0f || p.y() == 0.0f || p.y() == 1.0f) ? 1 : 0;
  EXPECT_EQ(onEdge, 80);  // the border's 80 vertices, none moved, none lost
}

TEST(SimplifyMesh, SmallHolesAndLongBordersStillReachTheTarget) {
  // A scan-like patch: 20,000 faces, a 400-edge outer border and 100 one-cell
  // holes. Frozen, the holes and the border would hold about 1,200 faces (a
  // polygon of 400 corners alone takes 398 triangles); the holes are closed
  // and the border collapsed along itself, to 200 faces.
  const auto height = [](float x, float y) {
    return 0.05f * std::sin(2.0f * std::numbers::pi_v<float> * x) * std::sin(2.0f * std::numbers::pi_v<float> * y);
  };
  const Scan grid = heightFieldGrid(100, height, [](int i, int j) { return i % 10 == 5 && j % 10 == 5; });
  SimplifyOptions options;
  options.targetFaces = 200;
  auto result = simplifyMesh(grid, test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const Scan& m = result->mesh;
  EXPECT_NEAR(static_cast<double>(m.triangles.size()), 200.0, 2.0);
  EXPECT_EQ(result->report.filledHoles, 100u);
  EXPECT_TRUE(result->report.bordersCollapsed);
  EXPECT_EQ(result->report.quality.boundaryLoops, 1u);
  // m's vertices stay on the height field (about 50 faces per bump: a
  // vertex sits within a tenth of the bump height), and the border keeps the
  // square's extent.
  for (const Vec3f& p : m.points.positions) EXPECT_NEAR(p.z(), height(p.x(), p.y()), 0.005f);
  const Aabb box = boundingBox(m.points.positions);
  EXPECT_NEAR(box.min.x(), 0.0f, 0.01f);
  EXPECT_NEAR(box.max.x(), 1.0f, 0.01f);
  EXPECT_NEAR(box.min.y(), 0.0f, 0.01f);
  EXPECT_NEAR(box.max.y(), 1.0f, 0.01f);
}

// The viewer's preview: about the target's faces, made of the input's own
// vertices with their own normals, still on the sphere (a sphere's normal is
// its position); a mesh already small enough comes back as it was.
TEST(PreviewMesh, KeepsTheInputsVerticesAndNormalsAtAboutTheTarget) {
  Scan dense = test::makeIcosphere(6);  // 81,920 faces
  dense.points.normals = dense.points.positions;
  auto preview = previewMesh(dense, 5000);
  ASSERT_TRUE(preview.ok()) << preview.error().message;
  EXPECT_LE(preview->triangles.size(), 5000u);
  EXPECT_GT(preview->triangles.size(), 4000u);
  ASSERT_EQ(preview->points.normals.size(), preview->points.size());
  for (std::size_t i = 0; i < preview->points.size(); ++i) {
    EXPECT_NEAR(preview->points.positions[i].norm(), 1.0f, 1e-5f);
    EXPECT_EQ(preview->points.normals[i], preview->points.positions[i]);
  }
  auto same = previewMesh(dense, 100000);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->triangles, dense.triangles);
  EXPECT_FALSE(previewMesh(Scan{}, 10).ok());  // no triangles
}

}  // namespace
}  // namespace apo
