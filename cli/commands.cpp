// `apo ingest`, `apo simulate-scan`, `apo reconstruct`, `apo simplify`: one
// stage each, from files to files.
#include "cli/command_support.h"
#include "cli/stage_options.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/timing.h"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

// A stage's two outputs: its mesh as binary PLY and its report as JSON.
Status writeMeshAndReport(const fs::path& meshPath, const Scan& mesh, const fs::path& reportPath,
                          const std::string& reportJson) {
  APO_RETURN_IF_ERROR(writePly(meshPath, mesh));
  return writeFileAtomically(reportPath, reportJson);
}

struct IngestCommand {
  fs::path input;
  fs::path outDir;
  IngestArguments arguments;
};

int runIngest(IngestCommand command) {
  command.arguments.apply();
  const auto options = check(command.arguments.options);
  if (!options) return reportFailure(options.error());
  auto result = ingestScan(command.input, *options);
  if (!result) return reportFailure(result.error());
  if (Status written = writeIngestOutputs(command.outDir, *result); !written.ok()) return reportFailure(written.error());
  const IngestReport& report = result->report;
  spdlog::info("ingest: {} points, {} triangles, normals {} -> {} in {:.2f} s (peak memory {} MiB)", report.pointsOut,
               report.trianglesOut, report.normalsSource, (command.outDir / "scan.ply").string(), report.totalSeconds,
               peakResidentBytes() >> 20);
  return kExitSuccess;
}

struct SimulateScanCommand {
  fs::path mesh;
  fs::path output;     // PLY: the points (with --normals, their true normals)
  fs::path e57Output;  // E57: one scan per view, with its pose and row/column grid
  fs::path lasOutput, lazOutput;  // LAS 1.2 and LAZ: the points, each with its view as point source id
  SimulateScanOptions options;
};

// The scan as LAS or LAZ when asked for (test data for read-speed benchmarks
// of tens of millions of points).
Status writeLasOutput(const fs::path& path, const Scan& scan, bool compressed) {
  if (path.empty()) return okStatus();
  APO_RETURN_IF_ERROR(writeLas(path, scan, compressed));
  spdlog::info("simulate-scan: {} points as {} -> {}", scan.points.size(), compressed ? "LAZ" : "LAS", path.string());
  return okStatus();
}

int runSimulateScan(const SimulateScanCommand& command) {
  const auto options = check(command.options);
  if (!options) return reportFailure(options.error());
  auto mesh = readScan(command.mesh);
  if (!mesh) return reportFailure(mesh.error());
  if (!mesh->isMesh()) return reportFailure(badInput("{}: simulate-scan needs a triangle mesh, the file has only points", command.mesh.string()));
  if (command.output.empty() && command.e57Output.empty() && command.lasOutput.empty() && command.lazOutput.empty())
    return reportFailure(usageError("simulate-scan: give one or more of -o OUT.ply, --e57 OUT.e57, --las OUT.las and --laz OUT.laz"));
  auto simulated = simulateRangeScan(*mesh, *options);
  if (!simulated) return reportFailure(aboutInput(command.mesh, simulated.error()));
  if (!command.output.empty()) {
    if (Status written = writePly(command.output, simulated->scan); !written.ok()) return reportFailure(written.error());
    spdlog::info("simulate-scan: {} points from {} views -> {}", simulated->scan.points.size(), command.options.views,
                 command.output.string());
  }
  if (!command.e57Output.empty()) {
    if (Status written = writeE57(command.e57Output, simulated->scan); !written.ok()) return reportFailure(written.error());
    spdlog::info("simulate-scan: {} points in {} scans with their poses and grids -> {}", simulated->scan.points.size(),
                 simulated->scan.stations.size(), command.e57Output.string());
  }
  if (Status written = writeLasOutput(command.lasOutput, simulated->scan, false); !written.ok())
    return reportFailure(written.error());
  if (Status written = writeLasOutput(command.lazOutput, simulated->scan, true); !written.ok())
    return reportFailure(written.error());
  return kExitSuccess;
}

struct ReconstructCommand {
  fs::path input;
  fs::path outDir;
  ReconstructOptions options;
};

