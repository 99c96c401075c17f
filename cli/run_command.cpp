// `apo run SCAN -o OUTDIR`: the whole pipeline on one scan (pipeline.h).
#include "cli/command_support.h"
#include "cli/config.h"
#include "cli/stage_options.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct RunCommand {
  fs::path input, outDir;
  bool printManifest = false;
  std::string split = "whole";
  StageArguments arguments;
};

int runRun(CLI::App& app, const RunCommand& command, bool quiet) {
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  // Every stage's options, before any stage runs.
  auto options = check(runOptionsFrom(command.arguments));
  if (!options) return reportFailure(options.error());
  auto part = runPartNamed(command.split);
  if (!part) return reportFailure(part.error());
  if (part->kind != RunPart::Kind::Whole && !(*options)->allPoints)
    return reportFailure(usageError("--split {} splits the bake of every point: it needs --all-points", command.split));
  const RunSettings settings{command.input, command.outDir, *options, *part};
  const auto threads = limitThreads(command.arguments.bake.threads);
  const ProgressStyle style = progressStyleForStderr(quiet);
  Progress progress(style, static_cast<int>(kRunStageCount));
  // The stages' own info lines would break a live line; the manifest has them.
  const auto level = spdlog::get_level();
  if (style == ProgressStyle::LiveLine && level == spdlog::level::info) spdlog::set_level(spdlog::level::warn);
  const RunOutcome outcome = runPipeline(settings, progress);
  spdlog::set_level(level);
  if (command.printManifest) std::printf("%s\n", outcome.manifest.dump(2).c_str());
  if (!outcome.status.ok()) return reportFailure(outcome.status.error());
  if (part->kind == RunPart::Kind::Whole)
    spdlog::info("run: {} -> {}", (command.outDir / "report.html").string(), command.outDir.string());
  return kExitSuccess;
}

}  // namespace

void addRunCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<RunCommand>();
  CLI::App* sub = app.add_subcommand("run", "The whole pipeline on one scan: ingest, reconstruct, simplify, bake, render, "
                                            "and a QA report (OUTDIR/report.html, manifest.json)");
  sub->add_option("scan", command->input, "Scan file (" + scanExtensionList() + ")")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder")->required();
  sub->add_flag("--json", command->printManifest, "Print the manifest to stdout at the end");
  sub->add_option("--split", command->split,
                  "A part of a run split across tasks, as `apo slurm` on one scan runs them (docs/cluster.md): "
                  "prepare (up to m and the point store), PASS:T/N (task T's share of the bake's pass: areas, "
                  "records, samples), merge (the rest, from the prepared part and the tasks' work), whole (default)");
  addStageOptionGroups(*sub, command->arguments);
  sub->callback([sub, command, &app, &exitCode] {
    const bool quiet = app.get_option("--quiet")->count() > 0;
    exitCode = guarded([&] { return runRun(*sub, *command, quiet); });
  });
}

}  // namespace apo::cli
