#include "cli/commands.h"

#include "core/error.h"
#include "core/timing.h"
#include "ingest/ingest.h"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

int exitCodeFor(const Error& error) {
  switch (error.kind) {
    case ErrorKind::Usage: return kExitUsage;
    case ErrorKind::BadInput: return kExitBadInput;
    case ErrorKind::Internal: return kExitInternal;
  }
  return kExitInternal;
}

int reportFailure(const Error& error) {
  spdlog::error("{}", error.message);
  return exitCodeFor(error);
}

// Runs a command body, turning escaped exceptions into internal errors so
// that no input ever ends in an uncaught exception.
template <class Body>
int guarded(Body&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return reportFailure(internalError("out of memory"));
  } catch (const std::exception& exception) {
    return reportFailure(internalError("unexpected failure: {}", exception.what()));
  }
}

struct IngestCommand {
  fs::path input;
  fs::path outDir;
  std::vector<float> sensor;
  IngestOptions options;
};

int runIngest(const IngestCommand& command) {
  auto result = ingestScan(command.input, command.options);
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
  fs::path output;
  SimulateScanOptions options;
};

int runSimulateScan(const SimulateScanCommand& command) {
  auto mesh = readScan(command.mesh);
  if (!mesh) return reportFailure(mesh.error());
  if (!mesh->isMesh()) return reportFailure(badInput("{}: simulate-scan needs a triangle mesh, the file has only points", command.mesh.string()));
  auto simulated = simulateScan(*mesh, command.options);
  if (!simulated) return reportFailure(simulated.error());
  if (Status written = writePly(command.output, simulated->scan); !written.ok()) return reportFailure(written.error());
  spdlog::info("simulate-scan: {} points from {} views -> {}", simulated->scan.points.size(), command.options.views,
               command.output.string());
  return kExitSuccess;
}

}  // namespace

void addIngestCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<IngestCommand>();
  CLI::App* sub = app.add_subcommand("ingest", "Read, validate and clean a scan; estimate and orient normals");
  sub->add_option("input", command->input, "Scan file (.ply .pcd .xyz .xyzn .pts .pwn .off .obj .stl)")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder (scan.ply, ingest.json)")->required();
  IngestOptions& o = command->options;
  sub->add_flag("!--no-merge-duplicates", o.mergeDuplicates, "Keep exact duplicate points");
  sub->add_flag("--remove-outliers", o.removeOutliers, "Statistical outlier removal (PCL)");
  sub->add_option("--outlier-k", o.outlierNeighbours, "Neighbours for outlier statistics")->capture_default_str();
  sub->add_option("--outlier-std", o.outlierStdDevs, "Keep points within mean + this many std-devs")->capture_default_str();
  sub->add_option("--voxel", o.voxelSize, "Voxel downsampling size in scan units (0: off)")->capture_default_str();
  sub->add_flag("!--no-normals", o.estimateNormals, "Do not estimate normals for point clouds without them");
  sub->add_option("--normal-k", o.normalNeighbours, "Neighbours for normal estimation (0: chosen from the data)")
      ->capture_default_str();
  sub->add_flag("--force-normals", o.forceNormalEstimation, "Re-estimate normals even when the file has them");
  sub->add_option("--sensor", command->sensor,
                   "Scanner position X Y Z: estimated normals face it (overrides the file's viewpoint)")
      ->expected(3);
  sub->callback([command, &exitCode] {
    if (!command->sensor.empty()) command->options.sensorPosition = Vec3f(command->sensor[0], command->sensor[1], command->sensor[2]);
    exitCode = guarded([&] { return runIngest(*command); });
  });
}

void addSimulateScanCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<SimulateScanCommand>();
  CLI::App* sub = app.add_subcommand("simulate-scan", "Scan a mesh with a virtual range scanner (test data with known truth)");
  sub->add_option("mesh", command->mesh, "Triangle mesh to scan")->required();
  sub->add_option("-o,--out", command->output, "Output point cloud (.ply)")->required();
  SimulateScanOptions& o = command->options;
  sub->add_option("--views", o.views, "Scanner positions around the mesh")->capture_default_str();
  sub->add_option("--rays", o.raysPerSide, "Rays per side of each view's square grid")->capture_default_str();
  sub->add_option("--noise", o.rangeNoise, "Range noise std-dev, fraction of the bbox diagonal")->capture_default_str();
  sub->add_option("--misregistration", o.misregistration, "Per-view rigid error, fraction of the diagonal")
      ->capture_default_str();
  sub->add_option("--seed", o.seed, "Random seed")->capture_default_str();
  sub->add_flag("--normals", o.withNormals, "Write the true surface normals too");
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runSimulateScan(*command); }); });
}

}  // namespace apo::cli
