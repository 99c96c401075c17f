// `apo run`'s pipeline on one scan, in one process: ingest -> reconstruct
// (skipped for a mesh: M is the mesh) -> simplify -> bake -> render ->
// report, recording every stage in OUTDIR/manifest.json (docs/run.md). The
// manifest is rewritten after each stage, so a run that is killed leaves one
// that says "running" and where it stopped.
#include "pipeline/pipeline.h"

#include "adapters/embree/embree_ray_caster.h"
#include "core/file_io.h"
#include "core/timing.h"
#include "pipeline/manifest.h"
#include "report/report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <array>
#include <cstdio>
#include <optional>
#include <string>

namespace apo {
namespace fs = std::filesystem;
namespace {

using Json = nlohmann::ordered_json;
enum StageIndex : std::size_t { kIngest, kReconstruct, kSimplify, kBake, kRender, kExport, kReport };

// What the stages hand to one another.
struct PipelineData {
  Scan scan;    // ingested: points with normals, or a mesh
  Scan dense;   // M as a mesh (the scan itself when it is one)
  Scan coarse;  // m
  ApoTexture texture;
  std::optional<N3Tree> n3tree;      // --layout n3tree: what the renders draw
  const Scan* reference = nullptr;   // M as the renders draw it: dense, or the scan's points
  std::optional<ScanProbes> probes;  // point scans: the probes on m judging the asset against the scan
  std::vector<Camera> cameras;       // the renders' views, in their order
  std::optional<PointStore> store;   // --all-points on a large scan: its every point
};

// Where --all-points keeps a large scan's every point while the run needs them.
constexpr const char* kScratchFolder = ".scratch";
// The bricks' depth for a store's every point (64 at most: a brick of a
// 100-million-point scan holds a few million).
constexpr int kStoreBrickDepth = 2;
// Where the part of a split run before the bake leaves, in the scratch
// folder, what the tasks and the merge take from it: the ingested scan, M
// and m, in the local frame's floats as the run holds them.
constexpr const char* kPreparedScanFile = "scan.ply";
constexpr const char* kPreparedDenseFile = "M.ply";
constexpr const char* kPreparedCoarseFile = "m.ply";
// The stages the merge of a split run takes from its prepared part.
constexpr std::array<StageIndex, 3> kPreparedStages = {kIngest, kReconstruct, kSimplify};

fs::path scratchFolderOf(const RunSettings& settings) { return settings.outDir / kScratchFolder; }
fs::path storeFolderOf(const RunSettings& settings) { return scratchFolderOf(settings) / "points"; }

// The bake options a store's points are baked with: --brick-depth, or kStoreBrickDepth.
BakeOptions storeBakeOptions(const RunOptions& options) {
  BakeOptions bake = options.bake;
  if (bake.brickDepth == 0) bake.brickDepth = std::min(kStoreBrickDepth, bake.coarseDepth);
  return bake;
}

// The bake in bricks keeps each brick's finished work in the store's
// folder (removed with it), under a key of the store, m and the bake's
// options: a run killed in the bake resumes from its finished bricks, and
// the tasks of a split run share it with the merge.
Result<fs::path> journalFolder(const PointStore& store, const Scan& coarse, const RunOptions& options) {
  auto described = readFileBytes(store.folder() / "store.json");
  if (!described) return described.error();
  const auto bytesOf = [](const auto& items) {
    return std::string_view(reinterpret_cast<const char*>(items.data()), items.size() * sizeof(items[0]));
  };
  std::string key = *described;
  key += optionsJson(options)["bake"].dump();
  key += fmt::format(" brick depth {}", storeBakeOptions(options).brickDepth);
  key += sha256OfBytes(bytesOf(coarse.points.positions));
  key += sha256OfBytes(bytesOf(coarse.points.normals));
  key += sha256OfBytes(bytesOf(coarse.triangles));
  return store.folder() / "journal" / sha256OfBytes(key).substr(0, 16);
}

// M's every point from the store, baked in bricks with the journal.
Result<BrickedPoints> storePoints(const PointStore& store, const Scan& coarse, const RunOptions& options) {
  BrickedPoints points = brickedPoints(store.size(), [&store](const Aabb& box) { return store.pointsIn(box); });
  auto journal = journalFolder(store, coarse, options);
  if (!journal) return journal.error();
  points.journal = brickJournalIn(*journal);
  return points;
}

class Run {
 public:
  // `manifest`: manifest::initial's, or manifestToMerge's for a merge.
  Run(const RunSettings& settings, Progress& progress, Json manifest)
      : settings_(settings), progress_(progress), manifest_(std::move(manifest)) {}

