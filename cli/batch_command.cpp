// `apo batch SCANDIR -o OUTDIR [-j N]`: `apo run` on every scan under SCANDIR
// (pipeline.h runBatch).
#include "cli/command_support.h"
#include "cli/config.h"
#include "cli/stage_options.h"

#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct BatchCommand {
  fs::path scanDir, outDir;
  int jobs = 1;
  double scanTimeout = 0.0;  // seconds; 0: none
  StageArguments arguments;
};

int runBatchCommand(CLI::App& app, const BatchCommand& command) {
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  BatchSettings settings;
  settings.scanDir = command.scanDir;
  settings.outDir = command.outDir;
  settings.jobs = command.jobs;
  settings.scanTimeout = command.scanTimeout;
  settings.options = runOptionsFrom(command.arguments);
  if (Status valid = validateRunOptions(settings.options); !valid.ok()) return reportFailure(valid.error());
  settings.workerArguments = givenStageArguments(app);
  const Result<BatchSummary> summary = runBatch(settings);
  if (!summary) return reportFailure(summary.error());
  return summary->failed == 0 && summary->notProcessed == 0 ? kExitSuccess : kExitBadInput;
}

}  // namespace

void addBatchCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<BatchCommand>();
  CLI::App* sub = app.add_subcommand(
      "batch", "apo run on every scan under a folder, N at a time, resuming where an earlier batch stopped; "
               "OUTDIR/index.html lists them (exit code 2 if any scan failed or any file was not processed)");
  sub->add_option("scans", command->scanDir, "Folder searched recursively for scans by extension")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder: one folder per scan, at its path under the scan folder")
      ->required();
  sub->add_option("-j,--jobs", command->jobs, "Scans processed at a time (the cores are shared among them)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  sub->add_option("--scan-timeout", command->scanTimeout,
                  "Stop a scan that runs longer than this many seconds and record it as failed (0: no limit)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  addStageOptionGroups(*sub, command->arguments);
  sub->callback([sub, command, &exitCode] { exitCode = guarded([&] { return runBatchCommand(*sub, *command); }); });
}

}  // namespace apo::cli
