#include "reconstruct/reconstruct.h"

#include "ingest/ingest.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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
  auto result = simplifyMesh(dense, options);
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
}

TEST(SimplifyMesh, SameOptionsGiveByteIdenticalFiles) {
  const Scan dense = test::makeIcosphere(5);
  SimplifyOptions options;
  options.targetFaces = 700;
  const fs::path dir = test::freshTempDir();
  for (const char* name : {"a.ply", "b.ply"}) {
    auto result = simplifyMesh(dense, options);
    ASSERT_TRUE(result.ok());
    ASSERT_TRUE(writePly(dir / name, result->mesh).ok());
  }
  EXPECT_EQ(test::runCommand("cmp " + (dir / "a.ply").string() + " " + (dir / "b.ply").string()).exitCode, 0);
}

TEST(SimplifyMesh, RatioAndLindstromTurk) {
  SimplifyOptions options;
  options.ratio = 0.1;
  options.policy = SimplifyPolicy::LindstromTurk;
  auto result = simplifyMesh(test::makeIcosphere(4), options);  // 5,120 faces
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->report.targetFaces, 512u);
  EXPECT_NEAR(static_cast<double>(result->report.facesOut), 512.0, 5.2);
  EXPECT_EQ(result->report.policy, "lindstrom-turk");
}

TEST(SimplifyMesh, TargetNotBelowInputKeepsTheMeshAndSaysSo) {
  SimplifyOptions options;
  options.targetFaces = 100000;
  const Scan sphere = test::makeIcosphere(2);
  auto result = simplifyMesh(sphere, options);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->mesh.triangles, sphere.triangles);
  EXPECT_THAT(result->report.policy, HasSubstr("target not below input"));
}

TEST(SimplifyMesh, PointCloudAndBadTargetsAreRefused) {
  Scan cloud;
  cloud.points.positions = {{0, 0, 0}};
  EXPECT_EQ(simplifyMesh(cloud, SimplifyOptions{}).error().kind, ErrorKind::BadInput);
  SimplifyOptions options;
  options.targetFaces = 2;
  EXPECT_EQ(simplifyMesh(test::makeIcosphere(1), options).error().kind, ErrorKind::Usage);
  options = {};
  options.ratio = 1.5;
  EXPECT_EQ(simplifyMesh(test::makeIcosphere(1), options).error().kind, ErrorKind::Usage);
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
  auto result = simplifyMesh(a, options);
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_NEAR(static_cast<double>(result->report.facesOut), 400.0, 4.0);
}

}  // namespace
}  // namespace apo
