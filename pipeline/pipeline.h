// pipeline: the whole job on one scan (`apo run`: ingest, reconstruct,
// simplify, bake, render, report) and on a folder of scans (`apo batch`, one
// worker process per scan, resumable), with the manifest each run writes.
// docs/run.md describes OUTDIR, manifest.json and resuming. This is the room
// that wires the stages to their production seams (Embree, FLANN:
// pipeline/bake_seams.h).
#pragma once

#include "bake/bake.h"
#include "core/error.h"
#include "ingest/ingest.h"
#include "pipeline/bake_seams.h"
#include "pipeline/progress.h"
#include "reconstruct/reconstruct.h"
#include "render/render.h"
#include "export/export.h"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string_view>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace apo {

// manifest.json's version: 2 records the options as typed values taken from
// the option structs (version 1 held the command line's strings).
inline constexpr int kManifestFormatVersion = 2;
inline constexpr const char* kRenderFolder = "render";

// A run's stages, in order, as the manifest and the progress lines name them.
inline constexpr std::array<const char*, 7> kRunStages = {"ingest", "reconstruct", "simplify", "bake", "render", "export", "report"};
inline constexpr std::size_t kRunStageCount = kRunStages.size();

// What the APO is baked from. Mesh: the dense mesh M (reconstructed, or the
// input mesh itself), also the reference of the renders. Points: the scan's
// points with their normals, also rendered as the reference. Auto: for a
// point scan, both are baked and the one whose APO is closer to the scan's
// own points (by more than kPointsDetailMargin) is kept, M staying the
// reference; a mesh scan is its own M (docs/run.md, "Detail source").
enum class DetailSource { Auto, Mesh, Points };
std::string detailSourceName(DetailSource source);  // "auto", "mesh", "points"
// Baking from the points must win by this fraction of the mean error: the
// mesh-baked APO also matches the reference renders and is seldom larger.
inline constexpr double kPointsDetailMargin = 0.05;

// The QA report's renders: 512 px, 3 timed frames, filtered (`apo render`
// alone defaults to 1024 px, 5 frames, unfiltered).
inline RenderOptions reportRenderOptions() {
  RenderOptions render;
  render.size = 512;
  render.timedFrames = 3;
  render.filtering = true;
  return render;
}

// Where --all-points takes each point's normal (docs/run.md, "Every point").
enum class PointNormals { Centroids, Fitted };

// Every option of every stage of a run, with their defaults.
struct RunOptions {
  DetailSource detailSource = DetailSource::Auto;
  // M.ply and m.ply in world coordinates (double) rather than the local frame.
  bool keepGeoreference = false;
  // A scan above --max-scan-points: the APO baked from every point (a point
  // store in the output folder, the bake in bricks), not the centroids
  // (docs/run.md, "Every point").
  bool allPoints = false;
  // Every point's normal in the store: its nearest centroid's (Centroids),
  // or a plane fitted to its k nearest points at full density (Fitted).
  PointNormals pointNormals = PointNormals::Centroids;
  IngestOptions ingest;
  ReconstructOptions reconstruct;
  SimplifyOptions simplify;
  BakeOptions bake;
  RenderOptions render = reportRenderOptions();
  ExportOptions exporting;
  // The report's interactive view, viewer.html (--no-viewer: none).
  bool viewer = true;
};

// Every stage's options checked by the stage's own check, so that a bad value
// fails before any stage runs: a Usage error naming the option. The stages'
// parts of the checked options are checked too (core/checked.h, partOf).
template <>
Result<Checked<RunOptions>> check(const RunOptions& options);

// The manifest's "options": every field of every stage's options by its
// command-line name without dashes (the names a --config file uses), typed
// (numbers, booleans, strings; null for unset optional values). Resuming
// compares it.
nlohmann::ordered_json optionsJson(const RunOptions& options);

