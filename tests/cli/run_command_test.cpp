// `apo run` and `apo batch` through the binary: OUTDIR's files and manifest,
// the config file, bad scans, and a batch that is killed and resumed.
#include "core/file_io.h"
#include "format/format.h"
#include "ingest/ingest.h"
#include "pipeline/pipeline.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// Small, quick settings: every stage runs in well under a second.
constexpr const char* kQuick = "--faces 300 --size 64 --views 2 --frames 1 --map-size 128";

nlohmann::json readJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

std::string fileBytes(const fs::path& path) {
  auto bytes = readFileBytes(path);
  return bytes.ok() ? *bytes : std::string("<missing: ") + path.string() + ">";
}

test::CommandResult apo(const std::string& arguments) { return test::runApo(arguments); }

// A bumpy sphere mesh of 5,120 faces: the input is already M.
fs::path writeMeshScan(const fs::path& path) {
  EXPECT_TRUE(writePly(path, test::BumpySphere().mesh(4)).ok());
  return path;
}

TEST(RunCommand, AMeshScanGoesThroughEveryStageIntoOneFolder) {
  const fs::path dir = test::freshTempDir();
  const fs::path scan = writeMeshScan(dir / "sphere.ply");
  const auto result = apo(fmt::format("run '{}' -o '{}' {}", scan.string(), (dir / "out").string(), kQuick));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  for (const char* file : {"m.ply", "scan.apo", "texture.png", "report.html", "manifest.json", "render/view00_apo.png",
                           "render/view01_reference.png", "render/view01_apo_error.png", "render/render.json"})
    EXPECT_TRUE(fs::exists(dir / "out" / file)) << file;
  EXPECT_FALSE(fs::exists(dir / "out" / "M.ply"));  // the input is M

  const nlohmann::json manifest = readJson(dir / "out" / "manifest.json");
  EXPECT_EQ(manifest["status"], "succeeded");
  EXPECT_EQ(manifest["input"]["sha256"], *sha256OfFile(scan));
  EXPECT_EQ(manifest["input"]["bytes"], fs::file_size(scan));
  const std::vector<std::string> expected = {"succeeded", "skipped", "succeeded", "succeeded",
                                             "succeeded", "succeeded", "succeeded"};
  ASSERT_EQ(manifest["stages"].size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(manifest["stages"][i]["status"], expected[i]) << manifest["stages"][i]["name"];
    if (expected[i] == "succeeded") {
      EXPECT_GT(manifest["stages"][i]["peak_memory_bytes"].get<std::uint64_t>(), 0u);
    }
  }
  EXPECT_EQ(manifest["format_version"], 2);
  EXPECT_EQ(manifest["options"]["simplify"]["faces"], 300);
  EXPECT_EQ(manifest["options"]["render"]["size"], 64);
  // The export stage: the GLB, its figures, its options.
  EXPECT_EQ(manifest["options"]["export"]["map-size"], 128);
  EXPECT_EQ(manifest["options"]["export"]["no-export"], false);
  EXPECT_EQ(manifest["files"]["glb"], "asset.glb");
  EXPECT_TRUE(fs::is_regular_file(dir / "out" / "asset.glb"));
  EXPECT_EQ(manifest["results"]["export"]["map"]["width"], 128);
  EXPECT_EQ(manifest["results"]["export"]["triangles"], 300);
  EXPECT_EQ(manifest["results"]["export"]["glb_bytes"], fs::file_size(dir / "out" / "asset.glb"));
  EXPECT_EQ(manifest["options"]["bake"]["budget"], 3u << 20);  // defaults are recorded too
  EXPECT_EQ(manifest["options"]["bake"]["error"], 0.0);
  EXPECT_EQ(manifest["options"]["bake"]["normal-encoding"], "oct24");
  EXPECT_EQ(manifest["options"]["reconstruct"]["max-points"], nullptr);  // unset: the method's default
  EXPECT_EQ(manifest["results"]["simplify"]["faces"]["out"], 300);
  // Filtered by default here (unfiltered, on this smooth sphere, the APO is
  // about as close as m's own normals: docs/render.md).
  EXPECT_EQ(manifest["options"]["render"]["no-filter"], false);
  EXPECT_EQ(manifest["results"]["render"]["options"]["filtering"], true);
  const auto& overall = manifest["results"]["render"]["overall"];
  EXPECT_LT(overall["apo"]["mean"].get<double>(), overall["baseline"]["mean"].get<double>());
  EXPECT_THAT(fileBytes(dir / "out" / "report.html"), HasSubstr("sphere.ply"));
}

TEST(RunCommand, PointsAreReconstructedAndCanBeMThemselves) {
  const fs::path dir = test::freshTempDir();
  const fs::path mesh = writeMeshScan(dir / "sphere.ply");
  const auto simulated = apo(fmt::format("simulate-scan '{}' -o '{}' --views 6 --rays 80", mesh.string(), (dir / "points.ply").string()));
  ASSERT_EQ(simulated.exitCode, 0) << simulated.output;
  const auto result = apo(fmt::format("run '{}' -o '{}' {} --detail-source points --json", (dir / "points.ply").string(),
                                      (dir / "out").string(), kQuick));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_TRUE(fs::exists(dir / "out" / "M.ply"));
  const nlohmann::json manifest = readJson(dir / "out" / "manifest.json");
  EXPECT_EQ(manifest["stages"][1]["status"], "succeeded");
  EXPECT_EQ(manifest["options"]["detail-source"], "points");
  EXPECT_EQ(manifest["results"]["bake"]["detail"]["kind"], "points");
  // --json: the same manifest on stdout.
  EXPECT_THAT(result.output, HasSubstr(fmt::format("\"sha256\": \"{}\"", manifest["input"]["sha256"].get<std::string>())));
}

// A scan above --max-scan-points with --all-points: ingest keeps voxel
// centroids for M and puts every point in a store, the APO is baked from all
// of them in bricks, and the store goes once the bake is done.
TEST(RunCommand, AllPointsBakesEveryPointOfALargeScanThenRemovesItsStore) {
  const fs::path dir = test::freshTempDir();
  const fs::path mesh = writeMeshScan(dir / "sphere.ply");
  const auto simulated =
      apo(fmt::format("simulate-scan '{}' -o '{}' --views 6 --rays 120", mesh.string(), (dir / "points.ply").string()));
  ASSERT_EQ(simulated.exitCode, 0) << simulated.output;
  const auto result = apo(fmt::format("run '{}' -o '{}' {} --max-scan-points 5000 --all-points --detail-source points",
                                      (dir / "points.ply").string(), (dir / "out").string(), kQuick));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const nlohmann::json manifest = readJson(dir / "out" / "manifest.json");
  const nlohmann::json& ingest = manifest["results"]["ingest"];
  EXPECT_EQ(manifest["options"]["all-points"], true);
  EXPECT_EQ(manifest["options"]["point-normals"], "centroids");
  ASSERT_EQ(ingest["point_store"]["written"], true);
  EXPECT_EQ(ingest["point_store"]["neighbours"], 0);  // each point its nearest centroid's normal
  const auto inFile = ingest["large_scan"]["points_in_file"].get<std::uint64_t>();
  EXPECT_GT(inFile, 5000u);
  EXPECT_EQ(ingest["point_store"]["points"].get<std::uint64_t>(), inFile);
  const nlohmann::json& bake = manifest["results"]["bake"];
  EXPECT_EQ(bake["detail_source"]["points_from"], "store");
  EXPECT_EQ(bake["detail_source"]["points_baked"].get<std::uint64_t>(), inFile);
  EXPECT_EQ(bake["detail"]["primitives"].get<std::uint64_t>(), inFile);
  EXPECT_EQ(bake["bricks"]["depth"], 2);
  EXPECT_FALSE(fs::exists(dir / "out" / ".scratch"));
}

