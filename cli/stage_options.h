// Each stage's command-line options, registered on any CLI11 app or option
// group: the stage's own subcommand and `apo run` / `apo batch` (one group
// per stage) share them, so their names, defaults and help never drift.
// Values fill the stages' option structs; the stages validate them
// (validate*Options), and `apo run` / `apo batch` validate them all before
// any stage runs.
#pragma once

#include "pipeline/pipeline.h"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace apo::cli {

// What the command line fills in beyond the stages' option structs; apply()
// moves it into them once parsing is done.
struct IngestArguments {
  IngestOptions options;
  std::vector<float> sensor;  // X Y Z, or empty
  std::string orient = "propagation";
  std::string meshInput = "auto";
  void apply();
};

struct SimplifyArguments {
  SimplifyOptions options;
  std::string policy = "gh";
  bool noQuickPass = false;
  void apply();
};

struct BakeArguments {
  BakeOptions options;
  int threads = 0;  // 0: every core
};

struct RenderArguments {
  RenderOptions options;
  bool noMipmapping = false;
  // `apo run` and `apo batch` filter unless told --no-filter (their report is
  // about accuracy); `apo render` filters when told --filter (the paper's
  // default, and 3-4x cheaper per frame).
  bool filterByDefault = false;
  bool noFiltering = false;
  bool noPointLod = false;
  void apply();
};

// A flag takes no value on the command line (CLI11 gives it expected(0)).
inline bool isFlag(const CLI::Option& option) { return option.get_items_expected_max() == 0; }

void addIngestOptions(CLI::App& app, IngestArguments& arguments);
void addReconstructOptions(CLI::App& app, ReconstructOptions& options);
void addSimplifyOptions(CLI::App& app, SimplifyArguments& arguments);
void addBakeOptions(CLI::App& app, BakeArguments& arguments);
void addRenderOptions(CLI::App& app, RenderArguments& arguments);
// --map-size, --gutter (apo export and the export stage of apo run / batch).
void addExportOptions(CLI::App& app, ExportOptions& options);

// The stage options of `apo run` and `apo batch`: one group per stage in
// --help, --detail-source and --config (TOML).
struct StageArguments {
  bool keepGeoreference = false;
  bool allPoints = false;
  std::string pointNormals = "centroids";
  std::string detailSource = "auto";
  IngestArguments ingest;
  ReconstructOptions reconstruct;
  SimplifyArguments simplify;
  BakeArguments bake;
  RenderArguments render = reportRenderArguments();
  ExportOptions exporting;
  bool noExport = false;
  bool noViewer = false;
  std::filesystem::path configFile;  // --config

  // The QA report's renders (pipeline.h reportRenderOptions), filtered unless
  // told --no-filter.
  static RenderArguments reportRenderArguments() {
    RenderArguments render;
    render.options = reportRenderOptions();
    render.filterByDefault = true;
    return render;
  }
};

void addStageOptionGroups(CLI::App& app, StageArguments& arguments);
// The run's options from parsed arguments.
RunOptions runOptionsFrom(StageArguments arguments);
// The stage options given to `app` (on the command line or by --config), as
// arguments for `apo run`, in the order they were registered.
std::vector<std::string> givenStageArguments(const CLI::App& app);

}  // namespace apo::cli