// Which part of a run (`apo run --split`): the whole, or for `apo slurm`
// on one scan (docs/cluster.md, "One scan across tasks") the part up to m
// and the point store, kept in OUTDIR for the tasks and the merge
// (Prepare), one task's share of a pass of the bake in bricks from them
// (Share), or the rest of the run from them (Merge), which finds the
// bake's journal complete.
struct RunPart {
  enum class Kind { Whole, Prepare, Share, Merge };
  Kind kind = Kind::Whole;
  BrickShare share;  // Kind::Share
};
// "whole", "prepare", PASS:T/N (PASS areas, records or samples; task T of
// N) or "merge"; a Usage error naming the text otherwise.
Result<RunPart> runPartNamed(std::string_view text);

struct RunSettings {
  std::filesystem::path input, outDir;
  Checked<RunOptions> options;
  RunPart part;
};

struct RunOutcome {
  Status status;
  nlohmann::ordered_json manifest;  // as written to OUTDIR/manifest.json
};

// ---- The report's interactive view -------------------------------------------

// M travels whole into viewer.html up to these sizes; beyond, a mesh is
// previewed at kViewerMostTriangles (reconstruct's previewMesh) and points
// are drawn from the finest point-LOD level within kViewerMostPoints
// (docs/report.md, "The viewer"): about 4 and 3.5 MB of base64 at most.
inline constexpr std::size_t kViewerMostTriangles = 100000;
inline constexpr std::size_t kViewerMostPoints = 120000;

// What viewer.html draws: m with the APO, m alone and M (`detail`, may be
// null) as render/ gives them to WebGL2, seen from `views` (the renders'),
// with the render options' mip-mapping and filtering.
Result<ViewerScene> viewerScene(const Scan& coarse, const ApoTexture& apo, const Scan* detail,
                                const std::vector<Camera>& views, const RenderOptions& options);

// The stages in order, recording each in OUTDIR/manifest.json as it ends (a
// killed run leaves one that says "running" and where it stopped); outputs
// are written atomically.
RunOutcome runPipeline(const RunSettings& settings, Progress& progress);

// ---- apo batch ---------------------------------------------------------------

// One of `count` parts of a batch (`--shard index/count`, index from 0):
// the scans whose shardOf is `index`.
struct Shard {
  int index = 0, count = 1;
};
inline constexpr int kMostShards = 100000;

// The shard of a scan, from its own path under SCANDIR (generic form) alone:
// the first 8 bytes of the path's SHA-256, big-endian, modulo `count`. So a
// scan keeps its shard when other scans come or go, on any machine.
int shardOf(std::string_view relativePath, int count);
// "I/N" with 0 <= I < N <= kMostShards; a Usage error naming --shard else.
Result<Shard> parseShard(std::string_view text);

struct BatchSettings {
  std::filesystem::path scanDir, outDir;
  // Only this shard's scans (docs/cluster.md): the shard's own lock and its
  // summary in OUTDIR/.apo-shards/I-of-N.json; index.html and summary.json
  // are left to mergeBatch.
  std::optional<Shard> shard;
  int jobs = 1;              // scans at a time; the cores are shared among them
  int threads = 0;           // each worker's threads; 0: the cores divided among the jobs
  double scanTimeout = 0.0;  // seconds; 0: none
  Checked<RunOptions> options;  // what each scan runs with (resume compares them)
  // The same options as `apo run` arguments, passed to every worker as they
  // are (the worker adds the scan, its output folder and its threads).
  std::vector<std::string> workerArguments;
};

struct BatchSummary {
  std::uint64_t scans = 0, succeeded = 0, failed = 0, upToDate = 0;
  std::uint64_t notProcessed = 0;  // files under scanDir that are not scans apo reads
  double seconds = 0.0;
};

// `apo run` on every scan under scanDir (by extension, recursively, sorted by
// path) in its own process, into outDir/<path under scanDir>/, skipping the
// scans whose manifest records success for the same input, options and tool
// version; then outDir/index.html and summary.json. Every other file under
// scanDir (hidden ones aside) is listed there as not processed, with the
// reason. BadInput when scanDir holds no scan; Usage when another batch holds
// outDir. A failed scan is counted, never an error.
Result<BatchSummary> runBatch(const BatchSettings& settings);