int runReconstruct(const ReconstructCommand& command) {
  const auto options = check(command.options);
  if (!options) return reportFailure(options.error());
  auto scan = readScan(command.input);
  if (!scan) return reportFailure(scan.error());
  auto reconstruction = reconstructScan(*scan, *options);
  if (!reconstruction) return reportFailure(aboutInput(command.input, reconstruction.error()));
  if (Status written = writeMeshAndReport(command.outDir / "M.ply", reconstruction->mesh, command.outDir / "reconstruct.json",
                                          reconstructReportJson(reconstruction->report));
      !written.ok())
    return reportFailure(written.error());
  const ReconstructReport& report = reconstruction->report;
  spdlog::info("reconstruct: {} -> {} vertices, {} triangles, {} component(s), mean point distance {:.3g} of the diagonal, {:.2f} s",
               report.method, report.quality.vertices, report.quality.triangles, report.quality.components,
               report.pointToMeshMean, report.seconds);
  return kExitSuccess;
}

struct SimplifyCommand {
  fs::path input;
  fs::path outDir;
  SimplifyArguments arguments;
};

int runSimplify(SimplifyCommand command) {
  command.arguments.apply();
  const auto options = check(command.arguments.options);
  if (!options) return reportFailure(options.error());
  auto mesh = readScan(command.input);
  if (!mesh) return reportFailure(mesh.error());
  auto simplified = simplifyMesh(*mesh, *options);
  if (!simplified) return reportFailure(aboutInput(command.input, simplified.error()));
  if (Status written = writeMeshAndReport(command.outDir / "m.ply", simplified->mesh, command.outDir / "simplify.json",
                                          simplifyReportJson(simplified->report));
      !written.ok())
    return reportFailure(written.error());
  const SimplifyReport& report = simplified->report;
  spdlog::info("simplify: {} -> {} faces ({}), Hausdorff {:.3g} and mean {:.3g} of the diagonal, {:.2f} s", report.facesIn,
               report.facesOut, report.policy, report.hausdorff, report.meanDistance, report.seconds);
  return kExitSuccess;
}

}  // namespace

void addReconstructCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<ReconstructCommand>();
  CLI::App* sub = app.add_subcommand("reconstruct", "Reconstruct a dense mesh M from scan points with normals");
  sub->add_option("input", command->input, "Points with oriented normals (e.g. scan.ply from apo ingest), or a mesh")
      ->required();
  sub->add_option("-o,--out", command->outDir, "Output folder (M.ply, reconstruct.json)")->required();
  addReconstructOptions(*sub, command->options);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runReconstruct(*command); }); });
}

void addSimplifyCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<SimplifyCommand>();
  CLI::App* sub = app.add_subcommand("simplify", "Simplify a dense mesh M into a coarse mesh m (edge collapse)");
  sub->add_option("input", command->input, "Triangle mesh M")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder (m.ply, simplify.json)")->required();
  addSimplifyOptions(*sub, command->arguments);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runSimplify(*command); }); });
}

void addIngestCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<IngestCommand>();
  CLI::App* sub = app.add_subcommand("ingest", "Read, validate and clean a scan; estimate and orient normals");
  sub->add_option("input", command->input, "Scan file (" + scanExtensionList() + ")")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder (scan.ply, ingest.json)")->required();
  addIngestOptions(*sub, command->arguments);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runIngest(*command); }); });
}

void addSimulateScanCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<SimulateScanCommand>();
  CLI::App* sub = app.add_subcommand("simulate-scan", "Scan a mesh with a virtual range scanner (test data with known truth)");
  sub->add_option("mesh", command->mesh, "Triangle mesh to scan")->required();
  sub->add_option("-o,--out", command->output, "Output point cloud (.ply)");
  sub->add_option("--e57", command->e57Output,
                  "Also (or instead) write an E57 file: one scan per view, with its position, pose and row/column grid");
  sub->add_option("--las", command->lasOutput, "Also (or instead) write a LAS 1.2 file of the points");
  sub->add_option("--laz", command->lazOutput,
                  "Also (or instead) write a LAZ file of the points (LASzip compressor 2, as LASzip writes it)");
  SimulateScanOptions& o = command->options;
  sub->add_option("--views", o.views, "Scanner positions around the mesh")->capture_default_str();
  sub->add_option("--rays", o.raysPerSide, "Rays per side of each view's square grid")->capture_default_str();
  sub->add_option("--noise", o.rangeNoise, "Range noise std-dev, fraction of the bbox diagonal")->capture_default_str();
  sub->add_option("--misregistration", o.misregistration, "Per-view rigid error, fraction of the diagonal")
      ->capture_default_str();
  sub->add_option("--seed", o.seed, "Random seed")->check(CLI::NonNegativeNumber)->capture_default_str();
  sub->add_flag("--normals", o.withNormals, "Write the true surface normals too");
  sub->add_flag("--mesh", o.asMesh,
                "Write each view's range grid triangulated, all views in one soup of overlapping sheets (as scanner "
                "software writes a set of range scans)");
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runSimulateScan(*command); }); });
}

}  // namespace apo::cli