  // Runs the stages until one fails; the manifest records each.
  Status execute() {
    APO_RETURN_IF_ERROR(save());
    if (settings_.part.kind == RunPart::Kind::Merge) {
      APO_RETURN_IF_ERROR(takePrepared());
    } else {
      APO_RETURN_IF_ERROR(makeCoarseMesh());
      if (settings_.part.kind == RunPart::Kind::Prepare) return leaveForTasks();
    }
    APO_RETURN_IF_ERROR(stage(kBake, [&] { return bake(); }));
    APO_RETURN_IF_ERROR(stage(kRender, [&] { return render(); }));
    if (settings_.options->exporting.enabled)
      APO_RETURN_IF_ERROR(stage(kExport, [&] { return exportAsset(); }));
    else
      skip(kExport);
    APO_RETURN_IF_ERROR(stage(kReport, [&] { return report(); }));
    removeScratch();
    manifest_["status"] = "succeeded";
    return save();
  }

  // After a failed execute(): the manifest says so (best effort: the failure
  // may be the output folder itself).
  void recordFailure(const Error& error) {
    manifest_["status"] = "failed";
    if (manifest_["error"].is_null()) manifest_["error"] = {{"stage", "setup"}, {"message", error.message}};
    if (Status saved = save(); !saved.ok()) spdlog::warn("{}", saved.error().message);
  }

  const Json& manifest() const { return manifest_; }

 private:
  // Ingest, reconstruct (M is the scan when it is a mesh) and simplify.
  Status makeCoarseMesh() {
    APO_RETURN_IF_ERROR(stage(kIngest, [&] { return ingest(); }));
    if (data_.scan.isMesh()) {
      skip(kReconstruct);
      data_.dense = data_.scan;
    } else {
      APO_RETURN_IF_ERROR(stage(kReconstruct, [&] { return reconstruct(); }));
    }
    return stage(kSimplify, [&] { return simplify(); });
  }

  // The part of a split run before the bake: the scan, M and m as held (m
  // for the tasks' journal key to be the merge's) beside the store; the
  // manifest says `prepared`.
  Status leaveForTasks() {
    const fs::path scratch = scratchFolderOf(settings_);
    APO_RETURN_IF_ERROR(writePly(scratch / kPreparedScanFile, data_.scan));
    if (!data_.scan.isMesh()) APO_RETURN_IF_ERROR(writePly(scratch / kPreparedDenseFile, data_.dense));
    APO_RETURN_IF_ERROR(writePly(scratch / kPreparedCoarseFile, data_.coarse));
    if (data_.store)
      spdlog::info("run: the scan, M, m and the store of {} points left in {} for the bake's tasks and the merge",
                   data_.store->size(), scratch.string());
    else
      spdlog::info("run: no point store (the scan is read whole): the merge bakes it, the tasks have nothing to share");
    manifest_["status"] = "prepared";
    return save();
  }

  // The merge of a split run (its manifest from manifestToMerge): the scan,
  // M, m and the store its prepared part left.
  Status takePrepared() {
    const fs::path scratch = scratchFolderOf(settings_);
    const auto readPrepared = [&scratch](const char* name, Scan& into) {
      auto read = readScan(scratch / name, ScanFormat::Ply);
      if (!read) return Status(read.error());
      into = std::move(*read);
      return okStatus();
    };
    APO_RETURN_IF_ERROR(readPrepared(kPreparedScanFile, data_.scan));
    if (data_.scan.isMesh())
      data_.dense = data_.scan;
    else
      APO_RETURN_IF_ERROR(readPrepared(kPreparedDenseFile, data_.dense));
    APO_RETURN_IF_ERROR(readPrepared(kPreparedCoarseFile, data_.coarse));
    if (manifest_["results"]["ingest"]["point_store"].value("written", false)) {
      auto store = PointStore::open(storeFolderOf(settings_));
      if (!store) return store.error();
      data_.store = std::move(*store);
    }
    for (StageIndex index : kPreparedStages) {
      progress_.startStage(kRunStages[index]);
      progress_.finishStage("done by the prepared part");
    }
    return okStatus();
  }

