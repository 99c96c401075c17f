// Golden files (tests/golden/, docs/testing.md): a small committed input, the
// outputs the stages made of it when the files were last regenerated on
// purpose, and a byte-for-byte comparison that names the first differing
// byte and the field it belongs to. Regenerate with
//   APO_UPDATE_GOLDEN=1 build/golden_tests
// and review `git diff tests/golden` before committing.
//
// v1/ holds the .apo of format version 1: whatever later versions write, the
// v1 file must stay readable with the same normals (ReadsTheV1Apo). v4/
// holds one of format version 4 (two-sided leaves, leaves and internal nodes
// showing m's normal), read the same way (ReadsTheV4Apo). n3t/ holds
// N^3-trees, .n3t version 1 (BakeGivesTheGoldenN3Trees).
#include "core/file_io.h"
#include "format/format.h"
#include "ingest/ingest.h"
#include "pipeline/bake_seams.h"
#include "reconstruct/reconstruct.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/bake/thin_shell.h"
#include "tests/test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <optional>
#include <sstream>

namespace apo {
namespace {
namespace fs = std::filesystem;

const fs::path kGolden = fs::path(APO_SOURCE_DIR) / "tests" / "golden";
const fs::path kCurrent = kGolden / "v1";  // the format version the tools write now

bool updating() {
  const char* update = std::getenv("APO_UPDATE_GOLDEN");
  return update != nullptr && std::string(update) == "1";
}

// The stages' settings for the golden outputs: small, so the files are.
SimplifyOptions goldenSimplify() {
  SimplifyOptions options;
  options.targetFaces = 200;
  return options;
}
// The paper's threshold with no budget: the tree of format version 1's
// golden file, unchanged since it was written.
BakeOptions goldenBake() {
  BakeOptions options;
  options.coarseDepth = 3;
  options.maxDepth = 7;
  options.budget = 0;
  options.error = 0.05;
  return options;
}

// Where in a PLY our writer makes (ingest.h writePly: binary little endian,
// fixed-size vertex properties, faces as a uchar count and int indices) a
// byte lies: a header line, a vertex's property, or a face.
std::string plyField(const std::string& bytes, std::size_t offset) {
  const std::size_t headerEnd = bytes.find("end_header\n");
  if (headerEnd == std::string::npos) return "no PLY header";
  const std::size_t bodyStart = headerEnd + std::string("end_header\n").size();
  std::istringstream header(bytes.substr(0, bodyStart));
  std::string line;
  std::size_t lineNumber = 0, lineStart = 0, vertices = 0, vertexBytes = 0;
  std::vector<std::pair<std::string, std::size_t>> properties;  // name, first byte within the vertex
  bool inVertex = false;
  while (std::getline(header, line)) {
    ++lineNumber;
    if (offset >= lineStart && offset <= lineStart + line.size()) return fmt::format("header line {}: '{}'", lineNumber, line);
    lineStart += line.size() + 1;
    std::istringstream words(line);
    std::string word, type, name;
    words >> word;
    if (word == "element") {
      words >> name;
      inVertex = name == "vertex";
      if (inVertex) words >> vertices;
    } else if (word == "property" && inVertex) {
      words >> type >> name;
      properties.emplace_back(name, vertexBytes);
      vertexBytes += type == "uchar" ? 1 : type == "double" ? 8 : 4;
    }
  }
  const std::size_t body = offset - bodyStart;
  if (body < vertices * vertexBytes) {
    const std::size_t within = body % vertexBytes;
    std::string property = "?";
    for (const auto& [name, start] : properties)
      if (within >= start) property = name;
    return fmt::format("vertex {}, property {}", body / vertexBytes, property);
  }
  return fmt::format("face {} (13 bytes each: count and three indices)", (body - vertices * vertexBytes) / 13);
}

// The line holding a byte of a text file (its key, for JSON).
std::string textLine(const std::string& bytes, std::size_t offset) {
  const std::size_t start = bytes.rfind('\n', offset == 0 ? 0 : offset - 1);
  const std::size_t from = start == std::string::npos || offset == 0 ? 0 : start + 1;
  const std::size_t end = bytes.find('\n', offset);
  const std::size_t line = static_cast<std::size_t>(std::count(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(from), '\n')) + 1;
  return fmt::format("line {}: '{}'", line, bytes.substr(from, end == std::string::npos ? std::string::npos : end - from));
}

using FieldOf = std::string (*)(const std::string&, std::size_t);

// Compares fresh output bytes with the golden file (or rewrites it when
// updating), failing with the first differing byte and its field.
void expectGolden(const std::string& fresh, const fs::path& golden, FieldOf fieldOf) {
  if (updating()) {
    ASSERT_TRUE(writeFileAtomically(golden, fresh).ok()) << golden;
    return;
  }
  auto expected = readFileBytes(golden);
  ASSERT_TRUE(expected.ok()) << expected.error().message << " (APO_UPDATE_GOLDEN=1 writes it)";
  if (fresh == *expected) return;
  const auto mismatch = std::mismatch(fresh.begin(), fresh.end(), expected->begin(), expected->end());
  const std::size_t at = static_cast<std::size_t>(mismatch.first - fresh.begin());
  const std::string& longer = fresh.size() >= expected->size() ? fresh : *expected;
  ADD_FAILURE() << golden.filename() << " differs from the golden file (" << fresh.size() << " bytes made, "
                << expected->size() << " expected) first at byte " << at << ", in "
                << fieldOf(longer, std::min(at, longer.size() - 1))
                << ". If the change is meant, regenerate: APO_UPDATE_GOLDEN=1 build/golden_tests";
}

std::string apoField(const std::string& bytes, std::size_t offset) { return describeApoFileByte(bytes, offset); }

std::string plyBytes(const Scan& mesh) {
  const fs::path path = test::freshTempDir() / "mesh.ply";
  EXPECT_TRUE(writePly(path, mesh).ok());
  return readFileBytes(path).value();
}

std::string apoBytes(const ApoTexture& texture) {
  const fs::path path = test::freshTempDir() / "scan.apo";
  EXPECT_TRUE(writeApoFile(path, texture).ok());
  return readFileBytes(path).value();
}

// bake.json without what changes from run to run: seconds and peak memory.
std::string bakeJsonWithoutTimings(const BakeReport& report) {
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(bakeReportJson(report));
  json.erase("seconds");
  json.erase("peak_memory_bytes");
  return json.dump(2) + "\n";
}

class Golden : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The input is the bumpy sphere of tests/bake/bumpy_sphere.h, written once.
    if (updating() && !fs::exists(kGolden / "input.ply")) {
      ASSERT_TRUE(writePly(kGolden / "input.ply", test::BumpySphere().mesh(3)).ok());
    }
    auto input = readScan(kGolden / "input.ply");
    ASSERT_TRUE(input.ok()) << input.error().message;
    input_ = new Scan(std::move(input).value());
  }
  static void TearDownTestSuite() { delete input_; }
  static Scan* input_;
};
Scan* Golden::input_ = nullptr;