// One scan's run split as `apo slurm SCAN --tasks 2` runs it: the part up to
// m, each pass's two shares, then the merge, which takes ingest, M and m
// from the first part, reads every brick's work back from the journal and
// writes the whole run's bytes.
TEST(RunCommand, ARunSplitAcrossTasksGivesTheWholeRunsBytes) {
  const fs::path dir = test::freshTempDir();
  const fs::path mesh = writeMeshScan(dir / "sphere.ply");
  const fs::path points = dir / "points.ply";
  ASSERT_EQ(apo(fmt::format("simulate-scan '{}' -o '{}' --views 6 --rays 120", mesh.string(), points.string())).exitCode, 0);
  const std::string options = fmt::format("{} --max-scan-points 5000 --all-points --detail-source points", kQuick);
  const auto run = [&](const fs::path& out, const std::string& split) {
    return apo(fmt::format("run '{}' -o '{}' {} --split {}", points.string(), out.string(), options, split));
  };
  const auto whole = run(dir / "whole", "whole");
  ASSERT_EQ(whole.exitCode, 0) << whole.output;

  const fs::path out = dir / "split";
  const auto early = run(out, "records:0/2");
  EXPECT_EQ(early.exitCode, 2) << early.output;
  EXPECT_THAT(early.output, HasSubstr("no prepared run"));
  ASSERT_EQ(run(out, "prepare").exitCode, 0);
  EXPECT_EQ(readJson(out / "manifest.json")["status"], "prepared");
  const auto outOfOrder = run(out, "records:1/2");
  EXPECT_EQ(outOfOrder.exitCode, 2) << outOfOrder.output;
  EXPECT_THAT(outOfOrder.output, HasSubstr("the areas pass must be done by every task"));
  for (const char* pass : {"areas", "records", "samples"})
    for (int task = 0; task < 2; ++task) {
      const auto share = run(out, fmt::format("{}:{}/2", pass, task));
      ASSERT_EQ(share.exitCode, 0) << share.output;
    }
  const nlohmann::json prepared = readJson(out / "manifest.json");
  const auto otherOptions = apo(fmt::format("run '{}' -o '{}' {} --split merge --budget 1MiB", points.string(),
                                            out.string(), options));
  EXPECT_EQ(otherOptions.exitCode, 2) << otherOptions.output;
  EXPECT_THAT(otherOptions.output, HasSubstr("prepared from another input, other options"));
  EXPECT_EQ(readJson(out / "manifest.json"), prepared) << "a refused merge touched the prepared part's manifest";
  // A merge that fails after its bake (the GLB's name taken by a folder)
  // can be run again: the prepared part's files stay until one succeeds.
  fs::create_directories(out / "asset.glb" / "taken");
  const auto failed = run(out, "merge");
  EXPECT_NE(failed.exitCode, 0) << failed.output;
  EXPECT_EQ(readJson(out / "manifest.json")["status"], "failed");
  fs::remove_all(out / "asset.glb");
  const auto merge = run(out, "merge");
  ASSERT_EQ(merge.exitCode, 0) << merge.output;
  const nlohmann::json merged = readJson(out / "manifest.json");
  const nlohmann::json bricks = merged["results"]["bake"]["bricks"];
  EXPECT_EQ(bricks["journal"]["entries_written"], 0) << "the merge did a brick's work again";
  EXPECT_GT(bricks["journal"]["entries_reused"].get<int>(), 64);
  EXPECT_EQ(bricks["points_loaded"], 0);
  // Ingest, reconstruction and simplification ran once: the merge's records
  // of them are the prepared part's, to the time taken.
  EXPECT_EQ(merged["split"]["prepared_stages"], nlohmann::json({"ingest", "reconstruct", "simplify"}));
  for (int stage = 0; stage < 3; ++stage) EXPECT_EQ(merged["stages"][stage], prepared["stages"][stage]) << stage;
  EXPECT_EQ(merged["results"]["ingest"], prepared["results"]["ingest"]);
  EXPECT_EQ(merged["status"], "succeeded");
  for (const char* file : {"m.ply", "M.ply", "scan.apo", "texture.png", "asset.glb"})
    EXPECT_EQ(fileBytes(out / file), fileBytes(dir / "whole" / file)) << file;
  EXPECT_FALSE(fs::exists(out / ".scratch"));
  const auto again = run(out, "merge");
  EXPECT_EQ(again.exitCode, 2) << again.output;
  EXPECT_THAT(again.output, HasSubstr("its merge has succeeded"));
  EXPECT_EQ(run(dir / "bad", "samples:2/2").exitCode, 1);
  EXPECT_EQ(apo(fmt::format("run '{}' -o '{}' {} --split prepare", points.string(), (dir / "nope").string(), kQuick)).exitCode, 1);
}

// Mean angle between the filtered lookup of OUTDIR/scan.apo and the bumpy
// sphere's analytic normals, at the centroids of m's faces.
double apoErrorAgainstShape(const fs::path& outDir, const test::BumpySphere& shape) {
  const auto apo = readApoFile(outDir / "scan.apo");
  const auto coarse = readScan(outDir / "m.ply");
  EXPECT_TRUE(apo.ok() && coarse.ok());
  if (!apo.ok() || !coarse.ok()) return 180.0;
  double sum = 0.0;
  const auto& p = coarse->points.positions;
  for (const Triangle& t : coarse->triangles) {
    const Vec3f at = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
    const Lookup looked = lookupTextureFiltered(*apo, apo->transform.toUnit(at));
    sum += looked.found ? test::degreesBetween(looked.normal, shape.normal(at)) : 180.0;
  }
  return sum / static_cast<double>(coarse->triangles.size());
}