  // The point store and a split run's prepared files, once the run is done:
  // a run killed before reuses them.
  void removeScratch() {
    data_.store.reset();
    std::error_code error;
    fs::remove_all(scratchFolderOf(settings_), error);
    if (error) spdlog::warn("could not remove the scratch folder {}: {}", scratchFolderOf(settings_).string(), error.message());
  }

  template <class Body>
  Status stage(StageIndex index, Body&& body) {
    Json& record = manifest_["stages"][index];
    progress_.startStage(kRunStages[index]);
    resetPeakResident();
    const Stopwatch stopwatch;
    Status status = body();
    record["seconds"] = stopwatch.seconds();
    record["peak_memory_bytes"] = peakResidentSinceReset();
    record["status"] = status.ok() ? "succeeded" : "failed";
    if (!status.ok()) manifest_["error"] = {{"stage", kRunStages[index]}, {"message", status.error().message}};
    progress_.finishStage(status.ok() ? fmt::format("{:.1f} s, peak {} MiB", record["seconds"].get<double>(),
                                                    record["peak_memory_bytes"].get<std::uint64_t>() >> 20)
                                      : "failed");
    APO_RETURN_IF_ERROR(save());
    return status;
  }

  void skip(StageIndex index) {
    manifest_["stages"][index]["status"] = "skipped";
    progress_.startStage(kRunStages[index]);
    progress_.finishStage("skipped");
  }

  Status save() const { return manifest::write(settings_.outDir, manifest_); }

  void addFile(const char* key, const std::string& name) { manifest_["files"][key] = name; }

  Status ingest() {
    APO_RETURN_IF_ERROR(checkReadableFile(settings_.input));
    auto digest = sha256OfFile(settings_.input);
    if (!digest) return digest.error();
    std::error_code ignored;
    manifest_["input"]["sha256"] = *digest;
    manifest_["input"]["bytes"] = fs::file_size(settings_.input, ignored);
    // A scan read a run at a time says how much is read: most of its ingest
    // (the first part of it when every point goes to a store after).
    const double readShare = settings_.options->allPoints ? 0.3 : 1.0;
    auto ingested = ingestScan(settings_.input, partOf(settings_.options, &RunOptions::ingest),
                               [this, readShare](double fraction) { progress_.setFraction(readShare * fraction); });
    if (!ingested) return ingested.error();
    data_.scan = std::move(ingested->scan);
    manifest_["results"]["ingest"] = Json::parse(ingestReportJson(ingested->report));
    if (settings_.options->allPoints) APO_RETURN_IF_ERROR(storeEveryPoint(ingested->report, readShare));
    // Every output's coordinates: the scan's file coordinates = origin + them
    // (local), or the file's own (world, --keep-georeference; scan.apo and the
    // renders stay local, the .apo header holding the origin).
    const auto& o = data_.scan.origin;
    manifest_["georeference"] = {{"origin", {o[0], o[1], o[2]}},
                                 {"meshes", settings_.options->keepGeoreference && data_.scan.isGeoreferenced() ? "world" : "local"}};
    return okStatus();
  }

  // --all-points: a scan read into voxel centroids has its every point put
  // in a store (reused when a killed run left it complete); the manifest
  // says what was done either way.
  Status storeEveryPoint(const IngestReport& report, double readShare) {
    Json& record = manifest_["results"]["ingest"]["point_store"];
    if (!report.largeScan.subsampled || data_.scan.isMesh()) {
      record = {{"written", false}, {"reason", "the scan is read whole (at most --max-scan-points points)"}};
      return okStatus();
    }
    const int k = settings_.options->pointNormals == PointNormals::Fitted ? report.normalNeighbours : 0;
    auto store = writePointStore(settings_.input, data_.scan, k,
                                 storeFolderOf(settings_),
                                 [this, readShare](double f) { progress_.setFraction(readShare + (1.0 - readShare) * f); });
    if (!store) return aboutInput(settings_.input, store.error());
    const PointStoreReport& r = store->report();
    record = {{"written", true},         {"reused", r.reused},
              {"points", r.points},      {"non_finite", r.nonFinite},
              {"grid_depth", r.gridDepth}, {"occupied_cells", r.occupiedCells},
              {"neighbours", r.neighbours}, {"unfitted_normals", r.unfittedNormals},
              {"cut_neighbourhoods", r.cutNeighbourhoods}, {"bytes", r.bytes},
              {"seconds", r.seconds}};
    data_.store = std::move(store).value();
    return okStatus();
  }