TEST_F(Golden, SimplifyGivesTheGoldenM) {
  auto m = simplifyMesh(*input_, test::checked(goldenSimplify()));
  ASSERT_TRUE(m.ok()) << m.error().message;
  expectGolden(plyBytes(m->mesh), kCurrent / "m.ply", plyField);
}

TEST_F(Golden, BakeGivesTheGoldenApoAndReport) {
  auto m = readScan(kCurrent / "m.ply");
  ASSERT_TRUE(m.ok()) << m.error().message;
  auto bake = bakeApo(*input_, *m, test::checked(goldenBake()));
  ASSERT_TRUE(bake.ok()) << bake.error().message;
  expectGolden(apoBytes(bake->texture), kCurrent / "scan.apo", apoField);
  expectGolden(bakeJsonWithoutTimings(bake->report), kCurrent / "bake.json", textLine);
}

// The default refinement (a byte budget, refined globally) with a budget
// small enough to stop it: the order of splits, pinned.
TEST_F(Golden, BakeWithABudgetGivesTheGoldenApo) {
  auto m = readScan(kCurrent / "m.ply");
  ASSERT_TRUE(m.ok()) << m.error().message;
  BakeOptions options = goldenBake();
  options.budget = 6000;
  options.error = 0.0;
  auto bake = bakeApo(*input_, *m, test::checked(options));
  ASSERT_TRUE(bake.ok()) << bake.error().message;
  EXPECT_EQ(bake->report.refinement.stoppedBy, "budget");
  EXPECT_LE(bake->texture.texels.size() + 128, options.budget);
  expectGolden(apoBytes(bake->texture), kCurrent / "budget.apo", apoField);
}

// A thin part under a budget: two-sided leaves and nodes showing m, so
// format version 4, written from a generated input (the thin shell of
// tests/bake/thin_shell.h).
struct ThinShellInput {
  test::ThinShell shell;
  Scan detail = shell.mesh(24, true), coarse = shell.mesh(4, false);
};

TEST_F(Golden, BakeWithTwoSidedLeavesGivesTheGoldenV4Apo) {
  const ThinShellInput in;
  BakeOptions options = goldenBake();
  options.error = 0.0;
  options.budget = 16000;
  auto bake = bakeApo(in.detail, in.coarse, test::checked(options));
  ASSERT_TRUE(bake.ok()) << bake.error().message;
  EXPECT_GT(bake->texture.twoSidedLeaves, 0u);
  const std::string bytes = apoBytes(bake->texture);
  EXPECT_EQ(bytes[8], 4) << "format version";
  expectGolden(bytes, kGolden / "v4" / "thin_shell.apo", apoField);
}

// The N^3-trees (docs/n3tree-format.md) of the golden bake (N = 2) and of
// the thin shell's (N = 4: two-sided leaves, cells showing m), version 1 of
// the .n3t file; read back, they walk to what they were built from.
std::string n3tField(const std::string& bytes, std::size_t offset) {
  constexpr std::size_t kHeaderBytes = 136;
  if (offset < kHeaderBytes) return fmt::format("the header, byte {} (docs/n3tree-format.md)", offset);
  return fmt::format("the payload, byte {} (cell {}, channel {})", offset - kHeaderBytes, (offset - kHeaderBytes) / 4,
                     "RGBA"[(offset - kHeaderBytes) % 4]);
}