// A dense point scan of fine bumps with exact normals, reconstructed from
// only 1,000 of its points: M smooths the bumps away, the points keep them.
// The default (auto) bakes both, keeps the APO closer to the scan, and says
// so; by the analytic normals, an independent truth, it is the closer one.
// A mesh scan is its own M: nothing to choose.
TEST(RunCommand, TheDefaultDetailSourceKeepsTheScansDetailWhenMLosesIt) {
  const fs::path dir = test::freshTempDir();
  const test::BumpySphere shape = test::BumpySphere::allOver();
  Scan scan;
  for (const Vec3f& d : test::fibonacciSpherePoints(60000)) {
    scan.points.positions.push_back(shape.surfacePoint(d));
    scan.points.normals.push_back(shape.normal(d));
  }
  ASSERT_TRUE(writePly(dir / "points.ply", scan).ok());
  const std::string options = fmt::format("{} --max-points 1000", kQuick);
  for (const char* source : {"auto", "mesh", "points"}) {
    const auto result = apo(fmt::format("run '{}' -o '{}' {} --detail-source {}", (dir / "points.ply").string(),
                                        (dir / source).string(), options, source));
    ASSERT_EQ(result.exitCode, 0) << result.output;
  }
  const nlohmann::json manifest = readJson(dir / "auto" / "manifest.json");
  EXPECT_EQ(manifest["options"]["detail-source"], "auto");
  const nlohmann::json& choice = manifest["results"]["bake"]["detail_source"];
  EXPECT_EQ(choice["chosen"], "points") << choice.dump();
  EXPECT_EQ(manifest["results"]["bake"]["detail"]["kind"], "points");
  const double fromPoints = choice["candidates"]["points"]["against_scan_mean_degrees"];
  const double fromMesh = choice["candidates"]["mesh"]["against_scan_mean_degrees"];
  EXPECT_LT(fromPoints, 0.95 * fromMesh);
  // The kept APO is the one the render stage judged against the scan.
  EXPECT_EQ(manifest["results"]["render"]["against_scan"]["apo_filtered"]["mean"], fromPoints);
  const nlohmann::json meshManifest = readJson(dir / "mesh" / "manifest.json");
  EXPECT_EQ(meshManifest["results"]["bake"]["detail_source"]["chosen"], "mesh");
  EXPECT_EQ(meshManifest["results"]["render"]["against_scan"]["apo_filtered"]["mean"], fromMesh);
  EXPECT_EQ(fileBytes(dir / "auto" / "m.ply"), fileBytes(dir / "mesh" / "m.ply"));
  EXPECT_LT(apoErrorAgainstShape(dir / "auto", shape), 0.8 * apoErrorAgainstShape(dir / "mesh", shape));
  EXPECT_THAT(fileBytes(dir / "auto" / "report.html"), HasSubstr("the APO baked from the points is closer"));
  // The renders compare the APO with what it was baked from: auto, having
  // kept the points' APO, draws the points as the reference, exactly as
  // --detail-source points does, and not M.
  EXPECT_EQ(manifest["results"]["render"]["reference"], "points");
  EXPECT_EQ(readJson(dir / "mesh" / "manifest.json")["results"]["render"]["reference"], "M");
  const fs::path reference = fs::path("render") / "view00_reference_normals.pfm";
  EXPECT_EQ(fileBytes(dir / "auto" / reference), fileBytes(dir / "points" / reference));
  EXPECT_NE(fileBytes(dir / "auto" / reference), fileBytes(dir / "mesh" / reference));

  const fs::path mesh = writeMeshScan(dir / "sphere.ply");
  ASSERT_EQ(apo(fmt::format("run '{}' -o '{}' {}", mesh.string(), (dir / "sphere").string(), kQuick)).exitCode, 0);
  const nlohmann::json sphere = readJson(dir / "sphere" / "manifest.json");
  EXPECT_EQ(sphere["results"]["bake"]["detail_source"]["chosen"], "mesh");
  EXPECT_FALSE(sphere["results"]["bake"]["detail_source"].contains("candidates"));
  EXPECT_EQ(sphere["results"]["render"]["against_scan"], nullptr);
}

std::string afterHeader(const std::string& ply) { return ply.substr(ply.find("end_header\n")); }

// The same scan 5.4e6 units from zero (UTM-like), written in double: read in
// double and moved into a local frame whose origin is the whole shift (its
// centre is near zero), it gives the same m, texture and figures, byte for
// byte, with the origin recorded in the manifest, m.ply and scan.apo.
TEST(RunCommand, AGeoreferencedScanGivesTheSameAssetAsTheScanAtZero) {
  const fs::path dir = test::freshTempDir();
  const Scan sphere = test::BumpySphere().mesh(4);
  ASSERT_TRUE(writePly(dir / "near.ply", sphere).ok());
  Scan far = sphere;
  far.origin = {512000.0, 5403000.0, 300.0};
  ASSERT_TRUE(writePly(dir / "far.ply", far, /*worldCoordinates=*/true).ok());
  ASSERT_THAT(fileBytes(dir / "far.ply"), HasSubstr("property double x"));
  for (const char* name : {"near", "far"}) {
    const auto result = apo(fmt::format("run '{}' -o '{}' {}", (dir / (std::string(name) + ".ply")).string(),
                                        (dir / name).string(), kQuick));
    ASSERT_EQ(result.exitCode, 0) << result.output;
  }
  const nlohmann::json nearManifest = readJson(dir / "near" / "manifest.json");
  const nlohmann::json farManifest = readJson(dir / "far" / "manifest.json");
  EXPECT_EQ(nearManifest["georeference"]["origin"], nlohmann::json::array({0.0, 0.0, 0.0}));
  EXPECT_EQ(farManifest["georeference"]["origin"], nlohmann::json::array({512000.0, 5403000.0, 300.0}));
  EXPECT_EQ(farManifest["georeference"]["meshes"], "local");
  EXPECT_EQ(farManifest["results"]["ingest"]["origin"], farManifest["georeference"]["origin"]);

  const std::string nearM = fileBytes(dir / "near" / "m.ply"), farM = fileBytes(dir / "far" / "m.ply");
  EXPECT_THAT(farM, HasSubstr("comment apo_origin 512000 5403000 300\n"));
  EXPECT_EQ(afterHeader(nearM), afterHeader(farM));
  const std::string nearApo = fileBytes(dir / "near" / "scan.apo"), farApo = fileBytes(dir / "far" / "scan.apo");
  ASSERT_GT(farApo.size(), 160u);
  // Format version 1 without an origin, 2 with one; 3 for both when some
  // leaves show m's own normal, 4 when some are two-sided (the origin in the
  // header's extension, zero for the scan at zero). The same payload after
  // the header either way.
  EXPECT_TRUE(nearApo[8] == 1 || nearApo[8] == 3 || nearApo[8] == 4) << int{nearApo[8]};
  EXPECT_EQ(farApo[8], nearApo[8] == 1 ? 2 : nearApo[8]);
  const auto headerSize = [](const std::string& bytes) { return static_cast<unsigned char>(bytes[16]) | static_cast<unsigned char>(bytes[17]) << 8; };
  EXPECT_EQ(nearApo.substr(headerSize(nearApo)), farApo.substr(headerSize(farApo)));
  EXPECT_EQ(fileBytes(dir / "near" / "texture.png"), fileBytes(dir / "far" / "texture.png"));
  nlohmann::json nearFigures = nearManifest["results"]["render"]["overall"];
  nlohmann::json farFigures = farManifest["results"]["render"]["overall"];
  nearFigures.erase("cost");  // frame times
  farFigures.erase("cost");
  EXPECT_EQ(nearFigures, farFigures);
  for (const char* key : {"nodes", "sampling", "texture"})
    EXPECT_EQ(nearManifest["results"]["bake"][key], farManifest["results"]["bake"][key]) << key;

  // --keep-georeference: m.ply in the file's own coordinates, in double.
  const auto kept = apo(fmt::format("run '{}' -o '{}' {} --keep-georeference", (dir / "far.ply").string(),
                                    (dir / "kept").string(), kQuick));
  ASSERT_EQ(kept.exitCode, 0) << kept.output;
  EXPECT_EQ(readJson(dir / "kept" / "manifest.json")["georeference"]["meshes"], "world");
  const std::string keptM = fileBytes(dir / "kept" / "m.ply");
  EXPECT_THAT(keptM, HasSubstr("property double x"));
  EXPECT_THAT(keptM, Not(HasSubstr("apo_origin")));
  // The GLB: the same asset in the local frame, the origin in its extras;
  // `apo export` of the run whose m.ply is in world coordinates gives the
  // stage's bytes.
  const std::string farGlb = fileBytes(dir / "far" / "asset.glb");
  EXPECT_THAT(farGlb, HasSubstr(R"("georeference":{"origin":[512000.0,5403000.0,300.0])"));
  // The binary chunk (after the 20-byte header and the JSON chunk) is the same.
  const auto binChunk = [](const std::string& glb) {
    const std::size_t json = static_cast<unsigned char>(glb[12]) | static_cast<unsigned char>(glb[13]) << 8 |
                             static_cast<std::size_t>(static_cast<unsigned char>(glb[14])) << 16;
    return glb.substr(20 + json);
  };
  EXPECT_EQ(binChunk(farGlb), binChunk(fileBytes(dir / "near" / "asset.glb")));
  const auto exported = apo(fmt::format("export '{}' -o '{}' --map-size 128", (dir / "kept").string(),
                                        (dir / "kept.glb").string()));
  ASSERT_EQ(exported.exitCode, 0) << exported.output;
  EXPECT_EQ(fileBytes(dir / "kept.glb"), fileBytes(dir / "kept" / "asset.glb"));
  EXPECT_EQ(fileBytes(dir / "kept.glb"), farGlb);
  const auto local = readScan(dir / "near" / "m.ply");
  const auto world = readScan(dir / "kept" / "m.ply");
  ASSERT_TRUE(local.ok() && world.ok());
  ASSERT_EQ(local->points.size(), world->points.size());
  for (std::size_t i = 0; i < local->points.size(); ++i)
    for (int axis = 0; axis < 3; ++axis)
      ASSERT_DOUBLE_EQ(world->origin[axis] + world->points.positions[i][axis],
                       far.origin[axis] + local->points.positions[i][axis]) << i;
}

