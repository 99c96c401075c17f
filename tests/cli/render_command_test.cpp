// `apo render` through the binary: the files of each view and render.json,
// an .apo baked around another m refused, and a machine without OSMesa.
#include "bake/bake.h"
#include "ingest/ingest.h"
#include "tests/bake/bumpy_sphere.h"
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

struct Baked {
  fs::path dir = test::freshTempDir();
  Baked() {
    EXPECT_TRUE(writePly(dir / "M.ply", test::BumpySphere().mesh(5)).ok());
    EXPECT_TRUE(writePly(dir / "m.ply", test::makeIcosphere(2)).ok());
    const auto baked = test::runCommand(fmt::format("{} bake --detail '{}' --coarse '{}' -o '{}' --max-depth 8",
                                                    test::apoExecutable().string(), (dir / "M.ply").string(),
                                                    (dir / "m.ply").string(), dir.string()));
    EXPECT_EQ(baked.exitCode, 0) << baked.output;
  }
  test::CommandResult render(const fs::path& coarse, const std::string& extra) const {
    return test::runCommand(fmt::format("{} render --apo '{}' --coarse '{}' -o '{}' --size 96 --views 3 {}",
                                        test::apoExecutable().string(), (dir / "scan.apo").string(), coarse.string(),
                                        (dir / "render").string(), extra));
  }
};

TEST(RenderCommand, WritesEveryViewsImagesAndTheMetrics) {
  const Baked baked;
  const auto result = baked.render(baked.dir / "m.ply", fmt::format("--detail '{}'", (baked.dir / "M.ply").string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  for (int view = 0; view < 3; ++view)
    for (const char* file : {"reference.png", "baseline.png", "apo.png", "apo_error.png", "reference_normals.pfm",
                             "baseline_normals.pfm", "apo_normals.pfm"})
      EXPECT_TRUE(fs::exists(baked.dir / "render" / fmt::format("view{:02d}_{}", view, file))) << view << " " << file;
  EXPECT_EQ(fs::file_size(baked.dir / "render" / "view00_apo_normals.pfm"), 96u * 96u * 12u + std::string("PF\n96 96\n-1.0\n").size());
  std::ifstream in(baked.dir / "render" / "render.json");
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["views"].size(), 3u);
  EXPECT_GT(json["overall"]["apo"]["pixels"].get<int>(), 1000);
  EXPECT_LT(json["overall"]["apo"]["mean"].get<double>(), json["overall"]["baseline"]["mean"].get<double>());
}

TEST(RenderCommand, AnApoBakedAroundAnotherMIsBadInput) {
  const Baked baked;
  ASSERT_TRUE(writePly(baked.dir / "other.ply", test::makeTorus(1.0f, 0.3f, 24, 12)).ok());
  const auto result = baked.render(baked.dir / "other.ply", "");
  EXPECT_EQ(result.exitCode, 2);
  EXPECT_THAT(result.output, HasSubstr("baked around another coarse mesh"));
  EXPECT_FALSE(fs::exists(baked.dir / "render" / "render.json"));
}

TEST(RenderCommand, WithoutOsMesaItExitsThreeNamingTheLibraryAndWritesNothing) {
  const Baked baked;
  const auto result = test::runCommand(
      fmt::format("APO_OSMESA_LIBRARY=/nonexistent/libOSMesa.so.8 {} render --apo '{}' --coarse '{}' -o '{}' --size 96",
                  test::apoExecutable().string(), (baked.dir / "scan.apo").string(), (baked.dir / "m.ply").string(),
                  (baked.dir / "render").string()));
  EXPECT_EQ(result.exitCode, 3) << result.output;
  EXPECT_THAT(result.output, HasSubstr("/nonexistent/libOSMesa.so.8"));
  EXPECT_THAT(result.output, HasSubstr("libosmesa6"));
  EXPECT_FALSE(fs::exists(baked.dir / "render" / "render.json"));
  EXPECT_FALSE(fs::exists(baked.dir / "render" / "view00_apo.png"));
}

}  // namespace
}  // namespace apo
