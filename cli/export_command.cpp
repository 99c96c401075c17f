// `apo export RUNDIR -o asset.glb`: a finished `apo run` folder as a glTF 2.0
// binary: m with a tangent-space normal map on packed per-triangle patches,
// filled from the APO's filtered lookup (docs/export.md).
#include "cli/command_support.h"
#include "core/image_io.h"
#include "export/export.h"
#include "format/format.h"
#include "ingest/ingest.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fstream>
#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct ExportCommand {
  fs::path runDir, output;
  std::uint32_t mapSize = 1024;
  int gutter = 2;
};

// The run's manifest, which must say the run succeeded.
Result<nlohmann::json> finishedManifest(const fs::path& runDir) {
  const fs::path path = runDir / "manifest.json";
  std::ifstream in(path, std::ios::binary);
  if (!in) return badInput("{}: no manifest.json: not an apo run folder", runDir.string());
  const nlohmann::json manifest = nlohmann::json::parse(in, nullptr, false);
  if (manifest.is_discarded() || !manifest.is_object())
    return badInput("{}: not valid JSON (a manifest cut short?)", path.string());
  const auto status = manifest.find("status");
  if (status == manifest.end() || !status->is_string() || *status != "succeeded")
    return badInput("{}: the run did not succeed (status {}): export needs a finished run", path.string(),
                    status == manifest.end() ? "missing" : status->dump());
  return manifest;
}

// The origin to take off m's coordinates when m.ply was written in the
// scan's own (world) coordinates; the .apo and the GLB are local.
Vec3f localOffset(const nlohmann::json& manifest) {
  const auto georeference = manifest.find("georeference");
  if (georeference == manifest.end() || !georeference->is_object() || georeference->value("meshes", "") != "world")
    return Vec3f::Zero();
  const auto& origin = (*georeference)["origin"];
  if (!origin.is_array() || origin.size() != 3) return Vec3f::Zero();
  return Vec3f(origin[0].get<float>(), origin[1].get<float>(), origin[2].get<float>());
}

std::string extrasJson(const nlohmann::json& manifest, const PatchAtlas& atlas, const NormalMap& map) {
  nlohmann::ordered_json extras;
  extras["apo"] = {{"layout", "patches"},
                   {"source", "apo"},
                   {"map", {map.width, map.height}},
                   {"gutter", atlas.gutter},
                   {"texels_per_unit", atlas.texelsPerUnit},
                   {"used_share", atlas.usedShare},
                   {"texels_without_answer", map.texelsWithoutAnswer}};
  if (const auto georeference = manifest.find("georeference"); georeference != manifest.end())
    extras["georeference"] = {{"origin", (*georeference).value("origin", nlohmann::json::array({0, 0, 0}))},
                              {"meaning", "scan file coordinates = origin + glTF coordinates"}};
  return extras.dump();
}

int runExport(const ExportCommand& command) {
  auto manifest = finishedManifest(command.runDir);
  if (!manifest) return reportFailure(manifest.error());
  auto texture = readApoFile(command.runDir / "scan.apo");
  if (!texture) return reportFailure(texture.error());
  auto coarse = readScan(command.runDir / "m.ply");
  if (!coarse) return reportFailure(coarse.error());
  if (!coarse->isMesh()) return reportFailure(badInput("{}: m has no triangles", (command.runDir / "m.ply").string()));
  const Vec3f offset = localOffset(*manifest);
  for (Vec3f& p : coarse->points.positions) p -= offset;

  auto atlas = packTrianglePatches(*coarse, command.mapSize, command.mapSize, command.gutter);
  if (!atlas) return reportFailure(aboutInput(command.runDir / "m.ply", atlas.error()));
  const GltfMesh mesh = patchMesh(*coarse, *atlas);
  const ApoTexture& apo = *texture;
  const NormalMap map = bakeTangentNormalMap(mesh, *atlas, [&apo](const Vec3f& point, const Vec3f& coarseNormal) {
    const Lookup found = lookupTextureFiltered(apo, apo.transform.toUnit(point), coarseNormal);
    return found.found ? found.normal : Vec3f::Zero();
  });
  auto png = encodePng8(map.width, map.height, 3, map.rgb);
  if (!png) return reportFailure(png.error());
  const std::string glb = glbBytes(mesh, *png, fmt::format("apo {}", APO_VERSION), extrasJson(*manifest, *atlas, map));
  if (Status s = writeFileAtomically(command.output, glb); !s.ok()) return reportFailure(s.error());
  spdlog::info("export: {} triangles, {} x {} normal map ({} KiB PNG, {:.0f}% of texels in patches), {} KiB -> {}",
               coarse->triangles.size(), map.width, map.height, png->size() >> 10, 100.0 * atlas->usedShare,
               glb.size() >> 10, command.output.string());
  return kExitSuccess;
}

}  // namespace

void addExportCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<ExportCommand>();
  CLI::App* sub = app.add_subcommand(
      "export", "A finished run as a glTF 2.0 binary: m with a tangent-space normal map made from the APO, no UV unwrap");
  sub->add_option("rundir", command->runDir, "The folder of a finished apo run (manifest.json, m.ply, scan.apo)")->required();
  sub->add_option("-o,--out", command->output, "The GLB file to write")->required();
  sub->add_option("--map-size", command->mapSize, "The normal map's texels per side")
      ->check(CLI::Range(16, 16384))
      ->capture_default_str();
  sub->add_option("--gutter", command->gutter, "Texels kept free round each triangle's patch")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runExport(*command); }); });
}

}  // namespace apo::cli
