// `apo run SCAN -o OUTDIR`: the whole pipeline on one scan, in one process:
// ingest -> reconstruct (skipped for a mesh: M is the mesh) -> simplify ->
// bake -> render -> report, recording every stage in OUTDIR/manifest.json
// (docs/run.md). The manifest is rewritten after each stage, so a run that
// is killed leaves one that says "running" and where it stopped.
#include "cli/command_support.h"
#include "cli/progress.h"
#include "cli/report_html.h"
#include "cli/run.h"
#include "cli/stage_options.h"
#include "core/file_io.h"
#include "core/timing.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <array>
#include <cstdio>
#include <memory>
#include <optional>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

using Json = nlohmann::ordered_json;

constexpr std::array<const char*, 6> kStages = {"ingest", "reconstruct", "simplify", "bake", "render", "report"};
enum StageIndex : std::size_t { kIngest, kReconstruct, kSimplify, kBake, kRender, kReport };

// What the stages hand to one another.
struct PipelineData {
  Scan scan;    // ingested: points with normals, or a mesh
  Scan dense;   // M as a mesh (the scan itself when it is one)
  Scan coarse;  // m
  ApoTexture texture;
};

Json newManifest(const RunSettings& settings) {
  Json manifest;
  manifest["format_version"] = kManifestFormatVersion;
  manifest["tool"] = {{"name", "apo"}, {"version", APO_VERSION}};
  manifest["input"] = {{"path", settings.input.string()}, {"name", settings.input.filename().string()}};
  manifest["options"] = settings.options;
  manifest["status"] = "running";
  manifest["error"] = nullptr;
  manifest["stages"] = Json::array();
  for (const char* name : kStages)
    manifest["stages"].push_back({{"name", name}, {"status", "not_run"}, {"seconds", 0.0}, {"peak_memory_bytes", 0}});
  manifest["results"] = Json::object();
  manifest["files"] = Json::object();
  return manifest;
}

class Run {
 public:
  Run(const RunSettings& settings, Progress& progress)
      : settings_(settings), progress_(progress), manifest_(newManifest(settings)) {}

