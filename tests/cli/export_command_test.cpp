// `apo export` through the binary: a finished run's GLB passes the Khronos
// glTF-Validator with nothing to report, the same bytes every time; runs
// that did not finish, missing and corrupt files give exit 2 naming them.
#include "core/file_io.h"
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

test::CommandResult apo(const std::string& arguments) { return test::runApo(arguments); }

// A finished run of a bumpy sphere mesh, made once for the suite.
class ExportCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(test::freshTempDir());
    ASSERT_TRUE(writePly(*dir_ / "sphere.ply", test::BumpySphere().mesh(4)).ok());
    const auto run = apo(fmt::format("run '{}' -o '{}' --faces 300 --size 64 --views 2 --frames 1",
                                     (*dir_ / "sphere.ply").string(), (*dir_ / "run").string()));
    ASSERT_EQ(run.exitCode, 0) << run.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path* dir_;
};

fs::path* ExportCommand::dir_ = nullptr;

// What the Khronos glTF-Validator (npm, pinned) says of a file.
nlohmann::json khronosReport(const fs::path& glb) {
  const fs::path source(APO_SOURCE_DIR);
  const fs::path output = glb.string() + ".validator.json";
  const auto status = test::runCommand(fmt::format("node '{}' '{}' > '{}'",
                                                   (source / "tests/export/khronos_validate.mjs").string(),
                                                   glb.string(), output.string()));
  std::ifstream in(output);
  const nlohmann::json report = nlohmann::json::parse(in, nullptr, false);
  EXPECT_EQ(status.exitCode, 0) << status.output << report.dump().substr(0, 300);
  return report;
}

TEST_F(ExportCommand, AFinishedRunBecomesAGlbTheKhronosValidatorAccepts) {
  const fs::path glb = *dir_ / "asset.glb";
  const auto result = apo(fmt::format("export '{}' -o '{}' --map-size 256", (*dir_ / "run").string(), glb.string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const nlohmann::json report = khronosReport(glb);
  ASSERT_TRUE(report.contains("errors")) << report.dump().substr(0, 300);
  EXPECT_EQ(report["errors"], 0) << report["messages"].dump();
  EXPECT_EQ(report["warnings"], 0) << report["messages"].dump();
  EXPECT_EQ(report["infos"], 0) << report["messages"].dump();
  EXPECT_EQ(report["info"]["totalTriangleCount"], 300);
  EXPECT_EQ(report["info"]["resources"][1]["image"]["width"], 256);
  EXPECT_EQ(report["info"]["resources"][1]["image"]["format"], "rgb");

  // Draco-compressed: no error and no warning either (the validator cannot
  // decode Draco and says so as an info; GlbWriter's test decodes it).
  const fs::path draco = *dir_ / "draco.glb";
  ASSERT_EQ(apo(fmt::format("export '{}' -o '{}' --map-size 256 --draco", (*dir_ / "run").string(), draco.string()))
                .exitCode,
            0);
  const nlohmann::json dracoReport = khronosReport(draco);
  EXPECT_EQ(dracoReport["errors"], 0) << dracoReport["messages"].dump();
  EXPECT_EQ(dracoReport["warnings"], 0) << dracoReport["messages"].dump();
  EXPECT_EQ(dracoReport["info"]["totalTriangleCount"], 300);
  EXPECT_LT(fs::file_size(draco), fs::file_size(glb));

  // The same bytes again.
  const fs::path again = *dir_ / "again.glb";
  ASSERT_EQ(apo(fmt::format("export '{}' -o '{}' --map-size 256", (*dir_ / "run").string(), again.string())).exitCode, 0);
  EXPECT_EQ(*readFileBytes(again), *readFileBytes(glb));
}

// --source detail: the map filled from M itself (the run's input mesh here),
// named so in the asset; M as points is refused, naming the file.
TEST_F(ExportCommand, TheMapCanBeFilledFromMItself) {
  const fs::path glb = *dir_ / "detail.glb";
  const auto result = apo(fmt::format("export '{}' -o '{}' --map-size 256 --source detail", (*dir_ / "run").string(),
                                      glb.string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_THAT(*readFileBytes(glb), HasSubstr(R"("source":"detail")"));
  const nlohmann::json report = khronosReport(glb);
  EXPECT_EQ(report["errors"], 0) << report["messages"].dump();
  EXPECT_EQ(report["warnings"], 0) << report["messages"].dump();
  const fs::path fromApo = *dir_ / "from_apo.glb";
  ASSERT_EQ(apo(fmt::format("export '{}' -o '{}' --map-size 256", (*dir_ / "run").string(), fromApo.string())).exitCode, 0);
  EXPECT_NE(*readFileBytes(glb), *readFileBytes(fromApo));

  Scan points = test::BumpySphere().mesh(3);
  points.triangles.clear();
  ASSERT_TRUE(writePly(*dir_ / "points.ply", points).ok());
  const auto refused = apo(fmt::format("export '{}' -o '{}' --source detail --detail '{}'", (*dir_ / "run").string(),
                                       (*dir_ / "refused.glb").string(), (*dir_ / "points.ply").string()));
  EXPECT_EQ(refused.exitCode, 2);
  EXPECT_THAT(refused.output, HasSubstr("points.ply: --source detail needs M as a triangle mesh"));
}

TEST_F(ExportCommand, UnfinishedRunsMissingAndCorruptFilesAreNamed) {
  const fs::path out = *dir_ / "bad.glb";
  const auto exportOf = [&](const fs::path& run) {
    return apo(fmt::format("export '{}' -o '{}'", run.string(), out.string()));
  };
  const auto missing = exportOf(*dir_ / "nowhere");
  EXPECT_EQ(missing.exitCode, 2);
  EXPECT_THAT(missing.output, HasSubstr("nowhere: no manifest.json"));

  // A copy of the run that failed, then one whose .apo is cut short.
  const fs::path copy = *dir_ / "copy";
  fs::copy(*dir_ / "run", copy, fs::copy_options::recursive);
  std::ifstream in(copy / "manifest.json");
  nlohmann::json manifest = nlohmann::json::parse(in);
  in.close();
  manifest["status"] = "failed";
  ASSERT_TRUE(writeFileAtomically(copy / "manifest.json", manifest.dump()).ok());
  const auto failed = exportOf(copy);
  EXPECT_EQ(failed.exitCode, 2);
  EXPECT_THAT(failed.output, HasSubstr("the run did not succeed"));

  manifest["status"] = "succeeded";
  ASSERT_TRUE(writeFileAtomically(copy / "manifest.json", manifest.dump()).ok());
  const std::string apoBytes = *readFileBytes(copy / "scan.apo");
  ASSERT_TRUE(writeFileAtomically(copy / "scan.apo", apoBytes.substr(0, apoBytes.size() / 2)).ok());
  const auto corrupt = exportOf(copy);
  EXPECT_EQ(corrupt.exitCode, 2);
  EXPECT_THAT(corrupt.output, HasSubstr("scan.apo"));
  EXPECT_FALSE(fs::exists(out));

  const auto size = apo(fmt::format("export '{}' -o '{}' --map-size 8", (*dir_ / "run").string(), out.string()));
  EXPECT_NE(size.exitCode, 0);
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace apo
