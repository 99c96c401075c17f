// `apo batch SCANDIR -o OUTDIR [-j N]`: `apo run` on every scan under SCANDIR,
// each in its own process (a crash or a leak stays with its scan, and CGAL's
// address-dependent tie-breaks cannot make one scan's output depend on
// another's), N at a time, into OUTDIR/<relative path>/. A scan whose
// manifest records success for the same input, options and tool version is
// skipped; any other is redone from scratch. docs/run.md.
#include "cli/command_support.h"
#include "cli/report_html.h"
#include "cli/run.h"
#include "cli/stage_options.h"
#include "core/file_io.h"
#include "core/timing.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cstring>
#include <map>
#include <set>
#include <thread>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

using Json = nlohmann::ordered_json;

const std::set<std::string> kScanExtensions = {".ply", ".pcd", ".xyz", ".xyzn", ".pts", ".pwn", ".off", ".obj", ".stl"};

struct BatchCommand {
  fs::path scanDir, outDir;
  int jobs = 1;
  double scanTimeout = 0.0;  // seconds; 0: none
  StageArguments arguments;
};

struct ScanJob {
  fs::path scan;          // as found under SCANDIR
  std::string relative;   // its path under SCANDIR, generic form: the output folder under OUTDIR
  fs::path outDir;
};

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// Scan files under `scanDir` by extension, sorted by relative path; OUTDIR is
// not searched when it lies inside SCANDIR (its meshes are outputs).
Result<std::vector<ScanJob>> findScans(const fs::path& scanDir, const fs::path& outDir) {
  std::error_code error;
  if (!fs::is_directory(scanDir, error)) return badInput("{}: not a folder", scanDir.string());
  const fs::path outCanonical = fs::weakly_canonical(outDir, error);
  std::vector<ScanJob> jobs;
  fs::recursive_directory_iterator it(scanDir, fs::directory_options::skip_permission_denied, error);
  if (error) return badInput("{}: cannot list: {}", scanDir.string(), error.message());
  for (; it != fs::recursive_directory_iterator(); it.increment(error)) {
    if (error) return badInput("{}: cannot list: {}", scanDir.string(), error.message());
    if (it->is_directory(error) && fs::weakly_canonical(it->path(), error) == outCanonical) {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file(error) || !kScanExtensions.contains(lowercase(it->path().extension().string()))) continue;
    // Lexically, as found: fs::relative would follow a symlinked scan to its
    // target and put its output folder wherever that lies (on the input).
    const fs::path relative = it->path().lexically_relative(scanDir);
    if (relative.empty() || *relative.begin() == "..")
      return internalError("{}: found outside the scan folder {}", it->path().string(), scanDir.string());
    jobs.push_back({it->path(), relative.generic_string(), outDir / relative});
  }
  std::sort(jobs.begin(), jobs.end(), [](const ScanJob& a, const ScanJob& b) { return a.relative < b.relative; });
  return jobs;
}

// An output folder may be emptied only if apo made it: absent, an empty
// folder, or a folder holding a manifest or a worker's log. Anything else in
// the way (a file, a user's folder) is left alone.
Status checkOutputFolderIsOurs(const fs::path& folder) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(folder, error);
  if (!fs::exists(status)) return okStatus();
  if (!fs::is_directory(status))
    return badInput("{}: exists and is not a folder; the scan's outputs would replace it, so it is left alone",
                    folder.string());
  if (fs::is_empty(folder, error) || fs::exists(folder / "manifest.json", error) || fs::exists(folder / "run.log", error))
    return okStatus();
  return badInput("{}: a folder that apo did not write (no manifest.json); it is left alone", folder.string());
}

std::optional<Json> readManifest(const fs::path& outDir) {
  auto bytes = readFileBytes(outDir / "manifest.json");
  if (!bytes) return std::nullopt;
  Json manifest = Json::parse(*bytes, nullptr, false);
  if (manifest.is_discarded() || !manifest.is_object()) return std::nullopt;
  return manifest;
}

// Options as compared for resuming: the thread count does not change outputs.
Json comparableOptions(Json options) {
  if (options.contains("bake") && options["bake"].is_object()) options["bake"].erase("threads");
  return options;
}

bool upToDate(const Json& manifest, const std::string& sha256, const Json& options) {
  return manifest.value("status", "") == "succeeded" && manifest.contains("input") &&
         manifest["input"].value("sha256", "") == sha256 && manifest.contains("tool") &&
         manifest["tool"].value("version", "") == APO_VERSION && manifest.contains("options") &&
         comparableOptions(manifest["options"]) == comparableOptions(options);
}