// Not on a terminal (the test reads a pipe): a log line as each stage
// starts, passes each tenth and ends; --quiet: none of them.
TEST(RunCommand, ProgressIsLogLinesOffATerminalAndQuietSilencesThem) {
  const fs::path dir = test::freshTempDir();
  const fs::path scan = writeMeshScan(dir / "sphere.ply");
  const auto logged = apo(fmt::format("run '{}' -o '{}' {}", scan.string(), (dir / "logged").string(), kQuick));
  ASSERT_EQ(logged.exitCode, 0) << logged.output;
  for (const char* line : {"[1/7] ingest: started", "[2/7] reconstruct: skipped", "[3/7] simplify: 50%",
                           "[4/7] bake: 60%", "[4/7] bake: 100%", "[5/7] render: 50%", "[6/7] export: started",
                           "[7/7] report: started"})
    EXPECT_THAT(logged.output, HasSubstr(line));
  EXPECT_EQ(logged.output.find("\r"), std::string::npos);  // no live line redrawn in place

  const auto quiet = apo(fmt::format("-q run '{}' -o '{}' {}", scan.string(), (dir / "quiet").string(), kQuick));
  ASSERT_EQ(quiet.exitCode, 0) << quiet.output;
  EXPECT_THAT(quiet.output, Not(HasSubstr("ingest: started")));
  EXPECT_THAT(quiet.output, Not(HasSubstr("%")));
  EXPECT_EQ(fileBytes(dir / "quiet" / "scan.apo"), fileBytes(dir / "logged" / "scan.apo"));
}

// On a terminal (script(1) gives the run a pseudo-terminal): one live line
// per stage, redrawn in place, ending with the stage's time and memory.
TEST(RunCommand, ProgressIsALiveLinePerStageOnATerminal) {
  const fs::path dir = test::freshTempDir();
  const fs::path scan = writeMeshScan(dir / "sphere.ply");
  const auto live = test::runCommand(fmt::format("script -qec \"{} run '{}' -o '{}' {}\" /dev/null < /dev/null",
                                                 test::apoExecutable().string(), scan.string(),
                                                 (dir / "out").string(), kQuick));
  ASSERT_EQ(live.exitCode, 0) << live.output;
  EXPECT_NE(live.output.find('\r'), std::string::npos);
  EXPECT_THAT(live.output, HasSubstr("[2/7] reconstruct skipped"));
  EXPECT_THAT(live.output, testing::ContainsRegex("\\[4/7\\] bake +[0-9.]+ s, peak [0-9]+ MiB"));
  EXPECT_THAT(live.output, Not(HasSubstr("ingest: started")));  // not the log lines
}