  // Runs the stages until one fails; the manifest records each.
  Status execute() {
    APO_RETURN_IF_ERROR(save());
    APO_RETURN_IF_ERROR(stage(kIngest, [&] { return ingest(); }));
    if (data_.scan.isMesh()) {
      skip(kReconstruct);
      data_.dense = data_.scan;
    } else {
      APO_RETURN_IF_ERROR(stage(kReconstruct, [&] { return reconstruct(); }));
    }
    APO_RETURN_IF_ERROR(stage(kSimplify, [&] { return simplify(); }));
    const Scan& detail = detailForBake();
    APO_RETURN_IF_ERROR(stage(kBake, [&] { return bake(detail); }));
    APO_RETURN_IF_ERROR(stage(kRender, [&] { return render(detail); }));
    APO_RETURN_IF_ERROR(stage(kReport, [&] { return report(); }));
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
  template <class Body>
  Status stage(StageIndex index, Body&& body) {
    Json& record = manifest_["stages"][index];
    progress_.startStage(kStages[index]);
    resetPeakResident();
    const Stopwatch stopwatch;
    Status status = body();
    record["seconds"] = stopwatch.seconds();
    record["peak_memory_bytes"] = peakResidentSinceReset();
    record["status"] = status.ok() ? "succeeded" : "failed";
    if (!status.ok()) manifest_["error"] = {{"stage", kStages[index]}, {"message", status.error().message}};
    progress_.finishStage(status.ok() ? fmt::format("{:.1f} s, peak {} MiB", record["seconds"].get<double>(),
                                                    record["peak_memory_bytes"].get<std::uint64_t>() >> 20)
                                      : "failed");
    APO_RETURN_IF_ERROR(save());
    return status;
  }

  void skip(StageIndex index) {
    manifest_["stages"][index]["status"] = "skipped";
    progress_.startStage(kStages[index]);
    progress_.finishStage("skipped");
  }

  Status save() const { return writeFileAtomically(settings_.outDir / "manifest.json", manifest_.dump(2) + "\n"); }

  void addFile(const char* key, const std::string& name) { manifest_["files"][key] = name; }

  Status ingest() {
    APO_RETURN_IF_ERROR(checkReadableFile(settings_.input));
    auto digest = sha256OfFile(settings_.input);
    if (!digest) return digest.error();
    std::error_code ignored;
    manifest_["input"]["sha256"] = *digest;
    manifest_["input"]["bytes"] = fs::file_size(settings_.input, ignored);
    auto ingested = ingestScan(settings_.input, settings_.ingest);
    if (!ingested) return ingested.error();
    data_.scan = std::move(ingested->scan);
    manifest_["results"]["ingest"] = Json::parse(ingestReportJson(ingested->report));
    return okStatus();
  }

  // The current stage's fraction done, to the progress line.
  ProgressCallback reportFraction() {
    return [this](double fraction) { progress_.setFraction(fraction); };
  }

  Status reconstruct() {
    auto reconstruction = reconstructScan(data_.scan, settings_.reconstruct, reportFraction());
    if (!reconstruction) return aboutInput(settings_.input, reconstruction.error());
    data_.dense = std::move(reconstruction->mesh);
    APO_RETURN_IF_ERROR(writePly(settings_.outDir / "M.ply", data_.dense));
    addFile("M", "M.ply");
    manifest_["results"]["reconstruct"] = Json::parse(reconstructReportJson(reconstruction->report));
    return okStatus();
  }

  Status simplify() {
    auto simplified = simplifyMesh(data_.dense, settings_.simplify, reportFraction());
    if (!simplified) return aboutInput(settings_.input, simplified.error());
    data_.coarse = std::move(simplified->mesh);
    APO_RETURN_IF_ERROR(writePly(settings_.outDir / "m.ply", data_.coarse));
    addFile("m", "m.ply");
    manifest_["results"]["simplify"] = Json::parse(simplifyReportJson(simplified->report));
    return okStatus();
  }

  // M for the bake and the reference renders: the dense mesh, or with
  // --detail-source points the scan's points (a mesh's vertices with their
  // normals).
  const Scan& detailForBake() {
    if (settings_.detailSource != DetailSource::Points) return data_.dense;
    if (data_.scan.isMesh()) {
      if (!data_.scan.points.hasNormals()) data_.scan.points.normals = areaWeightedVertexNormals(data_.scan);
      data_.scan.triangles.clear();
    }
    return data_.scan;
  }

  Status bake(const Scan& detail) {
    auto baked = bakeApo(detail, data_.coarse, settings_.bake, reportFraction());
    if (!baked) return aboutInput(settings_.input, baked.error());
    data_.texture = std::move(baked->texture);
    APO_RETURN_IF_ERROR(writeApoFile(settings_.outDir / "scan.apo", data_.texture));
    APO_RETURN_IF_ERROR(writeApoPng(settings_.outDir / "texture.png", data_.texture));
    addFile("apo", "scan.apo");
    addFile("texture", "texture.png");
    manifest_["results"]["bake"] = Json::parse(bakeReportJson(baked->report));
    return okStatus();
  }

  Status render(const Scan& detail) {
    progress_.setFraction(0.0);
    auto views = renderViews(&detail, data_.coarse, data_.texture, settings_.render,
                             [&](int done, int total) { progress_.setFraction(static_cast<double>(done) / total); });
    if (!views) return aboutInput(settings_.input, views.error());
    const RenderFigures figures = measureViews(*views);
    APO_RETURN_IF_ERROR(writeRenderOutputs(settings_.outDir / kRenderFolder, *views, figures, settings_.render));
    std::vector<Camera> cameras;
    for (const ViewImages& view : *views) cameras.push_back(view.camera);
    manifest_["results"]["render"] = Json::parse(renderReportJson(figures, settings_.render, cameras));
    addFile("renders", kRenderFolder);
    return okStatus();
  }

  Status report() {
    addFile("report", "report.html");
    // The report shows the run as it will be recorded: every stage done.
    Json finished = manifest_;
    finished["status"] = "succeeded";
    finished["stages"][kReport]["status"] = "succeeded";
    return writeFileAtomically(settings_.outDir / "report.html", qaReportHtml(nlohmann::json::parse(finished.dump())));
  }

  const RunSettings& settings_;
  Progress& progress_;
  Json manifest_;
  PipelineData data_;
};

}  // namespace

RunOutcome runPipeline(const RunSettings& settings, Progress& progress) {
  Run run(settings, progress);
  Status status = run.execute();
  if (!status.ok()) run.recordFailure(status.error());
  return {std::move(status), run.manifest()};
}

namespace {

// The options added by `add` go under `group` in --help and in the manifest.
template <class Add>
void addGroup(CLI::App& app, const std::string& group, Add&& add) {
  const std::size_t before = app.get_options().size();
  add();
  std::vector<CLI::Option*> options = app.get_options(std::function<bool(CLI::Option*)>{});
  for (std::size_t i = before; i < options.size(); ++i) options[i]->group(group);
}

// Every option of a stage group, by stage and name (without dashes): the
// value given, else the default; flags as true / false.
Json optionsByStage(const CLI::App& app, const StageArguments& arguments) {
  Json options = Json::object();
  options["detail_source"] = arguments.detailSource;
  for (const char* stage : kStageGroups) options[stage] = Json::object();
  for (const CLI::Option* option : app.get_options()) {
    std::string group = option->get_group();
    for (char& c : group) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (!options.contains(group) || group == "detail_source") continue;
    std::string name = option->get_name();
    name.erase(0, name.find_first_not_of('-'));
    const bool flag = isFlag(*option);
    std::string value;
    if (flag)
      value = option->count() > 0 ? "true" : "false";
    else if (option->count() > 0)
      for (const std::string& result : option->results()) value += (value.empty() ? "" : " ") + result;
    else
      value = option->get_default_str();
    options[group][name] = value;
  }
  return options;
}

}  // namespace

