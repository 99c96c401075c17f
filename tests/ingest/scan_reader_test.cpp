#include "ingest/ingest.h"

#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(FormatFromExtension, KnowsEveryFormatCaseInsensitively) {
  EXPECT_EQ(*formatFromExtension("a.PLY"), ScanFormat::Ply);
  EXPECT_EQ(*formatFromExtension("a.pcd"), ScanFormat::Pcd);
  EXPECT_EQ(*formatFromExtension("a.xyz"), ScanFormat::Xyz);
  EXPECT_EQ(*formatFromExtension("a.xyzn"), ScanFormat::Xyz);
  EXPECT_EQ(*formatFromExtension("a.pts"), ScanFormat::Xyz);
  EXPECT_EQ(*formatFromExtension("a.Off"), ScanFormat::Off);
  EXPECT_EQ(*formatFromExtension("a.obj"), ScanFormat::Obj);
  EXPECT_EQ(*formatFromExtension("a.stl"), ScanFormat::Stl);
}

TEST(ReadScan, UnsupportedExtensionNamesFileAndExtension) {
  const fs::path path = test::freshTempDir() / "scan.xyzw";
  test::writeBytes(path, "whatever");
  auto scan = readScan(path);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(scan.error().message, HasSubstr(path.string()));
  EXPECT_THAT(scan.error().message, HasSubstr("unsupported extension '.xyzw'"));
}

TEST(ReadScan, DirectoryNamedLikeAScanIsRefused) {
  const fs::path dir = test::freshTempDir() / "folder.ply";
  fs::create_directories(dir);
  auto scan = readScan(dir);
  ASSERT_FALSE(scan.ok());
  EXPECT_THAT(scan.error().message, HasSubstr("is a directory"));
}

TEST(ReadScan, ParseErrorsArePrefixedWithTheFileName) {
  const fs::path path = test::freshTempDir() / "bad.off";
  test::writeBytes(path, "NOT_OFF\n1 0 0\n");
  auto scan = readScan(path);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(scan.error().message, HasSubstr(path.string() + ": line 1"));
}

TEST(WritePly, BinaryRoundTripThroughReadScan) {
  Scan mesh = test::makeIcosphere(1);
  mesh.points.normals = mesh.points.positions;
  mesh.points.colors.assign(mesh.points.size(), Rgb8{1, 2, 3});
  const fs::path path = test::freshTempDir() / "mesh.ply";
  ASSERT_TRUE(writePly(path, mesh).ok());
  auto read = readScan(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->points.positions, mesh.points.positions);
  EXPECT_EQ(read->points.normals, mesh.points.normals);
  EXPECT_EQ(read->points.colors, mesh.points.colors);
  EXPECT_EQ(read->triangles, mesh.triangles);
}

}  // namespace
}  // namespace apo
