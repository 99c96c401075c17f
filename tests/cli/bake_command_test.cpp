// `apo bake` and `apo lookup` through the binary: outputs, repeatability
// across thread counts, and the bad-input cases with their exit codes.
#include "bake/bake.h"
#include "format/format.h"
#include "ingest/ingest.h"
#include "pipeline/bake_seams.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

test::CommandResult apo(const std::string& arguments) { return test::runApo(arguments); }

// M (a bumpy sphere) and m (an icosphere) as files.
struct Inputs {
  fs::path dir = test::freshTempDir();
  fs::path detail = dir / "M.ply";
  fs::path coarse = dir / "m.ply";

  Inputs() {
    EXPECT_TRUE(writePly(detail, test::BumpySphere().mesh(5)).ok());
    EXPECT_TRUE(writePly(coarse, test::makeIcosphere(2)).ok());
  }
};

std::string bakeArguments(const Inputs& in, const fs::path& out, const std::string& extra = "") {
  return fmt::format("bake --detail '{}' --coarse '{}' -o '{}' --coarse-depth 3 --max-depth 7 {}", in.detail.string(),
                     in.coarse.string(), out.string(), extra);
}

// Each default is written once, in the options struct: --help reads it there.
TEST(BakeCommand, HelpShowsTheOptionStructsDefaults) {
  const auto bake = apo("bake --help");
  ASSERT_EQ(bake.exitCode, 0) << bake.output;
  ASSERT_EQ(BakeOptions{}.budget, std::uint64_t{3} << 20);
  EXPECT_THAT(bake.output, HasSubstr("...]=3MiB\n"));
  EXPECT_THAT(bake.output, HasSubstr("{apo,n3tree}=apo\n"));
  const auto reconstruct = apo("reconstruct --help");
  EXPECT_THAT(reconstruct.output, HasSubstr("scale-space}=auto\n"));
}

// A bad option fails before any file is read (here M does not exist).
TEST(BakeCommand, BadOptionIsAUsageErrorBeforeAnyInputIsRead) {
  const fs::path dir = test::freshTempDir();
  const auto result = apo(fmt::format("bake --detail '{0}/absent.ply' --coarse '{0}/absent.ply' -o '{0}/out' --samples 0",
                                      dir.string()));
  EXPECT_EQ(result.exitCode, 1) << result.output;
  EXPECT_THAT(result.output, HasSubstr("--samples must be in [1, 64], got 0"));
}

TEST(BakeCommand, WritesTheApoItsPngAndReport) {
  const Inputs in;
  const fs::path out = in.dir / "out";
  const auto result = apo(bakeArguments(in, out));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  auto texture = readApoFile(out / "scan.apo");
  ASSERT_TRUE(texture.ok()) << texture.error().message;
  std::ifstream json(out / "bake.json");
  const auto report = nlohmann::json::parse(json);
  EXPECT_EQ(report["format_version"], 2);
  EXPECT_EQ(report["refinement"]["budget_bytes"], 3u << 20);  // the default
  EXPECT_EQ(report["refinement"]["stopped_by"], "converged");  // a small sphere does not need 3 MiB
  EXPECT_EQ(report["texture"]["width"], texture->width);
  EXPECT_EQ(report["nodes"]["leaves"], texture->leafNodes);
  EXPECT_EQ(report["detail"]["kind"], "mesh");
  EXPECT_TRUE(fs::file_size(out / "texture.png") > 0);
}

TEST(BakeCommand, SameBytesWithOneOrTwoThreads) {
  const Inputs in;
  ASSERT_EQ(apo(bakeArguments(in, in.dir / "one", "--threads 1")).exitCode, 0);
  ASSERT_EQ(apo(bakeArguments(in, in.dir / "two", "--threads 2")).exitCode, 0);
  for (const char* file : {"scan.apo", "texture.png"})
    EXPECT_EQ(test::runCommand(fmt::format("cmp '{}' '{}'", (in.dir / "one" / file).string(), (in.dir / "two" / file).string()))
                  .exitCode,
              0)
        << file;
}

