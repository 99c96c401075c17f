// `apo export RUNDIR -o asset.glb`: a finished `apo run` folder as a glTF 2.0
// binary: m with a tangent-space normal map on packed per-triangle patches,
// filled from the APO's filtered lookup, and the scan's colours on the same
// patches (docs/export.md).
#include "cli/command_support.h"
#include "cli/stage_options.h"
#include "export/export.h"
#include "format/format.h"
#include "ingest/ingest.h"
#include "pipeline/bake_seams.h"
#include "pipeline/pipeline.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fstream>
#include <memory>
#include <utility>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct ExportCommand {
  fs::path runDir, output;
  ExportOptions options;
  std::string source = "apo";
  fs::path detail;  // M for --source detail; default: RUNDIR/M.ply, else the run's input mesh
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

// The scan the run read, as its manifest names it (empty if it does not).
fs::path inputPath(const nlohmann::json& manifest) {
  const auto input = manifest.find("input");
  if (input != manifest.end() && input->is_object() && input->contains("path") && (*input)["path"].is_string())
    return fs::path((*input)["path"].get<std::string>());
  return {};
}

// M for --source detail: --detail, else the run's M.ply (point scans), else
// the run's input (a mesh scan is its own M).
fs::path detailPath(const ExportCommand& command, const nlohmann::json& manifest) {
  if (!command.detail.empty()) return command.detail;
  if (fs::exists(command.runDir / "M.ply")) return command.runDir / "M.ply";
  const fs::path input = inputPath(manifest);
  return input.empty() ? command.runDir / "M.ply" : input;
}

// The scan's colours for the base colour map, from the scan file as the
// export stage takes them (moved into the run's frame). A scan file no
// longer where the run read it leaves the GLB without base colour, and
// says so.
Result<ScanColors> scanColors(const ExportCommand& command, const nlohmann::json& manifest,
                              const std::array<double, 3>& origin) {
  if (!command.options.color) return ScanColors{};
  const fs::path input = inputPath(manifest);
  std::error_code missing;
  if (input.empty() || !fs::is_regular_file(input, missing)) {
    spdlog::warn("{}: the run's scan file is not there: the GLB gets no base colour map, even if the scan had colours",
                 input.empty() ? (command.runDir / "manifest.json").string() : input.string());
    return ScanColors{};
  }
  return readScanColors(input, origin);
}

Result<std::unique_ptr<ClosestPointFinder>> detailClosestPoint(const ExportCommand& command, const nlohmann::json& manifest,
                                                               const std::array<double, 3>& origin) {
  const fs::path path = detailPath(command, manifest);
  auto detail = readScan(path);
  if (!detail) return detail.error();
  if (!detail->isMesh())
    return badInput("{}: --source detail needs M as a triangle mesh; the file has only points", path.string());
  moveToFrame(*detail, origin);
  auto finder = meshClosestPoint(std::move(*detail));
  if (!finder) return aboutInput(path, finder.error());
  return finder;
}

// M's interpolated normal at its closest point to each point of m (the
// truth of ../shared/tools/normal_eval.py): the best a map of this layout
// can show, against which the APO's own loss is measured.
NormalField detailNormalField(const ClosestPointFinder& detail) {
  return [&detail](const Vec3f& point, const Vec3f&) {
    const std::optional<SurfacePoint> found = detail.closest(point);
    return found ? found->normal : Vec3f::Zero();
  };
}

int runExport(const ExportCommand& command) {
  const auto options = check(command.options);
  if (!options) return reportFailure(options.error());
  auto manifest = finishedManifest(command.runDir);
  if (!manifest) return reportFailure(manifest.error());
  auto texture = readApoFile(command.runDir / "scan.apo");
  if (!texture) return reportFailure(texture.error());
  const fs::path coarsePath = command.runDir / "m.ply";
  auto coarse = readScan(coarsePath);
  if (!coarse) return reportFailure(coarse.error());
  const std::array<double, 3> origin = originOf(*manifest);
  moveToFrame(*coarse, origin);
  std::unique_ptr<ClosestPointFinder> detail;
  if (command.source == "detail") {
    auto found = detailClosestPoint(command, *manifest, origin);
    if (!found) return reportFailure(found.error());
    detail = std::move(*found);
  }
  const NormalField field = detail ? detailNormalField(*detail) : apoNormalField(*texture);
  auto colors = scanColors(command, *manifest, origin);
  if (!colors) return reportFailure(colors.error());
  const ColorField colorField = nearestScanColors(*colors);
  auto asset = exportGlb(*coarse, field, command.source, *options, origin, fmt::format("apo {}", APO_VERSION),
                         colors->positions.empty() ? nullptr : &colorField);
  if (!asset) return reportFailure(aboutInput(coarsePath, asset.error()));
  if (Status s = writeFileAtomically(command.output, asset->glb); !s.ok()) return reportFailure(s.error());
  const ExportReport& r = asset->report;
  spdlog::info("export: {} triangles, {} x {} normal map ({} KiB PNG, {:.0f}% of texels in patches){}, {} KiB in {:.2f} s -> {}",
               r.triangles, r.mapWidth, r.mapHeight, r.pngBytes >> 10, 100.0 * r.usedShare,
               r.colorPngBytes > 0 ? fmt::format(", base colour map ({} KiB PNG)", r.colorPngBytes >> 10) : "",
               r.glbBytes >> 10, r.seconds, command.output.string());
  return kExitSuccess;
}

}  // namespace

void addExportCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<ExportCommand>();
  CLI::App* sub = app.add_subcommand(
      "export",
      "A finished run as a glTF 2.0 binary: m with a tangent-space normal map made from the APO (and the scan's "
      "colours as its base colour, when it has any), no UV unwrap");
  sub->add_option("rundir", command->runDir, "The folder of a finished apo run (manifest.json, m.ply, scan.apo)")->required();
  sub->add_option("-o,--out", command->output, "The GLB file to write")->required();
  addExportOptions(*sub, command->options);
  sub->add_option("--source", command->source,
                  "Fill the map from the APO's filtered lookup (apo), or straight from M's normal at its closest point "
                  "(detail: to measure what the APO costs)")
      ->check(CLI::IsMember({"apo", "detail"}))
      ->capture_default_str();
  sub->add_option("--detail", command->detail,
                  "M for --source detail (default: RUNDIR/M.ply, else the run's input mesh)");
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runExport(*command); }); });
}

}  // namespace apo::cli