void addStageOptionGroups(CLI::App& app, StageArguments& arguments) {
  app.add_option("--detail-source", arguments.detailSource,
                 "M for the bake and the reference renders: mesh (the reconstructed dense mesh, or the input mesh) or "
                 "points (the scan's points with their normals)")
      ->check(CLI::IsMember({"mesh", "points"}))
      ->capture_default_str();
  addGroup(app, "Ingest", [&] { addIngestOptions(app, arguments.ingest); });
  addGroup(app, "Reconstruct", [&] { addReconstructOptions(app, arguments.reconstruct); });
  addGroup(app, "Simplify", [&] { addSimplifyOptions(app, arguments.simplify); });
  addGroup(app, "Bake", [&] { addBakeOptions(app, arguments.bake); });
  addGroup(app, "Render", [&] { addRenderOptions(app, arguments.render); });
  app.add_option("--config", arguments.configFile,
                 "TOML file holding any of these options by name, without dashes (`faces = 5000`); the command line wins");
}

Status applyConfigFile(CLI::App& app, const std::filesystem::path& file) {
  if (file.empty()) return okStatus();
  APO_RETURN_IF_ERROR(checkReadableFile(file));
  std::vector<CLI::ConfigItem> items;
  CLI::ConfigTOML format;
  try {
    items = format.from_file(file.string());
  } catch (const CLI::Error& error) {
    return badInput("{}: not a TOML file of options: {}", file.string(), error.what());
  }
  for (const CLI::ConfigItem& item : items) {
    if (!item.parents.empty()) return badInput("{}: option '{}' is in a section; options stand at the top level", file.string(), item.fullname());
    CLI::Option* option = app.get_option_no_throw("--" + item.name);
    if (option == nullptr || item.name == "config" || item.name == "out")
      return badInput("{}: '{}' is not an option of apo {} (see --help)", file.string(), item.name, app.get_name());
    if (option->count() > 0) continue;  // given on the command line
    try {
      // As CLI11 does for a main command's config: flags through their flag value (so `no-normals = true` negates).
      if (isFlag(*option))
        option->add_result(option->get_flag_value(item.name, format.to_flag(item)));
      else
        option->add_result(item.inputs);
      option->run_callback();
    } catch (const CLI::Error& error) {
      return badInput("{}: option '{}': {}", file.string(), item.name, error.what());
    }
  }
  return okStatus();
}

RunSettings settingsFrom(const CLI::App& app, StageArguments arguments) {
  arguments.ingest.apply();
  arguments.simplify.apply();
  arguments.render.apply();
  RunSettings settings;
  settings.detailSource = arguments.detailSource == "points" ? DetailSource::Points : DetailSource::Mesh;
  settings.ingest = arguments.ingest.options;
  settings.reconstruct = arguments.reconstruct;
  settings.simplify = arguments.simplify.options;
  settings.bake = arguments.bake.options;
  settings.render = arguments.render.options;
  settings.options = optionsByStage(app, arguments);
  return settings;
}

namespace {

struct RunCommand {
  fs::path input, outDir;
  bool printManifest = false;
  StageArguments arguments;
};

int runRun(CLI::App& app, const RunCommand& command, bool quiet) {
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  RunSettings settings = settingsFrom(app, command.arguments);
  settings.input = command.input;
  settings.outDir = command.outDir;
  const auto threads = limitThreads(command.arguments.bake.threads);
  Progress progress(progressStyleForStderr(quiet), static_cast<int>(kStages.size()));
  // The stages' own info lines would break a live line; the manifest has them.
  const auto level = spdlog::get_level();
  if (progressStyleForStderr(quiet) == ProgressStyle::LiveLine && level == spdlog::level::info)
    spdlog::set_level(spdlog::level::warn);
  const RunOutcome outcome = runPipeline(settings, progress);
  spdlog::set_level(level);
  if (command.printManifest) std::printf("%s\n", outcome.manifest.dump(2).c_str());
  if (!outcome.status.ok()) return reportFailure(outcome.status.error());
  spdlog::info("run: {} -> {}", (command.outDir / "report.html").string(), command.outDir.string());
  return kExitSuccess;
}

}  // namespace

void addRunCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<RunCommand>();
  CLI::App* sub = app.add_subcommand("run", "The whole pipeline on one scan: ingest, reconstruct, simplify, bake, render, "
                                            "and a QA report (OUTDIR/report.html, manifest.json)");
  sub->add_option("scan", command->input, "Scan file (.ply .pcd .xyz .xyzn .pts .pwn .off .obj .stl)")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder")->required();
  sub->add_flag("--json", command->printManifest, "Print the manifest to stdout at the end");
  addStageOptionGroups(*sub, command->arguments);
  sub->callback([sub, command, &app, &exitCode] {
    const bool quiet = app.get_option("--quiet")->count() > 0;
    exitCode = guarded([&] { return runRun(*sub, *command, quiet); });
  });
}

}  // namespace apo::cli
