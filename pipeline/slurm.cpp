// `apo slurm`: `apo batch` as a Slurm job array, one shard per task, and a
// merge job after it (docs/cluster.md). Slurm schedules; apo only writes the
// scripts and hands them to sbatch.
#include "pipeline/pipeline.h"

#include "core/file_io.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

namespace apo {
namespace fs = std::filesystem;
namespace {

// A word for bash, single-quoted: nothing in it is expanded.
std::string bashWord(std::string_view word) {
  std::string out = "'";
  for (char c : word) {
    if (c == '\'')
      out += "'\\''";  // close the quotes, an escaped quote, reopen
    else
      out += c;
  }
  out += '\'';
  return out;
}

std::string bashWords(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& word : words) {
    out += ' ';
    out += bashWord(word);
  }
  return out;
}

// The log's path goes on sbatch's command line (SlurmScripts), where a space
// or a quote in it needs no parsing.
std::string sbatchOptions(const SlurmSettings& s, std::string_view name) {
  std::string out = fmt::format("#SBATCH --job-name={}\n#SBATCH --cpus-per-task={}\n", name, s.cpusPerTask);
  if (!s.partition.empty()) out += fmt::format("#SBATCH --partition={}\n", s.partition);
  if (!s.time.empty()) out += fmt::format("#SBATCH --time={}\n", s.time);
  if (!s.memory.empty()) out += fmt::format("#SBATCH --mem={}\n", s.memory);
  return out;
}

// Runs `arguments` (no shell; the program found on PATH) and returns what it
// printed on stdout, or an error with what it printed on stderr. posix_spawnp
// leaves nothing to run between fork and exec; both pipes are read together,
// so a long complaint on stderr cannot stall the child.
Result<std::string> capture(const std::vector<std::string>& arguments) {
  std::vector<char*> argv;
  for (const std::string& a : arguments) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::array<int, 2> out{}, err{};
  if (pipe2(out.data(), O_CLOEXEC) != 0) return internalError("pipe: {}", std::strerror(errno));
  if (pipe2(err.data(), O_CLOEXEC) != 0) {
    close(out[0]);
    close(out[1]);
    return internalError("pipe: {}", std::strerror(errno));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err[1], STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  close(err[1]);
  std::array<std::string, 2> texts;  // stdout, stderr
  std::array<pollfd, 2> open = {{{out[0], POLLIN, 0}, {err[0], POLLIN, 0}}};
  while (spawned == 0 && (open[0].fd >= 0 || open[1].fd >= 0)) {
    if (poll(open.data(), open.size(), -1) < 0 && errno != EINTR) break;
    for (std::size_t i = 0; i < open.size(); ++i) {
      if (open[i].fd < 0 || open[i].revents == 0) continue;
      std::array<char, 4096> buffer{};
      const ssize_t n = read(open[i].fd, buffer.data(), buffer.size());
      if (n > 0) {
        texts[i].append(buffer.data(), static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        close(open[i].fd);
        open[i].fd = -1;
      }
    }
  }
  for (const pollfd& p : open)
    if (p.fd >= 0) close(p.fd);
  if (spawned != 0) return badInput("cannot run {}: {}", arguments.front(), std::strerror(spawned));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return badInput("{} failed: {}", arguments.front(), texts[1].empty() ? "no message" : texts[1]);
  return texts[0];
}

// `sbatch --parsable` prints "JOBID" or "JOBID;CLUSTER".
Result<std::string> submit(const std::vector<std::string>& arguments) {
  auto printed = capture(arguments);
  if (!printed) return printed.error();
  std::string id = printed->substr(0, printed->find_first_of(";\n"));
  if (id.empty() || !std::all_of(id.begin(), id.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return internalError("sbatch printed no job id: {}", *printed);
  return id;
}

}  // namespace

SlurmScripts slurmScripts(const SlurmSettings& s) {
  const std::string apo = bashWord(s.executable.string()), scans = bashWord(s.scanDir.string()), out = bashWord(s.outDir.string());
  SlurmScripts scripts;
  scripts.arrayLog = s.outDir / "slurm" / "task-%a.log";
  scripts.mergeLog = s.outDir / "slurm" / "merge.log";
  // --requeue: a task stopped by preemption or a node failure runs again and
  // resumes (its finished scans are up to date; the interrupted one is redone).
  scripts.array = "#!/bin/bash\n" + sbatchOptions(s, "apo-batch") +
                  fmt::format("#SBATCH --array=0-{}\n#SBATCH --requeue\nset -eu\n", s.tasks - 1) +
                  fmt::format("exec {} batch {} -o {} --shard \"$SLURM_ARRAY_TASK_ID/{}\" --jobs 1 --threads \"${{SLURM_CPUS_PER_TASK:-1}}\"{}\n",
                              apo, scans, out, s.tasks, bashWords(s.workerArguments));
  SlurmSettings mergeSettings = s;
  mergeSettings.cpusPerTask = 1;
  scripts.merge = "#!/bin/bash\n" + sbatchOptions(mergeSettings, "apo-merge") +
                  fmt::format("set -eu\nexec {} batch {} -o {} --merge\n", apo, scans, out);
  return scripts;
}

Result<SlurmJobs> submitSlurm(const SlurmSettings& settings) {
  const fs::path folder = settings.outDir / "slurm";
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) return internalError("{}: cannot create: {}", folder.string(), error.message());
  const SlurmScripts scripts = slurmScripts(settings);
  APO_RETURN_IF_ERROR(writeFileAtomically(folder / "array.sbatch", scripts.array));
  APO_RETURN_IF_ERROR(writeFileAtomically(folder / "merge.sbatch", scripts.merge));
  SlurmJobs jobs;
  auto array = submit({"sbatch", "--parsable", "--output=" + scripts.arrayLog.string(), (folder / "array.sbatch").string()});
  if (!array) return array.error();
  jobs.arrayJob = *array;
  auto merge = submit({"sbatch", "--parsable", "--output=" + scripts.mergeLog.string(), "--dependency=afterany:" + jobs.arrayJob,
                       (folder / "merge.sbatch").string()});
  if (!merge) return merge.error();
  jobs.mergeJob = *merge;
  return jobs;
}

namespace {

constexpr std::array<const char*, 3> kPassNames = {"areas", "records", "samples"};

// `apo run` on the scan with the workers' options and --all-points (the
// split is of the bake of every point).
std::string runCommand(const SlurmSettings& s, const std::string& split) {
  std::vector<std::string> arguments = s.workerArguments;
  if (std::find(arguments.begin(), arguments.end(), "--all-points") == arguments.end())
    arguments.push_back("--all-points");
  return fmt::format("exec {} run {} -o {} --split {} --threads \"${{SLURM_CPUS_PER_TASK:-1}}\"{}\n",
                     bashWord(s.executable.string()), bashWord(s.scanDir.string()), bashWord(s.outDir.string()), split,
                     bashWords(arguments));
}

}  // namespace

ScanSplitScripts scanSplitScripts(const SlurmSettings& s) {
  ScanSplitScripts scripts;
  const fs::path logs = s.outDir / "slurm";
  scripts.prepareLog = logs / "prepare.log";
  scripts.mergeLog = logs / "merge.log";
  // --requeue: a job stopped by preemption or a node failure runs again;
  // the store and the journal's finished entries are reused.
  scripts.prepare = "#!/bin/bash\n" + sbatchOptions(s, "apo-prepare") + "#SBATCH --requeue\nset -eu\n" +
                    runCommand(s, "prepare");
  for (std::size_t p = 0; p < kPassNames.size(); ++p) {
    scripts.passLogs[p] = logs / fmt::format("{}-%a.log", kPassNames[p]);
    scripts.passes[p] = "#!/bin/bash\n" + sbatchOptions(s, fmt::format("apo-{}", kPassNames[p])) +
                        fmt::format("#SBATCH --array=0-{}\n#SBATCH --requeue\nset -eu\n", s.tasks - 1) +
                        runCommand(s, fmt::format("{}:\"$SLURM_ARRAY_TASK_ID\"/{}", kPassNames[p], s.tasks));
  }
  scripts.merge = "#!/bin/bash\n" + sbatchOptions(s, "apo-merge") + "#SBATCH --requeue\nset -eu\n" + runCommand(s, "merge");
  return scripts;
}

Result<ScanSplitJobs> submitScanSplit(const SlurmSettings& settings) {
  const fs::path folder = settings.outDir / "slurm";
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) return internalError("{}: cannot create: {}", folder.string(), error.message());
  const ScanSplitScripts scripts = scanSplitScripts(settings);
  const auto submitAfter = [&](const std::string& name, const std::string& script, const fs::path& log,
                               const std::string& after) -> Result<std::string> {
    APO_RETURN_IF_ERROR(writeFileAtomically(folder / name, script));
    std::vector<std::string> arguments = {"sbatch", "--parsable", "--output=" + log.string()};
    if (!after.empty()) arguments.push_back("--dependency=afterany:" + after);
    arguments.push_back((folder / name).string());
    return submit(arguments);
  };
  ScanSplitJobs jobs;
  auto prepare = submitAfter("prepare.sbatch", scripts.prepare, scripts.prepareLog, "");
  if (!prepare) return prepare.error();
  jobs.prepareJob = *prepare;
  std::string after = jobs.prepareJob;
  for (std::size_t p = 0; p < kPassNames.size(); ++p) {
    auto pass = submitAfter(fmt::format("{}.sbatch", kPassNames[p]), scripts.passes[p], scripts.passLogs[p], after);
    if (!pass) return pass.error();
    jobs.passJobs[p] = after = *pass;
  }
  auto merge = submitAfter("merge.sbatch", scripts.merge, scripts.mergeLog, after);
  if (!merge) return merge.error();
  jobs.mergeJob = *merge;
  return jobs;
}

}  // namespace apo
