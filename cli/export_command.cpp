// `apo export RUNDIR -o asset.glb`: a finished `apo run` folder as a glTF 2.0
// binary: m with a tangent-space normal map on packed per-triangle patches,
// filled from the APO's filtered lookup (docs/export.md).
#include "cli/command_support.h"
#include "cli/stage_options.h"
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
  ExportOptions options;
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

// The scan's local frame origin as the run recorded it: the .apo and the
// GLB are in that frame.
std::array<double, 3> originOf(const nlohmann::json& manifest) {
  const auto found = manifest.find("georeference");
  if (found == manifest.end() || !found->is_object()) return {0.0, 0.0, 0.0};
  const auto& origin = (*found)["origin"];
  if (!origin.is_array() || origin.size() != 3 || !origin[0].is_number() || !origin[1].is_number() || !origin[2].is_number())
    return {0.0, 0.0, 0.0};
  return {origin[0].get<double>(), origin[1].get<double>(), origin[2].get<double>()};
}

int runExport(const ExportCommand& command) {
  if (Status valid = validateExportOptions(command.options); !valid.ok()) return reportFailure(valid.error());
  auto manifest = finishedManifest(command.runDir);
  if (!manifest) return reportFailure(manifest.error());
  auto texture = readApoFile(command.runDir / "scan.apo");
  if (!texture) return reportFailure(texture.error());
  const fs::path coarsePath = command.runDir / "m.ply";
  auto coarse = readScan(coarsePath);
  if (!coarse) return reportFailure(coarse.error());
  // m.ply is local (its header names the origin) or in world coordinates
  // (--keep-georeference), which the reader brings near zero by an origin
  // of its own: either way, into the run's frame, in double.
  const std::array<double, 3> origin = originOf(*manifest);
  const Eigen::Vector3d shift(coarse->origin[0] - origin[0], coarse->origin[1] - origin[1], coarse->origin[2] - origin[2]);
  for (Vec3f& p : coarse->points.positions) p = (p.cast<double>() + shift).cast<float>();
  auto asset = exportApoGlb(*coarse, *texture, command.options, origin, fmt::format("apo {}", APO_VERSION));
  if (!asset) return reportFailure(aboutInput(coarsePath, asset.error()));
  if (Status s = writeFileAtomically(command.output, asset->glb); !s.ok()) return reportFailure(s.error());
  const ExportReport& r = asset->report;
  spdlog::info("export: {} triangles, {} x {} normal map ({} KiB PNG, {:.0f}% of texels in patches), {} KiB in {:.2f} s -> {}",
               r.triangles, r.mapWidth, r.mapHeight, r.pngBytes >> 10, 100.0 * r.usedShare, r.glbBytes >> 10, r.seconds,
               command.output.string());
  return kExitSuccess;
}

}  // namespace

void addExportCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<ExportCommand>();
  CLI::App* sub = app.add_subcommand(
      "export", "A finished run as a glTF 2.0 binary: m with a tangent-space normal map made from the APO, no UV unwrap");
  sub->add_option("rundir", command->runDir, "The folder of a finished apo run (manifest.json, m.ply, scan.apo)")->required();
  sub->add_option("-o,--out", command->output, "The GLB file to write")->required();
  addExportOptions(*sub, command->options);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runExport(*command); }); });
}

}  // namespace apo::cli