  // The current stage's fraction done, to the progress line.
  ProgressCallback reportFraction() {
    return [this](double fraction) { progress_.setFraction(fraction); };
  }

  Status reconstruct() {
    auto reconstruction = reconstructScan(data_.scan, partOf(settings_.options, &RunOptions::reconstruct), reportFraction());
    if (!reconstruction) return aboutInput(settings_.input, reconstruction.error());
    data_.dense = std::move(reconstruction->mesh);
    APO_RETURN_IF_ERROR(writePly(settings_.outDir / "M.ply", data_.dense, settings_.options->keepGeoreference));
    addFile("M", "M.ply");
    manifest_["results"]["reconstruct"] = Json::parse(reconstructReportJson(reconstruction->report));
    return okStatus();
  }

  Status simplify() {
    auto simplified = simplifyMesh(data_.dense, partOf(settings_.options, &RunOptions::simplify), reportFraction());
    if (!simplified) return aboutInput(settings_.input, simplified.error());
    data_.coarse = std::move(simplified->mesh);
    APO_RETURN_IF_ERROR(writePly(settings_.outDir / "m.ply", data_.coarse, settings_.options->keepGeoreference));
    addFile("m", "m.ply");
    manifest_["results"]["simplify"] = Json::parse(simplifyReportJson(simplified->report));
    return okStatus();
  }

  // The scan's points as detail: a mesh's vertices with their normals.
  const Scan& pointsOfScan() {
    if (data_.scan.isMesh()) {
      addVertexNormalsIfMissing(data_.scan);
      data_.scan.triangles.clear();
    }
    return data_.scan;
  }

  // A point scan is judged against its own points (docs/render.md, "Against
  // the scan"); the probes on m and their truths are made once.
  bool judgedAgainstScan() const { return !data_.scan.isMesh() && data_.scan.points.hasNormals(); }
  Result<const ScanProbes*> scanProbes() {
    if (!data_.probes) {
      auto probes = probeAgainstScan(data_.scan.points, data_.coarse);
      if (!probes) return aboutInput(settings_.input, probes.error());
      data_.probes = std::move(*probes);
    }
    return &*data_.probes;
  }

  Result<Bake> bakeFrom(const Scan& detail, double from, double to) {
    const ProgressCallback onProgress = [&](double fraction) { progress_.setFraction(from + (to - from) * fraction); };
    auto baked = &detail == &data_.scan && data_.store ? bakeFromStore(onProgress)
                                                       : bakeApo(detail, data_.coarse, partOf(settings_.options, &RunOptions::bake), onProgress);
    if (!baked) return aboutInput(settings_.input, baked.error());
    return baked;
  }

  // The scan's points as detail when they are in a store: every point, in
  // bricks (--brick-depth, or kStoreBrickDepth).
  Result<Bake> bakeFromStore(const ProgressCallback& onProgress) {
    auto checked = check(storeBakeOptions(*settings_.options));
    if (!checked) return checked.error();
    auto points = storePoints(*data_.store, data_.coarse, *settings_.options);
    if (!points) return points.error();
    return bakeApoInBricks(*points, data_.coarse, *checked, onProgress);
  }

  // --detail-source auto on a point scan: the APO baked from M and the one
  // baked from the points, each judged against the scan on the same probes;
  // the points must win by kPointsDetailMargin.
  Result<Bake> bakeCloserToScan(Json& choice) {
    auto fromMesh = bakeFrom(data_.dense, 0.0, 0.4);
    if (!fromMesh) return fromMesh.error();
    auto fromPoints = bakeFrom(data_.scan, 0.4, 0.8);
    if (!fromPoints) return fromPoints.error();
    const Stopwatch judging;
    auto probes = scanProbes();
    if (!probes) return probes.error();
    const AngularStats meshError = apoErrorAgainstScan(**probes, fromMesh->texture);
    const AngularStats pointsError = apoErrorAgainstScan(**probes, fromPoints->texture);
    choice["judging_seconds"] = judging.seconds();
    const bool points = pointsError.mean < (1.0 - kPointsDetailMargin) * meshError.mean;
    choice["chosen"] = points ? "points" : "mesh";
    choice["reason"] = points ? "the APO baked from the points is closer to the scan's own points"
                       : pointsError.mean < meshError.mean
                           ? "the APO baked from the points is closer to the scan's own points, but by less than the margin"
                           : "the APO baked from the mesh is closer to the scan's own points";
    const auto candidate = [](const Bake& baked, const AngularStats& error) {
      return Json{{"against_scan_mean_degrees", error.mean}, {"texture_bytes", baked.report.textureBytes}};
    };
    choice["candidates"] = {{"mesh", candidate(*fromMesh, meshError)}, {"points", candidate(*fromPoints, pointsError)}};
    choice["probes_kept"] = (*probes)->positions.size();
    choice["margin"] = kPointsDetailMargin;
    return points ? std::move(fromPoints) : std::move(fromMesh);
  }

