#include "ingest/ingest.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(SimulateScanCommand, ScansAMeshFileIntoAPlyThatIngests) {
  const fs::path dir = test::freshTempDir();
  ASSERT_TRUE(writePly(dir / "sphere.ply", test::makeIcosphere(3)).ok());
  const auto result = test::runCommand(test::apoExecutable().string() + " simulate-scan " + (dir / "sphere.ply").string() +
                                       " -o " + (dir / "scan.ply").string() + " --views 4 --rays 40");
  ASSERT_EQ(result.exitCode, 0) << result.output;
  auto scan = readScan(dir / "scan.ply");
  ASSERT_TRUE(scan.ok()) << scan.error().message;
  EXPECT_GT(scan->points.size(), 2000u);
  EXPECT_FALSE(scan->isMesh());
}

// --las and --laz: the same points as the PLY, within the LAS grid's step.
TEST(SimulateScanCommand, WritesLasAndLazOfThePoints) {
  const fs::path dir = test::freshTempDir();
  ASSERT_TRUE(writePly(dir / "sphere.ply", test::makeIcosphere(3)).ok());
  const auto result = test::runCommand(test::apoExecutable().string() + " simulate-scan " + (dir / "sphere.ply").string() +
                                       " -o " + (dir / "scan.ply").string() + " --las " + (dir / "scan.las").string() +
                                       " --laz " + (dir / "scan.laz").string() + " --views 4 --rays 40");
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const auto ply = readScan(dir / "scan.ply");
  ASSERT_TRUE(ply.ok()) << ply.error().message;
  for (const char* name : {"scan.las", "scan.laz"}) {
    SCOPED_TRACE(name);
    const auto las = readScan(dir / name);
    ASSERT_TRUE(las.ok()) << las.error().message;
    ASSERT_EQ(las->points.size(), ply->points.size());
    for (std::size_t i = 0; i < ply->points.size(); ++i)
      ASSERT_LT((las->points.positions[i] - ply->points.positions[i]).norm(), 1e-6f) << "point " << i;
  }
}

TEST(SimulateScanCommand, PointCloudInputIsBadInput) {
  const fs::path dir = test::freshTempDir();
  test::writeBytes(dir / "points.xyz", "0 0 0\n1 0 0\n0 1 0\n");
  const auto result = test::runCommand(test::apoExecutable().string() + " simulate-scan " + (dir / "points.xyz").string() +
                                       " -o " + (dir / "scan.ply").string());
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("needs a triangle mesh"));
}

}  // namespace
}  // namespace apo