// The child's command line: `apo run SCAN -o DIR` with every stage option
// the batch was given, and its share of the threads.
std::vector<std::string> childArguments(const CLI::App& batch, const ScanJob& job, int threads) {
  std::vector<std::string> arguments = {"apo", "run", job.scan.string(), "-o", job.outDir.string(), "--threads",
                                        std::to_string(threads)};
  for (const CLI::Option* option : batch.get_options()) {
    const std::string name = option->get_name();
    if (option->count() == 0 || name.rfind("--", 0) != 0 || name == "--out" || name == "--jobs" || name == "--threads" ||
        name == "--config" || name == "--help" || name == "--scan-timeout")
      continue;
    arguments.push_back(name);
    if (!isFlag(*option))
      for (const std::string& value : option->results()) arguments.push_back(value);
  }
  return arguments;
}

// Starts `apo run` for one scan: its log goes to OUTDIR/<scan>/run.log, and
// it dies with the batch (a killed batch leaves no worker writing behind it).
Result<pid_t> startChild(const std::vector<std::string>& arguments, const fs::path& logPath) {
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) return internalError("cannot start a worker process: {}", std::strerror(errno));
  if (pid > 0) return pid;
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(127);
  const int log = open(logPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (log >= 0) {
    dup2(log, STDERR_FILENO);
    dup2(log, STDOUT_FILENO);
    close(log);
  }
  std::vector<char*> argv;
  for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  execv("/proc/self/exe", argv.data());
  _exit(127);
}

std::string describeExit(int status, bool timedOut, double timeout) {
  if (timedOut) return fmt::format("the scan took longer than --scan-timeout {} s and was stopped", timeout);
  if (WIFSIGNALED(status)) return fmt::format("the worker was killed by signal {} ({})", WTERMSIG(status), strsignal(WTERMSIG(status)));
  return fmt::format("the worker exited with code {}", WEXITSTATUS(status));
}

// A worker that ended without recording its end (a crash, a kill): its
// manifest records the failure at the first stage that did not finish.
void recordAbnormalEnd(const ScanJob& job, const std::string& reason) {
  std::optional<Json> manifest = readManifest(job.outDir);
  if (!manifest) {
    manifest = Json{{"format_version", kManifestFormatVersion},
                    {"tool", {{"name", "apo"}, {"version", APO_VERSION}}},
                    {"input", {{"path", job.scan.string()}, {"name", job.scan.filename().string()}}},
                    {"stages", Json::array()}};
  }
  if (manifest->value("status", "") == "succeeded" || manifest->value("status", "") == "failed") return;
  std::string stage = "setup";
  if (manifest->contains("stages") && (*manifest)["stages"].is_array())
    for (Json& record : (*manifest)["stages"])
      if (record.value("status", "") == "not_run" || record.value("status", "") == "running") {
        stage = record.value("name", "setup");
        break;
      }
  (*manifest)["status"] = "failed";
  (*manifest)["error"] = {{"stage", stage}, {"message", reason + " (see run.log)"}};
  if (Status s = writeFileAtomically(job.outDir / "manifest.json", manifest->dump(2) + "\n"); !s.ok())
    spdlog::warn("{}", s.error().message);
}

// Holds OUTDIR/.apo-batch.lock while the batch runs: two batches writing the
// same folder would undo each other's work.
Result<int> lockOutput(const fs::path& outDir) {
  std::error_code error;
  fs::create_directories(outDir, error);
  if (error) return internalError("{}: cannot create the output folder: {}", outDir.string(), error.message());
  const fs::path lockPath = outDir / ".apo-batch.lock";
  const int fd = open(lockPath.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return internalError("{}: cannot open: {}", lockPath.string(), std::strerror(errno));
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    close(fd);
    return usageError("{}: another apo batch is writing to this folder", outDir.string());
  }
  return fd;
}

struct Tally {
  int succeeded = 0, failed = 0, upToDate = 0;
};

