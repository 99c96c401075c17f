#include "tests/test_support.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

test::CommandResult reconstruct(const fs::path& input, const fs::path& outDir, const std::string& extra = "") {
  return test::runCommand(fmt::format("{} reconstruct '{}' -o '{}' {}", test::apoExecutable().string(), input.string(),
                                      outDir.string(), extra));
}

nlohmann::json readJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(ReconstructCommand, KittenWithEveryMethod) {
  const fs::path kitten = test::datasetPath("cgal/points_3/kitten.xyz");
  for (const char* method : {"poisson", "advancing-front", "scale-space"}) {
    const fs::path out = test::freshTempDir() / method;
    const auto result = reconstruct(kitten, out, std::string("--method ") + method);
    ASSERT_EQ(result.exitCode, 0) << method << "\n" << result.output;
    const auto json = readJson(out / "reconstruct.json");
    EXPECT_EQ(json["method"], method);
    EXPECT_EQ(json["points"]["in"], 5210);
    EXPECT_GT(json["mesh"]["triangles"].get<int>(), 5000) << method;
    EXPECT_LT(json["points_to_mesh"]["mean"].get<double>(), 0.005) << method;
    EXPECT_TRUE(fs::exists(out / "M.ply"));
  }
}

TEST(ReconstructCommand, PointsWithoutNormalsExitTwoAndSayWhatToDo) {
  const fs::path dir = test::freshTempDir();
  std::string text;
  for (const Vec3f& p : test::fibonacciSpherePoints(500)) text += fmt::format("{} {} {}\n", p.x(), p.y(), p.z());
  test::writeBytes(dir / "bare.xyz", text);
  const auto result = reconstruct(dir / "bare.xyz", dir / "out");
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr((dir / "bare.xyz").string()));
  EXPECT_THAT(result.output, HasSubstr("apo ingest"));
}

TEST(ReconstructCommand, UnknownMethodIsUsage) {
  const fs::path dir = test::freshTempDir();
  EXPECT_EQ(reconstruct(dir / "x.ply", dir / "out", "--method marching").exitCode, 1);
}

}  // namespace
}  // namespace apo
