#include "ingest/ingest.h"
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

test::CommandResult simplify(const fs::path& input, const fs::path& outDir, const std::string& extra) {
  return test::runCommand(fmt::format("{} simplify '{}' -o '{}' {}", test::apoExecutable().string(), input.string(),
                                      outDir.string(), extra));
}

TEST(SimplifyCommand, BunnyTo3000Faces) {
  const fs::path out = test::freshTempDir();
  const auto result = simplify(test::datasetPath("cgal/meshes/bunny00.off"), out, "--faces 3000");
  ASSERT_EQ(result.exitCode, 0) << result.output;
  std::ifstream in(out / "simplify.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["faces"]["in"], 75408);
  EXPECT_NEAR(json["faces"]["out"].get<double>(), 3000.0, 30.0);
  EXPECT_LT(json["distance_to_input"]["hausdorff"].get<double>(), 0.02);
  auto m = readScan(out / "m.ply");
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->triangles.size(), json["faces"]["out"].get<std::size_t>());
  EXPECT_EQ(m->points.normals.size(), m->points.size());
}

TEST(SimplifyCommand, PointCloudIsBadInput) {
  const fs::path dir = test::freshTempDir();
  test::writeBytes(dir / "p.xyz", "0 0 0\n1 0 0\n0 1 0\n");
  const auto result = simplify(dir / "p.xyz", dir / "out", "--faces 10");
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("needs a triangle mesh"));
}

TEST(SimplifyCommand, FacesAndRatioTogetherIsUsage) {
  const fs::path dir = test::freshTempDir();
  EXPECT_EQ(simplify(dir / "m.ply", dir / "out", "--faces 10 --ratio 0.5").exitCode, 1);
}

}  // namespace
}  // namespace apo