int runBatch(CLI::App& app, const BatchCommand& command) {
  const Stopwatch stopwatch;
  if (Status s = applyConfigFile(app, command.arguments.configFile); !s.ok()) return reportFailure(s.error());
  auto lock = lockOutput(command.outDir);
  if (!lock) return reportFailure(lock.error());
  auto jobs = findScans(command.scanDir, command.outDir);
  if (!jobs) return reportFailure(jobs.error());
  if (jobs->empty()) return reportFailure(badInput("{}: no scans found (extensions: .ply .pcd .xyz .xyzn .pts .pwn .off .obj .stl)",
                                                   command.scanDir.string()));
  const Json options = settingsFrom(app, command.arguments).options;
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int workers = std::max(1, std::min(command.jobs, static_cast<int>(jobs->size())));
  const int threadsEach = std::max(1, cores / workers);
  spdlog::info("batch: {} scans under {}, {} at a time with {} thread(s) each -> {}", jobs->size(), command.scanDir.string(),
               workers, threadsEach, command.outDir.string());

  Tally tally;
  struct Worker {
    const ScanJob* job;
    Stopwatch started;
    bool timedOut = false;
  };
  std::map<pid_t, Worker> running;
  std::size_t next = 0, done = 0;
  const auto finish = [&](const ScanJob& job, const std::string& outcome) {
    ++done;
    spdlog::info("[{}/{}] {}: {}", done, jobs->size(), job.relative, outcome);
  };
  while (next < jobs->size() || !running.empty()) {
    while (next < jobs->size() && static_cast<int>(running.size()) < workers) {
      const ScanJob& job = (*jobs)[next++];
      auto digest = sha256OfFile(job.scan);
      const std::optional<Json> previous = readManifest(job.outDir);
      if (digest && previous && upToDate(*previous, *digest, options)) {
        ++tally.upToDate;
        finish(job, "up to date, skipped");
        continue;
      }
      // Redone from scratch: whatever an earlier, interrupted run left goes.
      if (Status ours = checkOutputFolderIsOurs(job.outDir); !ours.ok()) {
        ++tally.failed;
        finish(job, "FAILED: " + ours.error().message);
        continue;
      }
      std::error_code error;
      fs::remove_all(job.outDir, error);
      fs::create_directories(job.outDir, error);
      if (error) return reportFailure(internalError("{}: cannot create: {}", job.outDir.string(), error.message()));
      auto pid = startChild(childArguments(app, job, threadsEach), job.outDir / "run.log");
      if (!pid) return reportFailure(pid.error());
      running.emplace(*pid, Worker{&job, Stopwatch(), false});
    }
    if (running.empty()) continue;
    int status = 0;
    // With a time limit, poll so that a worker over it can be stopped; without, wait.
    const pid_t pid = waitpid(-1, &status, command.scanTimeout > 0.0 ? WNOHANG : 0);
    if (pid < 0) return reportFailure(internalError("waiting for the workers: {}", std::strerror(errno)));
    if (pid == 0) {  // none ended: stop those over the time limit, then look again shortly
      for (auto& [workerPid, worker] : running)
        if (!worker.timedOut && worker.started.seconds() > command.scanTimeout) {
          kill(workerPid, SIGKILL);
          worker.timedOut = true;
        }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const ScanJob& job = *it->second.job;
    const bool timedOut = it->second.timedOut;
    running.erase(it);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      recordAbnormalEnd(job, describeExit(status, timedOut, command.scanTimeout));
    const std::optional<Json> manifest = readManifest(job.outDir);
    if (manifest && manifest->value("status", "") == "succeeded") {
      ++tally.succeeded;
      finish(job, "succeeded");
    } else {
      ++tally.failed;
      const Json error = manifest && manifest->contains("error") ? (*manifest)["error"] : Json();
      finish(job, error.is_object() ? fmt::format("FAILED at {}: {}", error.value("stage", "?"), error.value("message", "?"))
                                    : "FAILED");
    }
  }

  // The index and the summary, from every scan's manifest.
  std::vector<BatchRow> rows;
  for (const ScanJob& job : *jobs) {
    const std::optional<Json> manifest = readManifest(job.outDir);
    rows.push_back({job.relative, manifest ? nlohmann::json::parse(manifest->dump()) : nlohmann::json::object()});
  }
  const nlohmann::json summary = {{"scans", jobs->size()},
                                  {"succeeded", tally.succeeded},
                                  {"failed", tally.failed},
                                  {"skipped_up_to_date", tally.upToDate},
                                  {"seconds", stopwatch.seconds()}};
  if (Status s = writeFileAtomically(command.outDir / "index.html", batchIndexHtml(rows, summary)); !s.ok())
    return reportFailure(s.error());
  if (Status s = writeFileAtomically(command.outDir / "summary.json", summary.dump(2) + "\n"); !s.ok())
    return reportFailure(s.error());
  spdlog::info("batch: {} succeeded, {} failed, {} up to date in {:.1f} s -> {}", tally.succeeded, tally.failed,
               tally.upToDate, stopwatch.seconds(), (command.outDir / "index.html").string());
  close(*lock);
  return tally.failed == 0 ? kExitSuccess : kExitBadInput;
}

}  // namespace

void addBatchCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<BatchCommand>();
  CLI::App* sub = app.add_subcommand(
      "batch", "apo run on every scan under a folder, N at a time, resuming where an earlier batch stopped; "
               "OUTDIR/index.html lists them (exit code 2 if any scan failed)");
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
  sub->callback([sub, command, &exitCode] { exitCode = guarded([&] { return runBatch(*sub, *command); }); });
}

}  // namespace apo::cli