  // Bakes from what --detail-source says (deciding it for auto); records
  // the choice in results.bake.detail_source.
  Result<Bake> bakeChosen(Json& choice) {
    const DetailSource option = settings_.options->detailSource;
    choice = {{"option", detailSourceName(option)}};
    if (option == DetailSource::Points) {
      choice["chosen"] = "points";
      choice["reason"] = "--detail-source points";
      return bakeFrom(pointsOfScan(), 0.0, 1.0);
    }
    if (option == DetailSource::Auto && judgedAgainstScan()) return bakeCloserToScan(choice);
    choice["chosen"] = "mesh";
    choice["reason"] = option == DetailSource::Mesh ? "--detail-source mesh"
                       : data_.scan.isMesh()            ? "the scan is a mesh: M is the scan"
                                                        : "the scan's points have no normals to judge against";
    return bakeFrom(data_.dense, 0.0, 1.0);
  }

  Status bake() {
    Json choice;
    auto baked = bakeChosen(choice);
    if (!baked) return baked.error();
    // How many points the APO's candidate from the points read: the scan's
    // every point (its store) or the points ingest kept.
    choice["points_baked"] = data_.store ? data_.store->size() : data_.scan.points.size();
    choice["points_from"] = data_.store ? "store" : "scan";
    // The renders compare the APO with what it was baked from: the scan's
    // points when those were kept, not a reconstruction the APO does not
    // follow (docs/run.md, "Detail source").
    data_.reference = choice["chosen"] == "points" ? &pointsOfScan() : &data_.dense;
    data_.texture = std::move(baked->texture);
    data_.n3tree = std::move(baked->n3tree);
    if (data_.n3tree) {
      APO_RETURN_IF_ERROR(writeN3TreeFile(settings_.outDir / "scan.n3t", *data_.n3tree));
      addFile("n3tree", "scan.n3t");
    }
    APO_RETURN_IF_ERROR(writeApoFile(settings_.outDir / "scan.apo", data_.texture));
    APO_RETURN_IF_ERROR(writeApoPng(settings_.outDir / "texture.png", data_.texture));
    addFile("apo", "scan.apo");
    addFile("texture", "texture.png");
    manifest_["results"]["bake"] = Json::parse(bakeReportJson(baked->report));
    manifest_["results"]["bake"]["detail_source"] = std::move(choice);
    return okStatus();
  }

  Status render() {
    progress_.setFraction(0.0);
    const auto onViewDone = [&](int done, int total) { progress_.setFraction(static_cast<double>(done) / total); };
    const auto options = partOf(settings_.options, &RunOptions::render);
    auto views = data_.n3tree ? renderViews(data_.reference, data_.coarse, *data_.n3tree, options, onViewDone)
                              : renderViews(data_.reference, data_.coarse, data_.texture, options, onViewDone);
    if (!views) return aboutInput(settings_.input, views.error());
    RenderFigures figures = measureViews(*views);
    if (data_.n3tree) {
      figures.layout = "n3tree";
      figures.n3Size = data_.n3tree->n;
    }
    APO_RETURN_IF_ERROR(writeRenderOutputs(settings_.outDir / kRenderFolder, *views, figures, settings_.options->render));
    std::vector<Camera>& cameras = data_.cameras;
    for (const ViewImages& view : *views) cameras.push_back(view.camera);
    manifest_["results"]["render"] = Json::parse(renderReportJson(figures, settings_.options->render, cameras));
    // What the views drew as the reference: what the kept APO was baked from.
    manifest_["results"]["render"]["reference"] = data_.reference == &data_.dense ? "M" : "points";
    // A point scan's M is a reconstruction: the asset is judged against the
    // scan's own points too (docs/render.md, "Against the scan").
    manifest_["results"]["render"]["against_scan"] = nullptr;
    if (judgedAgainstScan()) {
      const Stopwatch judging;
      auto probes = scanProbes();
      if (!probes) return probes.error();
      auto coarseCaster = makeEmbreeMeshCaster(data_.coarse);
      if (!coarseCaster) return aboutInput(settings_.input, coarseCaster.error());
      auto fidelity = measureAgainstScan(**probes, data_.scan.points, data_.dense, data_.texture,
                                         ScanViews{cameras, coarseCaster->get()});
      if (!fidelity) return aboutInput(settings_.input, fidelity.error());
      manifest_["results"]["render"]["against_scan"] = Json::parse(scanFidelityJson(*fidelity));
      // The probes, when the bake made them, are not in this figure.
      manifest_["results"]["render"]["against_scan"]["seconds"] = judging.seconds();
    }
    addFile("renders", kRenderFolder);
    return okStatus();
  }

