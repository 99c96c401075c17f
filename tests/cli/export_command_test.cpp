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

#include <cstring>
#include <fstream>
#include <random>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb_image.h>

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

// ---- The scan's colours as the base colour map ---------------------------

// A smooth colour of position on the unit-radius bumpy sphere.
Eigen::Vector3d paint(const Vec3f& p) {
  return Eigen::Vector3d(127.5 + 100.0 * p.x(), 127.5 + 100.0 * p.y() * p.z(), 127.5 - 90.0 * p.z());
}

// A GLB read back by the spec's layout: its JSON, its BIN chunk, the float
// attributes of its one primitive, and a texture decoded by stb_image.
struct ReadGlb {
  nlohmann::json json;
  std::string bin;
  std::vector<float> attribute(const char* name) const {
    const auto& accessor = json["accessors"][json["meshes"][0]["primitives"][0]["attributes"][name].get<int>()];
    const auto& view = json["bufferViews"][accessor["bufferView"].get<int>()];
    std::vector<float> values(view["byteLength"].get<std::size_t>() / 4);
    std::memcpy(values.data(), bin.data() + view["byteOffset"].get<std::size_t>(), values.size() * 4);
    return values;
  }
  struct Image {
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgb;
  };
  Image texture(int index) const {
    const auto& view = json["bufferViews"][json["images"][json["textures"][index]["source"].get<int>()]["bufferView"].get<int>()];
    Image image;
    int channels = 0;
    unsigned char* pixels = stbi_load_from_memory(
        reinterpret_cast<const unsigned char*>(bin.data() + view["byteOffset"].get<std::size_t>()),
        view["byteLength"].get<int>(), &image.width, &image.height, &channels, 3);
    if (pixels != nullptr) image.rgb.assign(pixels, pixels + std::size_t(image.width) * image.height * 3);
    stbi_image_free(pixels);
    return image;
  }
};

ReadGlb readGlb(const fs::path& path) {
  const std::string bytes = *readFileBytes(path);
  std::uint32_t jsonLength = 0;
  std::memcpy(&jsonLength, bytes.data() + 12, 4);
  return {nlohmann::json::parse(bytes.substr(20, jsonLength)), bytes.substr(20 + jsonLength + 8)};
}

// A coloured mesh scan: apo run's GLB carries its colours as the material's
// base colour, on the normal map's patches, as a viewer samples them (the
// PNG decoded by stb_image, bilinear at interpolated UVs) within a few
// levels of the paint; the Khronos validator accepts the file; a run on one
// thread and `apo export` of the run folder write the same bytes; --no-color
// leaves the colour out.
TEST(ExportColours, AColouredScansColoursBecomeTheBaseColourMap) {
  const fs::path dir = test::freshTempDir();
  Scan scan = test::BumpySphere().mesh(4);
  for (const Vec3f& p : scan.points.positions) {
    const Eigen::Vector3d c = paint(p);
    scan.points.colors.push_back({static_cast<std::uint8_t>(std::lround(c.x())), static_cast<std::uint8_t>(std::lround(c.y())),
                                  static_cast<std::uint8_t>(std::lround(c.z()))});
  }
  ASSERT_TRUE(writePly(dir / "painted.ply", scan).ok());
  const auto run = apo(fmt::format("run '{}' -o '{}' --faces 300 --size 64 --views 2 --frames 1 --map-size 256",
                                   (dir / "painted.ply").string(), (dir / "run").string()));
  ASSERT_EQ(run.exitCode, 0) << run.output;
  const fs::path glb = dir / "run" / "asset.glb";
  const ReadGlb read = readGlb(glb);
  const auto& pbr = read.json["materials"][0]["pbrMetallicRoughness"];
  ASSERT_TRUE(pbr.contains("baseColorTexture")) << pbr.dump();
  const ReadGlb::Image image = read.texture(pbr["baseColorTexture"]["index"]);
  ASSERT_EQ(image.width, 256);
  const std::vector<float> positions = read.attribute("POSITION"), uvs = read.attribute("TEXCOORD_0");
  std::mt19937 random(5);
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t f = 0; f < positions.size() / 9; ++f) {
    const std::array<float, 3> w = test::randomBarycentrics(random);
    Vec3f point = Vec3f::Zero();
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();
    for (std::size_t k = 0; k < 3; ++k) {
      point += w[k] * Vec3f(positions[9 * f + 3 * k], positions[9 * f + 3 * k + 1], positions[9 * f + 3 * k + 2]);
      uv += w[k] * Eigen::Vector2f(uvs[6 * f + 2 * k], uvs[6 * f + 2 * k + 1]);
    }
    const double x = uv.x() * image.width - 0.5, y = uv.y() * image.height - 0.5;
    const auto x0 = static_cast<std::size_t>(std::floor(x)), y0 = static_cast<std::size_t>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    const Eigen::Vector3d wanted = paint(point);
    for (int c = 0; c < 3; ++c) {
      const auto at = [&](std::size_t tx, std::size_t ty) { return double(image.rgb[3 * (ty * image.width + tx) + c]); };
      const double sampled = (1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) +
                             (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1);
      sum += std::abs(sampled - wanted[c]);
      ++count;
    }
  }
  // m lies within about 1% of the radius of the painted surface, and the
  // paint moves about 100 levels per radius: a few levels at most.
  EXPECT_LT(sum / count, 3.0);

  const auto manifest = nlohmann::json::parse(*readFileBytes(dir / "run" / "manifest.json"));
  EXPECT_EQ(manifest["results"]["export"]["base_color"]["source"], "scan colours");
  const nlohmann::json report = khronosReport(glb);
  EXPECT_EQ(report["errors"], 0) << report["messages"].dump();
  EXPECT_EQ(report["warnings"], 0) << report["messages"].dump();
  EXPECT_EQ(report["infos"], 0) << report["messages"].dump();

  // On one thread, the same bytes (the maps are filled on every core).
  const auto single = apo(fmt::format("run '{}' -o '{}' --faces 300 --size 64 --views 2 --frames 1 --map-size 256 --threads 1",
                                      (dir / "painted.ply").string(), (dir / "run1").string()));
  ASSERT_EQ(single.exitCode, 0) << single.output;
  EXPECT_EQ(*readFileBytes(dir / "run1" / "asset.glb"), *readFileBytes(glb));

  const fs::path exported = dir / "exported.glb";
  ASSERT_EQ(apo(fmt::format("export '{}' -o '{}' --map-size 256", (dir / "run").string(), exported.string())).exitCode, 0);
  EXPECT_EQ(*readFileBytes(exported), *readFileBytes(glb));
  const fs::path plain = dir / "plain.glb";
  ASSERT_EQ(apo(fmt::format("export '{}' -o '{}' --map-size 256 --no-color", (dir / "run").string(), plain.string())).exitCode,
            0);
  EXPECT_FALSE(readGlb(plain).json["materials"][0]["pbrMetallicRoughness"].contains("baseColorTexture"));
  EXPECT_LT(fs::file_size(plain), fs::file_size(glb));
}

}  // namespace
}  // namespace apo