std::string n3tBytes(const N3Tree& tree) {
  const fs::path path = test::freshTempDir() / "scan.n3t";
  EXPECT_TRUE(writeN3TreeFile(path, tree).ok());
  return readFileBytes(path).value();
}

TEST_F(Golden, BakeGivesTheGoldenN3Trees) {
  auto m = readScan(kCurrent / "m.ply");
  ASSERT_TRUE(m.ok()) << m.error().message;
  BakeOptions options = goldenBake();
  options.layout = TextureLayout::N3Tree;
  auto bake = bakeApo(*input_, *m, test::checked(options));
  ASSERT_TRUE(bake.ok() && bake->n3tree) << (bake.ok() ? "no tree" : bake.error().message);
  expectGolden(n3tBytes(*bake->n3tree), kGolden / "n3t" / "scan_n2.n3t", n3tField);

  const ThinShellInput in;
  BakeOptions thin = goldenBake();
  thin.error = 0.0;
  thin.budget = 16000;
  thin.layout = TextureLayout::N3Tree;
  thin.n3Size = 4;
  auto shell = bakeApo(in.detail, in.coarse, test::checked(thin));
  ASSERT_TRUE(shell.ok() && shell->n3tree) << (shell.ok() ? "no tree" : shell.error().message);
  EXPECT_GT(shell->n3tree->twoSidedLeaves, 0u);
  EXPECT_TRUE(shell->n3tree->defersToCoarse || shell->n3tree->coarseAtInternalNodes);
  expectGolden(n3tBytes(*shell->n3tree), kGolden / "n3t" / "thin_shell_n4.n3t", n3tField);
  for (const char* name : {"scan_n2.n3t", "thin_shell_n4.n3t"}) {
    auto read = readN3TreeFile(kGolden / "n3t" / name);
    ASSERT_TRUE(read.ok()) << read.error().message;
  }
  // The golden N = 2 tree walks to the golden APO's normals at the input's vertices.
  auto golden = readN3TreeFile(kGolden / "n3t" / "scan_n2.n3t");
  auto apo = readApoFile(kCurrent / "scan.apo");
  ASSERT_TRUE(golden.ok() && apo.ok());
  for (const Vec3f& p : input_->points.positions) {
    const Vec3f unit = apo->transform.toUnit(p);
    const Lookup expected = lookupTexture(*apo, unit);
    const N3Lookup actual = lookupN3Tree(*golden, unit);
    // Where the APO's grid cell is empty, the tree still has the ancestors' averages.
    if (!expected.found) continue;
    ASSERT_TRUE(actual.found);
    ASSERT_EQ(actual.normal, expected.normal) << p.transpose();
  }
}

// Normals of the v4 golden at points of both sheets of m, given m's normal
// there, as decoded when it was written.
TEST_F(Golden, ReadsTheV4Apo) {
  auto texture = readApoFile(kGolden / "v4" / "thin_shell.apo");
  ASSERT_TRUE(texture.ok()) << texture.error().message;
  const ThinShellInput in;
  std::string text;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j)
      for (int side = 0; side < 2; ++side) {
        const Vec3f unit = texture->transform.toUnit(in.shell.coarsePoint(0.05f * i, 0.05f * j, side));
        const Vec3f m = in.shell.coarseNormal(side);
        const Lookup plain = lookupTexture(*texture, unit, 255, m), filtered = lookupTextureFiltered(*texture, unit, m);
        text += fmt::format("{} {} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", plain.found ? 1 : 0,
                            plain.twoSided ? 2 : plain.coarse ? 1 : 0, plain.normal.x(), plain.normal.y(),
                            plain.normal.z(), filtered.normal.x(), filtered.normal.y(), filtered.normal.z());
      }
  EXPECT_NE(text.find(" 2 "), std::string::npos) << "some points on two-sided leaves";
  expectGolden(text, kGolden / "v4" / "lookups.txt", textLine);
}

// Normals of the v1 golden at fixed world points, as decoded when it was
// written: any later reader must find the same.
std::string lookupsOf(const ApoTexture& texture, const Scan& points) {
  std::string text;
  for (const Vec3f& p : points.points.positions) {
    const Vec3f unit = texture.transform.toUnit(p);
    const Lookup plain = lookupTexture(texture, unit), filtered = lookupTextureFiltered(texture, unit);
    text += fmt::format("{} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", plain.found ? 1 : 0, plain.normal.x(),
                        plain.normal.y(), plain.normal.z(), filtered.normal.x(), filtered.normal.y(), filtered.normal.z());
  }
  return text;
}

TEST_F(Golden, ReadsTheV1Apo) {
  auto texture = readApoFile(kGolden / "v1" / "scan.apo");
  ASSERT_TRUE(texture.ok()) << texture.error().message;
  // The input's vertices lie on M, where the APO has its normals.
  expectGolden(lookupsOf(*texture, *input_), kGolden / "v1" / "lookups.txt", textLine);
}

}  // namespace
}  // namespace apo
