// The whole pipeline on one scan (`apo run`), shared by `apo batch`, whose
// workers are `apo run` processes. docs/run.md describes OUTDIR and
// manifest.json.
#pragma once

#include "bake/bake.h"
#include "cli/progress.h"
#include "cli/stage_options.h"
#include "ingest/ingest.h"
#include "reconstruct/reconstruct.h"
#include "render/render.h"

#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>

namespace apo::cli {

inline constexpr int kManifestFormatVersion = 1;
inline constexpr const char* kRenderFolder = "render";

// M for the bake and the reference renders: the dense mesh (reconstructed, or
// the input mesh itself), or the scan's points with their normals.
enum class DetailSource { Mesh, Points };

struct RunSettings {
  std::filesystem::path input, outDir;
  DetailSource detailSource = DetailSource::Mesh;
  IngestOptions ingest;
  ReconstructOptions reconstruct;
  SimplifyOptions simplify;
  BakeOptions bake;
  RenderOptions render;
  nlohmann::ordered_json options;  // every option as set, by stage: the manifest's "options"
};

struct RunOutcome {
  Status status;
  nlohmann::ordered_json manifest;  // as written to OUTDIR/manifest.json
};

RunOutcome runPipeline(const RunSettings& settings, Progress& progress);

// The stage options of `apo run` and `apo batch`: one group per stage in
// --help, --detail-source and --config (TOML).
struct StageArguments {
  std::string detailSource = "mesh";
  IngestArguments ingest;
  ReconstructOptions reconstruct;
  SimplifyArguments simplify;
  BakeArguments bake;
  RenderArguments render = defaultRunRender();
  std::filesystem::path configFile;  // --config

  // The QA report's renders: 512 px, 3 timed frames, filtered (`apo render`
  // defaults to 1024, 5 and unfiltered).
  static RenderArguments defaultRunRender() {
    RenderArguments render;
    render.options.size = 512;
    render.options.timedFrames = 3;
    render.filterByDefault = true;
    render.options.filtering = true;
    return render;
  }
};

inline constexpr std::array<const char*, 5> kStageGroups = {"ingest", "reconstruct", "simplify", "bake", "render"};

void addStageOptionGroups(CLI::App& app, StageArguments& arguments);
// Sets every option of `app` that the TOML file names and the command line
// did not give. BadInput naming the file for an unreadable file, an unknown
// option, or a value the option refuses.
Status applyConfigFile(CLI::App& app, const std::filesystem::path& file);
// Settings from parsed arguments; `app` is where they were registered.
RunSettings settingsFrom(const CLI::App& app, StageArguments arguments);

}  // namespace apo::cli
