// `apo batch SCANDIR -o OUTDIR [-j N] [--shard I/N | --merge]`: `apo run` on
// every scan under SCANDIR, or one shard of them (pipeline.h runBatch), or
// the pages of all (mergeBatch); `apo slurm`: the batch as a Slurm job array
// (submitSlurm, docs/cluster.md).
#include "cli/command_support.h"
#include "cli/config.h"
#include "cli/stage_options.h"

#include <algorithm>
#include <cctype>
#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct BatchCommand {
  fs::path scanDir, outDir;
  int jobs = 1;
  double scanTimeout = 0.0;  // seconds; 0: none
  std::string shard;         // "I/N"; empty: every scan
  bool merge = false;
  StageArguments arguments;
};

struct SlurmCommand {
  fs::path scanDir, outDir;
  int tasks = 1;
  std::string partition, time, memory;
  int cpus = 1;
  bool dryRun = false;
  StageArguments arguments;
};

int runBatchCommand(CLI::App& app, const BatchCommand& command) {
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  auto options = check(runOptionsFrom(command.arguments));
  if (!options) return reportFailure(options.error());
  BatchSettings settings{.scanDir = command.scanDir,
                         .outDir = command.outDir,
                         .jobs = command.jobs,
                         .threads = command.arguments.bake.threads,
                         .scanTimeout = command.scanTimeout,
                         .options = *options,
                         .workerArguments = givenStageArguments(app)};
  if (!command.shard.empty()) {
    auto shard = parseShard(command.shard);
    if (!shard) return reportFailure(shard.error());
    settings.shard = *shard;
  }
  const Result<BatchSummary> summary = command.merge ? mergeBatch(settings) : runBatch(settings);
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
  sub->add_option("--shard", command->shard,
                  "Only the scans of shard I of N (I from 0; a scan's shard depends on its own path alone), for a "
                  "cluster's job array; index.html is left to --merge (docs/cluster.md)");
  sub->add_flag("--merge", command->merge,
                "Run no scan: write index.html and summary.json from every scan's manifest, whichever shard wrote it")
      ->excludes("--shard");
  addStageOptionGroups(*sub, command->arguments);
  sub->callback([sub, command, &exitCode] { exitCode = guarded([&] { return runBatchCommand(*sub, *command); }); });
}

namespace {

// A value written after "#SBATCH --option=": one word, else the line breaks
// or carries another option.
const CLI::Validator kOneWord(
    [](const std::string& value) {
      const bool blank = std::any_of(value.begin(), value.end(), [](unsigned char c) { return std::isspace(c) || c < 32; });
      return blank || value.empty() ? std::string("must be one word, without spaces") : std::string();
    },
    "WORD");

// One scan's bake across the tasks (submitScanSplit).
int runScanSplit(const SlurmSettings& settings, bool dryRun) {
  if (dryRun) {
    const ScanSplitScripts scripts = scanSplitScripts(settings);
    std::printf("# prepare.sbatch (sbatch --output=%s)\n%s\n", scripts.prepareLog.c_str(), scripts.prepare.c_str());
    for (std::size_t p = 0; p < scripts.passes.size(); ++p)
      std::printf("# pass %zu (sbatch --output=%s --dependency=afterany:PREVIOUS)\n%s\n", p + 1,
                  scripts.passLogs[p].c_str(), scripts.passes[p].c_str());
    std::printf("# merge.sbatch (sbatch --output=%s --dependency=afterany:PASS3)\n%s", scripts.mergeLog.c_str(),
                scripts.merge.c_str());
    return kExitSuccess;
  }
  const Result<ScanSplitJobs> jobs = submitScanSplit(settings);
  if (!jobs) return reportFailure(jobs.error());
  std::printf("prepare job %s, pass jobs %s %s %s (%d tasks each), merge job %s; scripts and logs in %s\n",
              jobs->prepareJob.c_str(), jobs->passJobs[0].c_str(), jobs->passJobs[1].c_str(), jobs->passJobs[2].c_str(),
              settings.tasks, jobs->mergeJob.c_str(), (settings.outDir / "slurm").string().c_str());
  return kExitSuccess;
}

int runSlurmCommand(CLI::App& app, const SlurmCommand& command) {
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  if (auto options = check(runOptionsFrom(command.arguments)); !options) return reportFailure(options.error());
  std::error_code error;
  SlurmSettings settings;
  settings.scanDir = fs::absolute(command.scanDir, error);
  settings.outDir = fs::absolute(command.outDir, error);
  settings.tasks = command.tasks;
  settings.partition = command.partition;
  settings.time = command.time;
  settings.memory = command.memory;
  settings.cpusPerTask = command.cpus;
  settings.executable = fs::read_symlink("/proc/self/exe", error);
  settings.workerArguments = givenStageArguments(app);
  if (fs::is_regular_file(settings.scanDir)) return runScanSplit(settings, command.dryRun);
  if (!fs::is_directory(settings.scanDir))
    return reportFailure(badInput("{}: neither a folder of scans nor a scan file", settings.scanDir.string()));
  if (command.dryRun) {
    const SlurmScripts scripts = slurmScripts(settings);
    std::printf("# array.sbatch (sbatch --output=%s)\n%s\n# merge.sbatch (sbatch --output=%s --dependency=afterany:ARRAY)\n%s",
                scripts.arrayLog.c_str(), scripts.array.c_str(), scripts.mergeLog.c_str(), scripts.merge.c_str());
    return kExitSuccess;
  }
  const Result<SlurmJobs> jobs = submitSlurm(settings);
  if (!jobs) return reportFailure(jobs.error());
  std::printf("array job %s (%d tasks), merge job %s; scripts and logs in %s\n", jobs->arrayJob.c_str(), settings.tasks,
              jobs->mergeJob.c_str(), (settings.outDir / "slurm").string().c_str());
  return kExitSuccess;
}

}  // namespace

void addSlurmCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<SlurmCommand>();
  CLI::App* sub = app.add_subcommand(
      "slurm", "apo batch as a Slurm job array: N tasks, each one shard of the scans, then a merge job writing "
               "index.html; or, given one scan file, its bake of every point shared among N tasks (a prepare job, "
               "three job arrays, a merge); submitted with sbatch unless --dry-run (docs/cluster.md)");
  sub->add_option("scans", command->scanDir,
                  "Folder searched recursively for scans by extension, or one scan file to split")
      ->required();
  sub->add_option("-o,--out", command->outDir, "Output folder, on a file system every node sees")->required();
  sub->add_option("--tasks", command->tasks, "Tasks of the job array, one shard of the scans each")
      ->check(CLI::Range(1, kMostShards))
      ->required();
  sub->add_option("--partition", command->partition, "sbatch --partition (default: the cluster's)")->check(kOneWord);
  sub->add_option("--time", command->time, "sbatch --time per task, e.g. 2:00:00 (default: the partition's)")->check(kOneWord);
  sub->add_option("--mem", command->memory, "sbatch --mem per task, e.g. 8G (default: the partition's)")->check(kOneWord);
  sub->add_option("--cpus", command->cpus, "sbatch --cpus-per-task; each task's scans use that many threads")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  sub->add_flag("--dry-run", command->dryRun, "Print the two sbatch scripts instead of submitting them");
  addStageOptionGroups(*sub, command->arguments);
  sub->callback([sub, command, &exitCode] { exitCode = guarded([&] { return runSlurmCommand(*sub, *command); }); });
}

}  // namespace apo::cli