TEST(RunCommand, AConfigFileHoldsTheSameOptions) {
  const fs::path dir = test::freshTempDir();
  const fs::path scan = writeMeshScan(dir / "sphere.ply");
  test::writeBytes(dir / "apo.toml", "faces = 200\nsize = 48\nviews = 1\nframes = 0\nerror = 0.1\n");
  const auto result = apo(fmt::format("run '{}' -o '{}' --config '{}'", scan.string(), (dir / "out").string(),
                                      (dir / "apo.toml").string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const nlohmann::json manifest = readJson(dir / "out" / "manifest.json");
  EXPECT_EQ(manifest["results"]["simplify"]["faces"]["out"], 200);
  EXPECT_EQ(manifest["options"]["bake"]["error"], 0.1);
  EXPECT_EQ(manifest["results"]["render"]["views"].size(), 1u);
}

TEST(RunCommand, ABrokenScanFailsAtIngestWithItsReasonInTheManifest) {
  const fs::path dir = test::freshTempDir();
  test::writeBytes(dir / "broken.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nend_header\n1 2 3\n");
  const auto result = apo(fmt::format("run '{}' -o '{}' {}", (dir / "broken.ply").string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(result.exitCode, 2) << result.output;
  EXPECT_THAT(result.output, HasSubstr("broken.ply"));
  const nlohmann::json manifest = readJson(dir / "out" / "manifest.json");
  EXPECT_EQ(manifest["status"], "failed");
  EXPECT_EQ(manifest["error"]["stage"], "ingest");
  EXPECT_THAT(manifest["error"]["message"].get<std::string>(), HasSubstr("broken.ply"));
  EXPECT_EQ(manifest["stages"][0]["status"], "failed");
  EXPECT_EQ(manifest["stages"][2]["status"], "not_run");
  EXPECT_FALSE(fs::exists(dir / "out" / "report.html"));
}

TEST(RunCommand, AMissingScanIsBadInput) {
  const fs::path dir = test::freshTempDir();
  const auto result = apo(fmt::format("run '{}' -o '{}'", (dir / "nothing.ply").string(), (dir / "out").string()));
  EXPECT_EQ(result.exitCode, 2) << result.output;
  EXPECT_THAT(result.output, HasSubstr("nothing.ply"));
}

// Every option of every stage is checked before the first stage runs: a bad
// value is bad usage (exit 1) and nothing is written.
TEST(RunCommand, BadOptionValuesFailBeforeAnyStage) {
  const fs::path dir = test::freshTempDir();
  const fs::path scan = writeMeshScan(dir / "sphere.ply");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--faces -5", "--faces"},         // an unsigned option given a negative number
      {"--faces 2", "--faces"},          // below the smallest closed mesh
      {"--error -1", "--error"},         // the bake's threshold, refused before ingest runs
      {"--size 0", "--size"},            // the render's, last of the stages
      {"--max-points -1", "--max-points"},
      {"--normal-k 2", "--normal-k"},
      {"--ratio 1.5", "--ratio"},
  };
  for (const auto& [option, name] : cases) {
    const fs::path out = dir / "out";
    const auto result = apo(fmt::format("run '{}' -o '{}' {}", scan.string(), out.string(), option));
    EXPECT_EQ(result.exitCode, 1) << option << ": " << result.output;
    EXPECT_THAT(result.output, HasSubstr(name)) << option;
    EXPECT_FALSE(fs::exists(out)) << option << ": a stage ran";
  }
  // The same for a batch: refused before any worker starts.
  const auto batch = apo(fmt::format("batch '{}' -o '{}' --error -1", dir.string(), (dir / "batch").string()));
  EXPECT_EQ(batch.exitCode, 1) << batch.output;
  EXPECT_FALSE(fs::exists(dir / "batch"));
}

TEST(Apo, AnUnknownSubcommandNamesTheNearestAndTheList) {
  const auto typo = apo("rnu scan.ply -o out");
  EXPECT_EQ(typo.exitCode, 1) << typo.output;
  EXPECT_THAT(typo.output, HasSubstr("'rnu' is not an apo subcommand; did you mean 'run'?"));
  EXPECT_THAT(typo.output, HasSubstr("ingest, simulate-scan, reconstruct, simplify, bake, lookup, render, run, batch"));
  const auto far = apo("frobnicate");
  EXPECT_EQ(far.exitCode, 1) << far.output;
  EXPECT_THAT(far.output, Not(HasSubstr("did you mean")));
  const auto none = apo("-q");
  EXPECT_EQ(none.exitCode, 1) << none.output;
  EXPECT_THAT(none.output, HasSubstr("a subcommand is required: ingest"));
  EXPECT_EQ(apo("--help").exitCode, 0);
  EXPECT_EQ(apo("--version").exitCode, 0);
}

// ---- apo batch ---------------------------------------------------------------

// Two good scans (one in a subfolder, one with a hostile name), two broken
// files and a file that is not a scan.
fs::path makeScanFolder(const fs::path& dir) {
  const fs::path scans = dir / "scans";
  writeMeshScan(scans / "a.ply");
  EXPECT_TRUE(writePly(scans / "lab 2" / "<img src=x onerror=alert(1)>.ply", test::makeTorus(1.0f, 0.35f, 48, 24)).ok());
  test::writeBytes(scans / "lab 2" / "empty.xyz", "");
  test::writeBytes(scans / "truncated.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n"
                                             "property float y\nproperty float z\nend_header\n\x01\x02");
  test::writeBytes(scans / "notes.txt", "not a scan");
  return scans;
}

// The outputs that must not depend on how often the batch was interrupted.
std::vector<std::string> lastingOutputs(const fs::path& out) {
  std::vector<std::string> files;
  for (const char* scan : {"a.ply", "lab 2/<img src=x onerror=alert(1)>.ply"})
    for (const char* file : {"m.ply", "scan.apo", "texture.png"}) {
      auto digest = sha256OfFile(out / scan / file);
      files.push_back(digest.ok() ? *digest : "missing: " + (out / scan / file).string());
    }
  return files;
}

TEST(BatchCommand, BadScansAreReportedAndTheRestSucceeds) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  const auto result = apo(fmt::format("batch '{}' -o '{}' -j 2 {}", scans.string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(result.exitCode, 2) << result.output;  // not every scan succeeded
  EXPECT_THAT(result.output, HasSubstr("FAILED at ingest"));
  const nlohmann::json summary = readJson(dir / "out" / "summary.json");
  EXPECT_EQ(summary["scans"], 4);  // notes.txt is not a scan
  EXPECT_EQ(summary["succeeded"], 2);
  EXPECT_EQ(summary["failed"], 2);
  EXPECT_EQ(readJson(dir / "out" / "truncated.ply" / "manifest.json")["error"]["stage"], "ingest");
  EXPECT_TRUE(fs::exists(dir / "out" / "lab 2" / "<img src=x onerror=alert(1)>.ply" / "report.html"));
  const std::string index = fileBytes(dir / "out" / "index.html");
  EXPECT_THAT(index, Not(HasSubstr("<img src=x onerror")));
  EXPECT_THAT(index, HasSubstr("truncated.ply"));

  // Rerun: nothing to redo for the two that succeeded; the failed are retried.
  const auto again = apo(fmt::format("batch '{}' -o '{}' -j 2 {}", scans.string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(again.exitCode, 2) << again.output;
  EXPECT_EQ(readJson(dir / "out" / "summary.json")["skipped_up_to_date"], 2);

  // Other options: everything is redone.
  const auto other = apo(fmt::format("batch '{}' -o '{}' -j 2 {} --error 0.1", scans.string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(readJson(dir / "out" / "summary.json")["skipped_up_to_date"], 0) << other.output;
}

TEST(BatchCommand, KilledAtAnyMomentAndRerunItEndsAsIfNeverInterrupted) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  const std::string batch = fmt::format("batch '{}' -o '{}' -j 2 {}", scans.string(), "{}", kQuick);
  const auto clean = apo(fmt::format(fmt::runtime(batch), (dir / "clean").string()));
  ASSERT_EQ(clean.exitCode, 2) << clean.output;

  // SIGKILL after various delays, each rerun continuing what the last left.
  const fs::path out = dir / "killed";
  for (const char* delay : {"0.3", "0.9", "0.2", "1.7", "0.6"})
    test::runCommand(fmt::format("timeout -s KILL {} {} {}", delay, test::apoExecutable().string(),
                                 fmt::format(fmt::runtime(batch), out.string())));
  const auto finished = apo(fmt::format(fmt::runtime(batch), out.string()));
  EXPECT_EQ(finished.exitCode, 2) << finished.output;
  const nlohmann::json summary = readJson(out / "summary.json");
  EXPECT_EQ(summary["succeeded"].get<int>() + summary["skipped_up_to_date"].get<int>(), 2);
  EXPECT_EQ(lastingOutputs(out), lastingOutputs(dir / "clean"));
  for (const char* scan : {"a.ply", "lab 2/<img src=x onerror=alert(1)>.ply"})
    EXPECT_EQ(readJson(out / scan / "manifest.json")["status"], "succeeded") << scan;
}

TEST(BatchCommand, AScanOverItsTimeLimitIsStoppedAndRecorded) {
  const fs::path dir = test::freshTempDir();
  writeMeshScan(dir / "scans" / "a.ply");
  // Every run takes longer than 50 ms (ingest, simplify, bake and render of a 5,120-face mesh).
  const auto result = apo(fmt::format("batch '{}' -o '{}' --scan-timeout 0.05 {}", (dir / "scans").string(),
                                      (dir / "out").string(), kQuick));
  EXPECT_EQ(result.exitCode, 2) << result.output;
  const nlohmann::json manifest = readJson(dir / "out" / "a.ply" / "manifest.json");
  EXPECT_EQ(manifest["status"], "failed");
  EXPECT_THAT(manifest["error"]["message"].get<std::string>(), HasSubstr("longer than --scan-timeout"));
}

// Labs link acquisitions into a batch folder: each output goes under OUTDIR at
// the link's path, and the linked files stay as they were.
TEST(BatchCommand, SymlinkedScansKeepTheirInputsAndWriteUnderOutdir) {
  const fs::path dir = test::freshTempDir();
  const fs::path elsewhere = writeMeshScan(dir / "archive" / "deep" / "a.ply");
  const std::string before = fileBytes(elsewhere);
  fs::create_directories(dir / "scans" / "lab");
  fs::create_symlink(fs::absolute(elsewhere), dir / "scans" / "lab" / "linked.ply");
  const auto result = apo(fmt::format("batch '{}' -o '{}' {}", (dir / "scans").string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(result.exitCode, 0) << result.output;
  EXPECT_TRUE(fs::is_regular_file(elsewhere));
  EXPECT_EQ(fileBytes(elsewhere), before);
  EXPECT_EQ(readJson(dir / "out" / "lab" / "linked.ply" / "manifest.json")["status"], "succeeded");
  EXPECT_FALSE(fs::exists(dir / "archive" / "deep" / "a.ply" / "manifest.json"));
}

// A scan's output folder that apo did not make is never emptied: that scan
// fails, naming it, and the others go on.
TEST(BatchCommand, AFolderInTheWayThatApoDidNotWriteIsLeftAlone) {
  const fs::path dir = test::freshTempDir();
  writeMeshScan(dir / "scans" / "a.ply");
  writeMeshScan(dir / "scans" / "b.ply");
  test::writeBytes(dir / "out" / "a.ply" / "thesis.tex", "years of work");
  const auto result = apo(fmt::format("batch '{}' -o '{}' {}", (dir / "scans").string(), (dir / "out").string(), kQuick));
  EXPECT_EQ(result.exitCode, 2) << result.output;
  EXPECT_THAT(result.output, HasSubstr("a folder that apo did not write"));
  EXPECT_EQ(fileBytes(dir / "out" / "a.ply" / "thesis.tex"), "years of work");
  EXPECT_EQ(readJson(dir / "out" / "b.ply" / "manifest.json")["status"], "succeeded");
}

TEST(BatchCommand, TwoBatchesCannotWriteTheSameFolder) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  const std::string command = fmt::format("{} batch '{}' -o '{}' {}", test::apoExecutable().string(), scans.string(),
                                          (dir / "out").string(), kQuick);
  const auto both = test::runCommand(fmt::format("{{ {} & sleep 0.3; {}; wait; }} 2>&1", command, command));
  EXPECT_THAT(both.output, HasSubstr("another apo batch is writing to this folder"));
}

// Each kind of batch's lock held by util-linux flock(1), as that batch holds it.
TEST(BatchCommand, AWholeBatchAndShardsNeverWriteTogether) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const auto underLock = [&](const char* lockName, const std::string& arguments) {
    return test::runCommand(fmt::format("flock --exclusive '{}' {} batch '{}' -o '{}' {} {}", (out / lockName).string(),
                                        test::apoExecutable().string(), scans.string(), out.string(), kQuick, arguments));
  };
  const auto shardDuringWholeBatch = underLock(".apo-batch.lock", "--shard 0/2");
  EXPECT_EQ(shardDuringWholeBatch.exitCode, 1);
  EXPECT_THAT(shardDuringWholeBatch.output, HasSubstr("another apo batch is writing to this folder without --shard"));
  const auto wholeBatchDuringAShard = underLock(".apo-batch-1-of-2.lock", "");
  EXPECT_EQ(wholeBatchDuringAShard.exitCode, 1);
  EXPECT_THAT(wholeBatchDuringAShard.output, HasSubstr("another apo batch is writing to this folder (a shard: .apo-batch-1-of-2.lock)"));
  const auto sameShardTwice = underLock(".apo-batch-0-of-2.lock", "--shard 0/2");
  EXPECT_EQ(sameShardTwice.exitCode, 1);
  EXPECT_THAT(sameShardTwice.output, HasSubstr("(shard 0/2)"));
  const auto shardBesideAnother = underLock(".apo-batch-1-of-2.lock", "--shard 0/2");
  EXPECT_THAT(shardBesideAnother.output, Not(HasSubstr("another apo batch")));
  EXPECT_TRUE(fs::exists(out / ".apo-shards" / "0-of-2.json"));
  // No shard running: the whole batch runs, though shards' lock files remain.
  const auto wholeBatchAfterShards = apo(fmt::format("batch '{}' -o '{}' {}", scans.string(), out.string(), kQuick));
  EXPECT_THAT(wholeBatchAfterShards.output, Not(HasSubstr("another apo batch")));
  EXPECT_TRUE(fs::exists(out / "index.html"));
}

TEST(Shard, EveryScanInExactlyOneShardAndAddingScansMovesNoOther) {
  std::vector<std::string> paths;
  for (int i = 0; i < 400; ++i) paths.push_back(fmt::format("lab {}/scan_{:03d}.ply", i % 7, i));
  for (int n = 1; n <= 16; ++n) {
    std::vector<int> seen(paths.size(), 0);
    std::vector<int> perShard(n, 0);
    for (int index = 0; index < n; ++index)
      for (std::size_t i = 0; i < paths.size(); ++i)
        if (shardOf(paths[i], n) == index) {
          ++seen[i];
          ++perShard[index];
        }
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), static_cast<long>(paths.size())) << "N " << n;
    for (int count : perShard) EXPECT_NEAR(count, 400.0 / n, 5.0 * std::sqrt(400.0 / n) + 1.0) << "N " << n;
  }
  std::vector<int> before;
  for (const std::string& path : paths) before.push_back(shardOf(path, 8));
  paths.insert(paths.begin() + 17, "lab 3/new scan.ply");
  paths.push_back("zz/last.ply");
  std::vector<int> after;
  for (const std::string& path : paths)
    if (path != "lab 3/new scan.ply" && path != "zz/last.ply") after.push_back(shardOf(path, 8));
  EXPECT_EQ(after, before);
  // The first 8 bytes of SHA-256("a.ply"), big-endian, modulo N (Python's hashlib gives the digest).
  EXPECT_EQ(shardOf("a.ply", 1000), static_cast<int>(0xfc86562d2e574325ull % 1000));
}

TEST(Shard, ParsesIOfNAndRefusesTheRest) {
  auto shard = parseShard("3/8");
  ASSERT_TRUE(shard.ok());
  EXPECT_EQ(shard->index, 3);
  EXPECT_EQ(shard->count, 8);
  for (const char* bad : {"8/8", "0/0", "-1/3", "1", "a/3", "1/b", "/3", "1/", "1/100001"}) {
    const auto refused = parseShard(bad);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_THAT(refused.error().message, HasSubstr("--shard")) << bad;
  }
}

// Shards run apart (here one after the other, and two at once: each holds
// its own lock), then the merge writes the pages: the same scans' outputs as
// one batch, every scan listed, the broken ones once.
TEST(BatchCommand, ShardsThenMergeGiveTheBatchsOutputs) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  ASSERT_EQ(apo(fmt::format("batch '{}' -o '{}' {}", scans.string(), (dir / "one").string(), kQuick)).exitCode, 2);
  const fs::path out = dir / "sharded";
  const std::string shard = fmt::format("{} batch '{}' -o '{}' {} --shard", test::apoExecutable().string(), scans.string(),
                                        out.string(), kQuick);
  const auto both = test::runCommand(fmt::format("{{ {} 0/3 & {} 1/3; wait; }} 2>&1", shard, shard));
  EXPECT_THAT(both.output, Not(HasSubstr("another apo batch")));
  test::runCommand(shard + " 2/3");
  EXPECT_FALSE(fs::exists(out / "index.html"));  // the merge's
  // A shard of an earlier run into the same folder, in 5 shards: not counted.
  const fs::path stale = out / ".apo-shards" / "0-of-5.json";
  ASSERT_TRUE(writeFileAtomically(stale, R"({"shard": "0/5", "scans": 9, "seconds": 100.0})").ok());
  fs::last_write_time(stale, fs::last_write_time(out / ".apo-shards" / "0-of-3.json") - std::chrono::hours(1));
  const auto merged = apo(fmt::format("batch '{}' -o '{}' --merge", scans.string(), out.string()));
  EXPECT_EQ(merged.exitCode, 2) << merged.output;
  const nlohmann::json summary = readJson(out / "summary.json");
  EXPECT_EQ(summary["scans"], 4);
  EXPECT_EQ(summary["succeeded"], 2);
  EXPECT_EQ(summary["failed"], 2);
  ASSERT_EQ(summary["shards"].size(), 3u);
  int scansInShards = 0;
  for (const auto& s : summary["shards"]) scansInShards += s["scans"].get<int>();
  EXPECT_EQ(scansInShards, 4);
  EXPECT_EQ(lastingOutputs(out), lastingOutputs(dir / "one"));
  const std::string index = fileBytes(out / "index.html");
  for (const char* name : {"a.ply", "truncated.ply", "empty.xyz", "&lt;img src=x onerror=alert(1)&gt;.ply"})
    EXPECT_THAT(index, HasSubstr(name));
  std::size_t failedRows = 0;
  for (std::size_t at = index.find("FAILED"); at != std::string::npos; at = index.find("FAILED", at + 1)) ++failedRows;
  EXPECT_EQ(failedRows, 2u);
}

// An executable bash script.
fs::path writeProgram(const fs::path& path, const std::string& body) {
  EXPECT_TRUE(writeFileAtomically(path, "#!/bin/bash\n" + body).ok());
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

TEST(SlurmScripts, OneScansTasksRunTheirShareOfEachPassWithEveryPathAndOptionIntact) {
  const fs::path dir = test::freshTempDir();
  SlurmSettings settings;
  settings.scanDir = dir / "scan of 'lab' $HOME.laz";
  settings.outDir = dir / "out `date`";
  settings.tasks = 5;
  settings.cpusPerTask = 2;
  settings.executable = writeProgram(dir / "fake apo", "for a in \"$@\"; do echo \"[$a]\"; done\n");
  settings.workerArguments = {"--budget", "1MiB", "--config", "a b;'c'.toml"};
  const ScanSplitScripts scripts = scanSplitScripts(settings);
  EXPECT_THAT(scripts.prepare, Not(HasSubstr("--array")));
  EXPECT_THAT(scripts.merge, Not(HasSubstr("--array")));
  const std::string rest = "[--threads]\n[2]\n[--budget]\n[1MiB]\n[--config]\n[a b;'c'.toml]\n[--all-points]\n";
  const auto ran = [&](const std::string& script, const char* name) {
    EXPECT_TRUE(writeFileAtomically(dir / name, script).ok());
    const auto task = test::runCommand(
        fmt::format("SLURM_ARRAY_TASK_ID=3 SLURM_CPUS_PER_TASK=2 bash '{}'", (dir / name).string()));
    EXPECT_EQ(task.exitCode, 0) << task.output;
    return task.output;
  };
  const auto expected = [&](const std::string& split) {
    return fmt::format("[run]\n[{}]\n[-o]\n[{}]\n[--split]\n[{}]\n", settings.scanDir.string(), settings.outDir.string(),
                       split) +
           rest;
  };
  EXPECT_EQ(ran(scripts.prepare, "prepare.sbatch"), expected("prepare"));
  const char* passes[] = {"areas", "records", "samples"};
  for (std::size_t p = 0; p < 3; ++p) {
    EXPECT_THAT(scripts.passes[p], HasSubstr("#SBATCH --array=0-4\n"));
    EXPECT_THAT(scripts.passes[p], HasSubstr("#SBATCH --requeue\n"));
    EXPECT_EQ(scripts.passLogs[p], settings.outDir / "slurm" / fmt::format("{}-%a.log", passes[p]));
    EXPECT_EQ(ran(scripts.passes[p], "pass.sbatch"), expected(fmt::format("{}:3/5", passes[p])));
  }
  EXPECT_EQ(ran(scripts.merge, "merge.sbatch"), expected("merge"));
  // --all-points given is not given twice.
  settings.workerArguments = {"--all-points"};
  EXPECT_EQ(ran(scanSplitScripts(settings).merge, "merge.sbatch"),
            fmt::format("[run]\n[{}]\n[-o]\n[{}]\n[--split]\n[merge]\n[--threads]\n[2]\n[--all-points]\n",
                        settings.scanDir.string(), settings.outDir.string()));
}

TEST(SlurmScripts, EachTaskRunsItsShardWithEveryPathAndOptionIntact) {
  const fs::path dir = test::freshTempDir();
  SlurmSettings settings;
  settings.scanDir = dir / "scans of 'lab' $HOME";
  settings.outDir = dir / "out `date`";
  settings.tasks = 4;
  settings.cpusPerTask = 3;
  settings.partition = "long";
  settings.time = "2:00:00";
  // apo on the nodes, played by a script printing each argument on a line.
  settings.executable = writeProgram(dir / "fake apo", "for a in \"$@\"; do echo \"[$a]\"; done\n");
  settings.workerArguments = {"--faces", "300", "--config", "a b;'c'.toml"};
  const SlurmScripts scripts = slurmScripts(settings);
  EXPECT_THAT(scripts.array, HasSubstr("#SBATCH --array=0-3\n"));
  EXPECT_THAT(scripts.array, HasSubstr("#SBATCH --requeue\n"));
  EXPECT_THAT(scripts.array, HasSubstr("#SBATCH --cpus-per-task=3\n"));
  EXPECT_THAT(scripts.array, HasSubstr("#SBATCH --partition=long\n"));
  EXPECT_THAT(scripts.array, HasSubstr("#SBATCH --time=2:00:00\n"));
  EXPECT_EQ(scripts.arrayLog, settings.outDir / "slurm" / "task-%a.log");
  EXPECT_THAT(scripts.merge, HasSubstr("#SBATCH --cpus-per-task=1\n"));
  EXPECT_THAT(scripts.merge, Not(HasSubstr("--array")));

  // What Slurm runs: bash on each script, with the task's environment.
  ASSERT_TRUE(writeFileAtomically(dir / "array.sbatch", scripts.array).ok());
  ASSERT_TRUE(writeFileAtomically(dir / "merge.sbatch", scripts.merge).ok());
  const auto task = test::runCommand(
      fmt::format("SLURM_ARRAY_TASK_ID=2 SLURM_CPUS_PER_TASK=3 bash '{}'", (dir / "array.sbatch").string()));
  ASSERT_EQ(task.exitCode, 0) << task.output;
  EXPECT_EQ(task.output, fmt::format("[batch]\n[{}]\n[-o]\n[{}]\n[--shard]\n[2/4]\n[--jobs]\n[1]\n[--threads]\n[3]\n"
                                     "[--faces]\n[300]\n[--config]\n[a b;'c'.toml]\n",
                                     settings.scanDir.string(), settings.outDir.string()));
  const auto merge = test::runCommand(fmt::format("bash '{}'", (dir / "merge.sbatch").string()));
  EXPECT_EQ(merge.output,
            fmt::format("[batch]\n[{}]\n[-o]\n[{}]\n[--merge]\n", settings.scanDir.string(), settings.outDir.string()));
}

TEST(SlurmCommand, SubmitsTheArrayThenTheMergeAfterItAndPrintsTheirIds) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  // sbatch, played by a script recording its arguments (call0, call1) and
  // printing "JOBID;CLUSTER" as --parsable does: 41, then 42.
  fs::create_directories(dir / "bin");
  writeProgram(dir / "bin" / "sbatch", fmt::format("n=$(ls '{0}'/call* 2>/dev/null | wc -l)\n"
                                                  "for a in \"$@\"; do echo \"$a\"; done > '{0}'/call$n\n"
                                                  "echo \"$((41 + n));cluster\"\n",
                                                  dir.string()));
  const std::string path = fmt::format("PATH='{}':\"$PATH\"", (dir / "bin").string());
  const auto result = test::runCommand(fmt::format("{} '{}' -q slurm '{}' -o '{}' --tasks 3 --faces 300", path,
                                                   test::apoExecutable().string(), scans.string(), (dir / "out").string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_THAT(result.output, HasSubstr("array job 41 (3 tasks), merge job 42;"));
  const fs::path slurm = dir / "out" / "slurm";
  EXPECT_EQ(fileBytes(dir / "call0"), fmt::format("--parsable\n--output={}\n{}\n", (slurm / "task-%a.log").string(),
                                                  (slurm / "array.sbatch").string()));
  EXPECT_EQ(fileBytes(dir / "call1"), fmt::format("--parsable\n--output={}\n--dependency=afterany:41\n{}\n",
                                                  (slurm / "merge.log").string(), (slurm / "merge.sbatch").string()));
  EXPECT_THAT(fileBytes(slurm / "array.sbatch"), HasSubstr("'--faces' '300'"));
  EXPECT_FALSE(fs::exists(dir / "out" / "index.html"));  // nothing runs until Slurm does

  // sbatch refusing: its own words, a non-zero exit, no merge submitted.
  writeProgram(dir / "bin" / "sbatch", "echo 'sbatch: error: invalid partition specified: gpu' >&2\nexit 1\n");
  const auto refused = test::runCommand(fmt::format("{} '{}' slurm '{}' -o '{}' --tasks 3 --partition gpu", path,
                                                    test::apoExecutable().string(), scans.string(), (dir / "out2").string()));
  EXPECT_NE(refused.exitCode, 0);
  EXPECT_THAT(refused.output, HasSubstr("invalid partition specified: gpu"));
  EXPECT_FALSE(fs::exists(dir / "call2"));
}

TEST(SlurmCommand, DryRunPrintsBothScriptsAndSubmitsNothing) {
  const fs::path dir = test::freshTempDir();
  const fs::path scans = makeScanFolder(dir);
  const auto result = test::runCommand(fmt::format("PATH=/nonexistent '{}' slurm '{}' -o '{}' --tasks 5 --dry-run",
                                                   test::apoExecutable().string(), scans.string(), (dir / "out").string()));
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_THAT(result.output, HasSubstr("#SBATCH --array=0-4"));
  EXPECT_THAT(result.output, HasSubstr("--shard \"$SLURM_ARRAY_TASK_ID/5\""));
  EXPECT_THAT(result.output, HasSubstr("--merge"));
  EXPECT_FALSE(fs::exists(dir / "out" / "slurm"));

  // A value that would break its #SBATCH line is refused before anything is written.
  const auto twoWords = apo(fmt::format("slurm '{}' -o '{}' --tasks 2 --partition 'long --mem=1T' --dry-run",
                                        scans.string(), (dir / "out").string()));
  EXPECT_EQ(twoWords.exitCode, 1) << twoWords.output;
  EXPECT_THAT(twoWords.output, HasSubstr("--partition"));
}

}  // namespace
}  // namespace apo