// apo restarts itself with glibc's huge-page tunable (cli/main.cpp) unless
// the caller set it: where the memory lies must not change a byte.
TEST(BakeCommand, SameBytesOnHugePagesOrNot) {
  const Inputs in;
  ASSERT_EQ(apo(bakeArguments(in, in.dir / "huge")).exitCode, 0);
  const auto small = test::runCommand(fmt::format("GLIBC_TUNABLES=glibc.malloc.hugetlb=0 {} {}", test::apoExecutable().string(),
                                                  bakeArguments(in, in.dir / "small")));
  ASSERT_EQ(small.exitCode, 0) << small.output;
  for (const char* file : {"scan.apo", "texture.png"})
    EXPECT_EQ(test::runCommand(fmt::format("cmp '{}' '{}'", (in.dir / "huge" / file).string(), (in.dir / "small" / file).string()))
                  .exitCode,
              0)
        << file;
}

TEST(LookupCommand, GivesTheBakedNormalPerPointAndZeroOutside) {
  const Inputs in;
  const fs::path out = in.dir / "out";
  ASSERT_EQ(apo(bakeArguments(in, out)).exitCode, 0);
  // Points on m near the +z bump's flank, and one far outside the octree.
  const test::BumpySphere shape;
  std::vector<Vec3f> points = {Vec3f(0.3f, 0.0f, 0.93f).normalized() * 0.99f, Vec3f(0.0f, 0.25f, -0.95f).normalized() * 0.99f};
  test::writeBytes(in.dir / "points.xyz", fmt::format("{} {} {}\n{} {} {}\n5 5 5\n", points[0].x(), points[0].y(),
                                                     points[0].z(), points[1].x(), points[1].y(), points[1].z()));
  const std::string lookup = fmt::format("lookup '{}' '{}' -o '{}'", (out / "scan.apo").string(),
                                         (in.dir / "points.xyz").string(), (in.dir / "normals.xyz").string());
  // Where m alone is closer to M than a leaf, the leaf shows m's normal
  // (format version 3): the lookup needs m then, and says so.
  const auto withoutM = apo(lookup);
  ASSERT_TRUE(readApoFile(out / "scan.apo")->defersToCoarse);
  EXPECT_EQ(withoutM.exitCode, 1);
  EXPECT_THAT(withoutM.output, HasSubstr("--coarse"));
  const auto result = apo(lookup + fmt::format(" --coarse '{}'", in.coarse.string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  std::ifstream normals(in.dir / "normals.xyz");
  for (const Vec3f& p : points) {
    Vec3f n;
    normals >> n.x() >> n.y() >> n.z();
    EXPECT_NEAR(n.norm(), 1.0f, 1e-4f);
    EXPECT_LT(std::acos(std::min(1.0f, n.dot(shape.normal(p)))), 0.05f) << "at " << p.transpose();  // < 3 degrees
  }
  Vec3f outside;
  normals >> outside.x() >> outside.y() >> outside.z();
  EXPECT_EQ(outside, Vec3f::Zero());
}

// --filter: the filtered lookup the report and the accuracy figures use,
// exactly (as text to 9 significant digits), so outside tools can check them.
TEST(LookupCommand, FilterGivesTheFilteredLookupOfTheReport) {
  const Inputs in;
  const fs::path out = in.dir / "out";
  ASSERT_EQ(apo(bakeArguments(in, out)).exitCode, 0);
  std::vector<Vec3f> points;
  std::string xyz;
  for (const Vec3f& d : test::fibonacciSpherePoints(200)) {
    points.push_back(0.99f * d);
    xyz += fmt::format("{:.9g} {:.9g} {:.9g}\n", points.back().x(), points.back().y(), points.back().z());
  }
  test::writeBytes(in.dir / "points.xyz", xyz);
  const auto texture = readApoFile(out / "scan.apo");
  ASSERT_TRUE(texture.ok());
  const auto m = readScan(in.coarse);
  ASSERT_TRUE(m.ok());
  const auto coarseNormals = coarseNormalsAt(*m, points);
  ASSERT_TRUE(coarseNormals.ok());
  for (const bool filtered : {true, false}) {
    const fs::path normalsPath = in.dir / (filtered ? "filtered.xyz" : "plain.xyz");
    const auto result = apo(fmt::format("lookup '{}' '{}' -o '{}' --coarse '{}' {}", (out / "scan.apo").string(),
                                        (in.dir / "points.xyz").string(), normalsPath.string(), in.coarse.string(),
                                        filtered ? "--filter" : ""));
    ASSERT_EQ(result.exitCode, 0) << result.output;
    std::ifstream normals(normalsPath);
    std::size_t differing = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3f& p = points[i];
      Vec3f n;
      normals >> n.x() >> n.y() >> n.z();
      const Vec3f unit = texture->transform.toUnit(p);
      const Lookup expected = lookupTextureFiltered(*texture, unit, (*coarseNormals)[i]);
      ASSERT_TRUE(expected.found);
      if (filtered) {
        EXPECT_LT((n - expected.normal).norm(), 1e-6f) << p.transpose();
      } else {
        EXPECT_LT((n - lookupTexture(*texture, unit, 255, (*coarseNormals)[i]).normal).norm(), 1e-6f) << p.transpose();
        differing += (n - expected.normal).norm() > 1e-3f;
      }
    }
    if (!filtered) {
      EXPECT_GT(differing, points.size() / 2);  // the two walks do differ
    }
  }
  const auto both = apo(fmt::format("lookup '{}' '{}' -o '{}' --filter --depth 3", (out / "scan.apo").string(),
                                    (in.dir / "points.xyz").string(), (in.dir / "x.xyz").string()));
  EXPECT_EQ(both.exitCode, 1);
  EXPECT_THAT(both.output, HasSubstr("--depth"));
}

TEST(BakeCommand, BadInputsGiveClearErrors) {
  const Inputs in;
  test::writeBytes(in.dir / "cloud.xyz", "0 0 0\n1 0 0\n0 1 0\n");
  auto result = apo(fmt::format("bake --detail '{}' --coarse '{}' -o '{}'", in.detail.string(),
                                (in.dir / "cloud.xyz").string(), (in.dir / "o1").string()));
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("must be a triangle mesh"));
  result = apo(fmt::format("bake --detail '{}' --coarse '{}' -o '{}'", (in.dir / "cloud.xyz").string(),
                           in.coarse.string(), (in.dir / "o2").string()));
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("normals"));
  result = apo(bakeArguments(in, in.dir / "o3", "--max-depth 2"));
  EXPECT_EQ(result.exitCode, 1);
  EXPECT_THAT(result.output, HasSubstr("--max-depth"));
  result = apo(bakeArguments(in, in.dir / "o4", "--normal-encoding rgb"));
  EXPECT_EQ(result.exitCode, 1);
}

TEST(LookupCommand, CorruptApoIsBadInput) {
  const Inputs in;
  const fs::path out = in.dir / "out";
  ASSERT_EQ(apo(bakeArguments(in, out)).exitCode, 0);
  std::string bytes;
  {
    std::ifstream file(out / "scan.apo", std::ios::binary);
    std::stringstream buffer;
    buffer << file.rdbuf();
    bytes = buffer.str();
  }
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5A);
  test::writeBytes(in.dir / "corrupt.apo", bytes);
  test::writeBytes(in.dir / "points.xyz", "0 0 1\n");
  const auto result = apo(fmt::format("lookup '{}' '{}' -o '{}'", (in.dir / "corrupt.apo").string(),
                                      (in.dir / "points.xyz").string(), (in.dir / "n.xyz").string()));
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("corrupt.apo"));
  EXPECT_FALSE(fs::exists(in.dir / "n.xyz"));
}

}  // namespace
}  // namespace apo