// `apo batch --merge`: index.html and summary.json of OUTDIR from every
// scan's manifest, whichever shard or machine wrote it, with the shards'
// summaries (OUTDIR/.apo-shards/) listed in summary.json. Runs no scan; a
// scan without a manifest counts as failed ("no manifest").
Result<BatchSummary> mergeBatch(const BatchSettings& settings);

// ---- apo slurm ---------------------------------------------------------------

struct SlurmSettings {
  std::filesystem::path scanDir, outDir;  // absolute: the jobs run elsewhere
  int tasks = 1;                           // the array's tasks, each one shard
  std::string partition, time, memory;     // sbatch's; empty: the cluster's default
  int cpusPerTask = 1;
  std::filesystem::path executable;        // apo on the nodes
  std::vector<std::string> workerArguments;  // stage options, passed to every task
};

struct SlurmScripts {
  std::string array, merge;                  // sbatch scripts
  std::filesystem::path arrayLog, mergeLog;  // sbatch --output (%a: the task)
};

// The job array (task I runs `apo batch --shard I/N`, requeued after a node
// failure or preemption) and the merge job (`apo batch --merge`), as bash
// scripts for sbatch; every path and argument single-quoted.
SlurmScripts slurmScripts(const SlurmSettings& settings);

struct SlurmJobs {
  std::string arrayJob, mergeJob;  // Slurm's job ids
};

// `apo slurm SCAN --tasks N` on one scan file (docs/cluster.md, "One scan
// across tasks"), scanDir then naming the file: a prepare job (`apo run
// --split prepare`: up to m and the point store), the bake's three passes
// each a job array of N tasks (`--split PASS:T/N`, requeued after a node
// failure), and the merge (a whole run, finding the store and the bake's
// journal complete), each after the one before (afterany: a pass that
// failed leaves its work to the merge, which does it itself).
struct ScanSplitScripts {
  std::string prepare, merge;
  std::array<std::string, 3> passes;  // areas, records, samples
  std::filesystem::path prepareLog, mergeLog;
  std::array<std::filesystem::path, 3> passLogs;
};
ScanSplitScripts scanSplitScripts(const SlurmSettings& settings);

struct ScanSplitJobs {
  std::string prepareJob, mergeJob;
  std::array<std::string, 3> passJobs;
};
Result<ScanSplitJobs> submitScanSplit(const SlurmSettings& settings);

// Writes the scripts to OUTDIR/slurm/ and submits them: the array, then the
// merge with --dependency=afterany on it. sbatch's own error, named, when it
// refuses.
Result<SlurmJobs> submitSlurm(const SlurmSettings& settings);

// ---- The stages with their production seams ------------------------------------

// simulateScan (ingest.h) with an Embree BVH of the mesh.
Result<SimulatedScan> simulateRangeScan(const Scan& mesh, const Checked<SimulateScanOptions>& options);

// A scan read as stored (a local frame of its reader's) moved into a run's
// frame (`origin`: file coordinates = origin + coordinates), in double.
void moveToFrame(Scan& scan, const std::array<double, 3>& origin);

// The scan's coloured points, for the GLB's base colour (docs/export.md,
// "Base colour"): the scan file read again as stored (finite points only),
// so that the export stage and `apo export` of the run folder give the same
// bytes, in the run's frame. Empty when the file has no colours.
struct ScanColors {
  std::vector<Vec3f> positions;
  std::vector<Rgb8> colors;
};
Result<ScanColors> readScanColors(const std::filesystem::path& scanPath, const std::array<double, 3>& runOrigin);

// Each point's colour: the mean of the kScanColorNeighbours nearest coloured
// points' colours, weighted by their inverse squared distance (nanoflann's exact
// search; the same answers whatever the thread count).
inline constexpr std::size_t kScanColorNeighbours = 4;
ColorField nearestScanColors(const ScanColors& colors);

}  // namespace apo
