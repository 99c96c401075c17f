// The `apo ingest` command end to end: every bad-input case of the issue
// exits 2 with a message naming the file and the problem.
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

test::CommandResult ingest(const fs::path& input, const fs::path& outDir) {
  return test::runCommand(test::apoExecutable().string() + " ingest '" + input.string() + "' -o '" + outDir.string() + "'");
}

// Writes `bytes` as `name` in a fresh folder, runs ingest on it, and checks
// exit code 2, the file's name and `problem` in the output, and no outputs.
void expectRejected(const std::string& name, const std::string& bytes, const std::string& problem) {
  const fs::path dir = test::freshTempDir();
  const fs::path input = dir / name;
  test::writeBytes(input, bytes);
  const auto result = ingest(input, dir / "out");
  EXPECT_EQ(result.exitCode, 2) << result.output;
  EXPECT_THAT(result.output, HasSubstr(input.string()));
  EXPECT_THAT(result.output, HasSubstr(problem));
  EXPECT_FALSE(fs::exists(dir / "out" / "scan.ply"));
}

std::string binaryPlyHeader(const std::string& vertexCount) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + vertexCount +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

TEST(IngestCommand, EmptyFile) { expectRejected("empty.ply", "", "empty"); }

TEST(IngestCommand, TruncatedBinaryBody) {
  expectRejected("truncated.ply", binaryPlyHeader("2") + std::string(12 + 5, '\0'), "truncated");
}

TEST(IngestCommand, HeaderCountLargerThanBody) {
  expectRejected("short.ply",
                 "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                 "end_header\n0 0 0\n1 1 1\n",
                 "line 9");
}

TEST(IngestCommand, FourBillionVerticesInASmallFile) {
  expectRejected("huge.ply", binaryPlyHeader("4000000000") + std::string(24, '\0'), "4000000000");
}

// Above --max-scan-points the scan is read a run at a time into at most that
// many voxel centroids; ingest.json says how many points the file held.
TEST(IngestCommand, ScanAboveMaxScanPointsIsReadIntoVoxelCentroids) {
  const fs::path dir = test::freshTempDir();
  std::string body;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 50; ++j) {
      const float p[3] = {0.01f * static_cast<float>(i), 0.01f * static_cast<float>(j), 0.0f};
      body.append(reinterpret_cast<const char*>(p), sizeof p);
    }
  test::writeBytes(dir / "grid.ply", binaryPlyHeader("3000") + body);
  const auto result = test::runApo(fmt::format("ingest '{}' -o '{}' --max-scan-points 1000 --no-normals",
                                               (dir / "grid.ply").string(), (dir / "out").string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  std::ifstream in(dir / "out" / "ingest.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["large_scan"]["points_in_file"], 3000);
  EXPECT_EQ(json["counts"]["points_in"], 3000);
  EXPECT_LE(json["large_scan"]["voxel_centroids"].get<int>(), 1000);
  EXPECT_GE(json["large_scan"]["voxel_centroids"].get<int>(), 250);
  EXPECT_EQ(json["counts"]["points_out"], json["large_scan"]["voxel_centroids"]);
  // Out of range: a usage error before anything is read.
  const auto refused = test::runApo(fmt::format("ingest '{}' -o '{}' --max-scan-points 10", (dir / "grid.ply").string(),
                                                (dir / "out2").string()));
  EXPECT_EQ(refused.exitCode, 1) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("--max-scan-points"));
}

TEST(IngestCommand, FaceIndexOutOfRange) {
  expectRejected("face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "out of range");
}

TEST(IngestCommand, NegativeCount) { expectRejected("negative.off", "OFF\n-3 1 0\n0 0 0\n", "negative"); }

TEST(IngestCommand, OnlyNonFiniteCoordinates) {
  expectRejected("nan.xyz", "nan 0 0\n1 inf 2\n", "non-finite");
}

TEST(IngestCommand, NonFiniteCoordinatesAmongGoodOnesAreDroppedAndCounted) {
  const fs::path dir = test::freshTempDir();
  std::string text;
  for (const Vec3f& p : test::fibonacciSpherePoints(400)) text += fmt::format("{} {} {}\n", p.x(), p.y(), p.z());
  text += "nan 0 0\n";
  test::writeBytes(dir / "some_nan.xyz", text);
  const auto result = ingest(dir / "some_nan.xyz", dir / "out");
  ASSERT_EQ(result.exitCode, 0) << result.output;
  std::ifstream in(dir / "out" / "ingest.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["cleaning"][0]["name"], "drop_non_finite");
  EXPECT_EQ(json["cleaning"][0]["removed"], 1);
  EXPECT_EQ(json["counts"]["points_out"], 400);
}

TEST(IngestCommand, NonNumericTokenInAscii) { expectRejected("word.xyz", "0 0 0\n1 one 1\n", "'one'"); }

TEST(IngestCommand, WrongMagic) { expectRejected("magic.ply", "plx\nformat ascii 1.0\n", "magic"); }

TEST(IngestCommand, UnsupportedExtension) { expectRejected("scan.dat", "LASF", "unsupported extension"); }

TEST(IngestCommand, KnownFormatWithoutReaderSaysWhatToExport) {
  expectRejected("scan.ptx", "PTX", "Leica PTX files have no reader in apo: export the scan as PLY, LAS or XYZ");
}

TEST(IngestCommand, DirectoryAsInput) {
  const fs::path dir = test::freshTempDir();
  fs::create_directories(dir / "scan.ply");
  const auto result = ingest(dir / "scan.ply", dir / "out");
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("is a directory"));
}

TEST(IngestCommand, MissingPath) {
  const fs::path dir = test::freshTempDir();
  const auto result = ingest(dir / "absent.pcd", dir / "out");
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr((dir / "absent.pcd").string()));
  EXPECT_THAT(result.output, HasSubstr("no such file"));
}

TEST(IngestCommand, BadUsageExitsOne) {
  EXPECT_EQ(test::runCommand(test::apoExecutable().string() + " ingest").exitCode, 1);
  EXPECT_EQ(test::runCommand(test::apoExecutable().string() + " ingest a.ply -o x --voxel=-2").exitCode, 1);
  EXPECT_EQ(test::runCommand(test::apoExecutable().string() + " frobnicate").exitCode, 1);
}

TEST(IngestCommand, HelpDocumentsExitCodes) {
  const auto result = test::runCommand(test::apoExecutable().string() + " --help");
  EXPECT_EQ(result.exitCode, 0);
  EXPECT_THAT(result.output, HasSubstr("0 success, 1 bad usage"));
  EXPECT_THAT(result.output, HasSubstr("2 bad input"));
  EXPECT_THAT(result.output, HasSubstr("3 internal error"));
}

TEST(IngestCommand, InputIsNeverModified) {
  const fs::path dir = test::freshTempDir();
  std::string text;
  for (const Vec3f& p : test::fibonacciSpherePoints(300)) text += fmt::format("{} {} {}\n", p.x(), p.y(), p.z());
  test::writeBytes(dir / "in.xyz", text);
  const auto before = fs::last_write_time(dir / "in.xyz");
  ASSERT_EQ(ingest(dir / "in.xyz", dir / "out").exitCode, 0);
  std::ifstream in(dir / "in.xyz", std::ios::binary);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), text);
  EXPECT_EQ(fs::last_write_time(dir / "in.xyz"), before);
}

}  // namespace
}  // namespace apo