  // m and the APO as a GLB (docs/export.md), in the local frame whose
  // origin the asset's extras record.
  // With the scan's colours, read again from its file as `apo export` does.
  Status exportAsset() {
    ScanColors colors;
    if (settings_.options->exporting.color && data_.scan.points.hasColors()) {
      auto read = readScanColors(settings_.input, data_.scan.origin);
      if (!read) return aboutInput(settings_.input, read.error());
      colors = std::move(*read);
    }
    const ColorField colorField = nearestScanColors(colors);
    auto asset = exportGlb(data_.coarse, apoNormalField(data_.texture), "apo", partOf(settings_.options, &RunOptions::exporting),
                           data_.scan.origin, fmt::format("apo {}", manifest_["tool"]["version"].get<std::string>()),
                           colors.positions.empty() ? nullptr : &colorField);
    if (!asset) return aboutInput(settings_.input, asset.error());
    APO_RETURN_IF_ERROR(writeFileAtomically(settings_.outDir / "asset.glb", asset->glb));
    addFile("glb", "asset.glb");
    manifest_["results"]["export"] = Json::parse(exportReportJson(asset->report));
    return okStatus();
  }

  Status report() {
    if (settings_.options->viewer) APO_RETURN_IF_ERROR(viewer());
    addFile("report", "report.html");
    // The report shows the run as it will be recorded: every stage done.
    Json finished = manifest_;
    finished["status"] = "succeeded";
    finished["stages"][kReport]["status"] = "succeeded";
    return writeFileAtomically(settings_.outDir / "report.html", qaReportHtml(nlohmann::json::parse(finished.dump())));
  }

  // OUTDIR/viewer.html, the interactive view the report embeds (docs/report.md,
  // "The viewer"); its size and what it shows as M go in results.viewer.
  Status viewer() {
    const Stopwatch making;
    auto scene = viewerScene(data_.coarse, data_.texture, data_.reference, data_.cameras, settings_.options->render);
    if (!scene) return aboutInput(settings_.input, scene.error());
    std::vector<std::string> images;
    for (std::size_t i = 0; i < data_.cameras.size(); ++i) images.push_back(fmt::format("{}/view{:02d}_apo.png", kRenderFolder, i));
    const std::string page = viewerHtml(*scene, settings_.input.filename().string(), images);
    APO_RETURN_IF_ERROR(writeFileAtomically(settings_.outDir / "viewer.html", page));
    addFile("viewer", "viewer.html");
    manifest_["results"]["viewer"] = {{"bytes", page.size()},
                                      {"texture_bytes", scene->texture.size()},
                                      {"detail", scene->detail.description},
                                      {"seconds", making.seconds()}};
    return okStatus();
  }

  const RunSettings& settings_;
  Progress& progress_;
  Json manifest_;
  PipelineData data_;
};

// One task's share of a split run's bake (RunPart::Kind::Share): the store
// and m the prepared part left, the journal the tasks share; no manifest
// (the prepared part's and the merge's).
Status bakeShare(const RunSettings& settings, Progress& progress) {
  const BrickShare& share = settings.part.share;
  progress.startStage(kRunStages[kBake]);
  const fs::path storeFolder = storeFolderOf(settings);
  std::error_code ignored;
  if (!fs::exists(storeFolder / "store.json", ignored)) {
    const fs::path manifestPath = settings.outDir / "manifest.json";
    if (!fs::exists(manifestPath, ignored))
      return badInput("{}: no prepared run (run `apo run --split prepare` first)", settings.outDir.string());
    spdlog::info("bake: {} pass, task {} of {}: no point store (the scan is read whole), nothing to share",
                 passName(share.pass), share.task, share.tasks);
    progress.finishStage("nothing to share");
    return okStatus();
  }
  auto store = PointStore::open(storeFolder);
  if (!store) return store.error();
  auto coarse = readScan(scratchFolderOf(settings) / kPreparedCoarseFile, ScanFormat::Ply);
  if (!coarse) return coarse.error();
  auto options = check(storeBakeOptions(*settings.options));
  if (!options) return options.error();
  auto points = storePoints(*store, *coarse, *settings.options);
  if (!points) return points.error();
  auto coarseCaster = makeEmbreeMeshCaster(*coarse);
  if (!coarseCaster) return coarseCaster.error();
  auto report = bakeShareOfBricks(*points, {&*coarse, coarseCaster->get()}, *options, share,
                                  [&progress](double fraction) { progress.setFraction(fraction); });
  if (!report) return aboutInput(settings.input, report.error());
  progress.finishStage(fmt::format("{} pass, task {} of {}: {} entries written, {} read back, {} points loaded",
                                   passName(share.pass), share.task, share.tasks, report->journalEntriesWritten,
                                   report->journalEntriesReused, report->pointsLoaded));
  return okStatus();
}

// The manifest a merge of a split run starts from: its prepared part's, or
// a merge's that did not end (killed and requeued), with the stages the
// prepared part ran named in `split`. Either must be of this input, these
// options and this apo.
Result<Json> manifestToMerge(const RunSettings& settings) {
  std::optional<Json> prepared = manifest::read(settings.outDir);
  const std::string status = prepared ? prepared->value("status", "") : "";
  if (status != "prepared" && !(prepared && prepared->contains("split") && status != "succeeded"))
    return badInput("{}: no prepared run to merge{} (run `apo run --split prepare` first)", settings.outDir.string(),
                    status == "succeeded" ? ": its merge has succeeded" : "");
  APO_RETURN_IF_ERROR(checkReadableFile(settings.input));
  auto digest = sha256OfFile(settings.input);
  if (!digest) return digest.error();
  if (!manifest::sameRun(*prepared, *digest, optionsJson(*settings.options)))
    return badInput("{}: prepared from another input, other options or another apo version than this merge's "
                    "(run `apo run --split prepare` again)",
                    settings.outDir.string());
  Json manifest = std::move(*prepared);
  manifest["status"] = "running";
  manifest["error"] = nullptr;
  manifest["split"] = {{"prepared_stages", Json::array()}};
  for (StageIndex index : kPreparedStages) manifest["split"]["prepared_stages"].push_back(kRunStages[index]);
  return manifest;
}

}  // namespace

Result<RunPart> runPartNamed(std::string_view text) {
  RunPart part;
  if (text == "whole") return part;
  if (text == "prepare" || text == "merge") {
    part.kind = text == "prepare" ? RunPart::Kind::Prepare : RunPart::Kind::Merge;
    return part;
  }
  const std::size_t colon = text.find(':'), slash = text.find('/');
  const auto pass = passNamed(text.substr(0, colon));
  unsigned task = 0, tasks = 0;
  char extra = 0;
  if (colon == std::string_view::npos || slash == std::string_view::npos || !pass ||
      std::sscanf(std::string(text.substr(colon + 1)).c_str(), "%u/%u%c", &task, &tasks, &extra) != 2 || tasks == 0 ||
      task >= tasks)
    return usageError("--split {}: expected whole, prepare, PASS:T/N or merge (PASS areas, records or samples; task T below N)",
                      text);
  part.kind = RunPart::Kind::Share;
  part.share = {*pass, task, tasks};
  return part;
}

RunOutcome runPipeline(const RunSettings& settings, Progress& progress) {
  if (settings.part.kind == RunPart::Kind::Share) return {bakeShare(settings, progress), {}};
  Json manifest = manifest::initial(settings);
  if (settings.part.kind == RunPart::Kind::Merge) {
    auto toMerge = manifestToMerge(settings);
    if (!toMerge) return {toMerge.error(), {}};
    manifest = std::move(*toMerge);
  }
  Run run(settings, progress, std::move(manifest));
  Status status = run.execute();
  if (!status.ok()) run.recordFailure(status.error());
  return {std::move(status), run.manifest()};
}

}  // namespace apo
