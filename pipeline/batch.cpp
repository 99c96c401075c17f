// `apo batch`: `apo run` on every scan under a folder, each in its own process
// (a crash or a leak stays with its scan, and CGAL's address-dependent
// tie-breaks cannot make one scan's output depend on another's), N at a
// time, into OUTDIR/<relative path>/. A scan whose manifest records success
// for the same input, options and tool version is skipped; any other is
// redone from scratch. docs/run.md.
#include "pipeline/pipeline.h"

#include "core/file_io.h"
#include "core/timing.h"
#include "pipeline/manifest.h"
#include "pipeline/process_pool.h"
#include "report/report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <map>
#include <thread>

namespace apo {
namespace fs = std::filesystem;
namespace {

using Json = nlohmann::ordered_json;

struct ScanJob {
  fs::path scan;         // as found under SCANDIR
  std::string relative;  // its path under SCANDIR, generic form: the output folder under OUTDIR
  fs::path outDir;
};

// A file under SCANDIR that is not a scan apo reads, and why.
struct NotProcessed {
  std::string relative;
  std::string reason;
};

struct FolderContents {
  std::vector<ScanJob> scans;
  std::vector<NotProcessed> others;
};

bool isHidden(const fs::path& relative) {
  return std::any_of(relative.begin(), relative.end(), [](const fs::path& part) { return part.string().starts_with('.'); });
}

// Scan files under `scanDir` by extension, sorted by relative path, and every
// other (not hidden) file with the reason it is not one; OUTDIR is not
// searched when it lies inside SCANDIR (its meshes are outputs).
Result<FolderContents> findScans(const fs::path& scanDir, const fs::path& outDir) {
  std::error_code error;
  if (!fs::is_directory(scanDir, error)) return badInput("{}: not a folder", scanDir.string());
  const fs::path outCanonical = fs::weakly_canonical(outDir, error);
  FolderContents found;
  fs::recursive_directory_iterator it(scanDir, fs::directory_options::skip_permission_denied, error);
  if (error) return badInput("{}: cannot list: {}", scanDir.string(), error.message());
  for (; it != fs::recursive_directory_iterator(); it.increment(error)) {
    if (error) return badInput("{}: cannot list: {}", scanDir.string(), error.message());
    if (it->is_directory(error) && fs::weakly_canonical(it->path(), error) == outCanonical) {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file(error)) continue;
    // Lexically, as found: fs::relative would follow a symlinked scan to its
    // target and put its output folder wherever that lies (on the input).
    const fs::path relative = it->path().lexically_relative(scanDir);
    if (relative.empty() || *relative.begin() == "..")
      return internalError("{}: found outside the scan folder {}", it->path().string(), scanDir.string());
    if (isHidden(relative)) continue;
    const Result<ScanFormat> format = formatFromExtension(relative);
    if (format)
      found.scans.push_back({it->path(), relative.generic_string(), outDir / relative});
    else
      found.others.push_back({relative.generic_string(), format.error().message});
  }
  std::sort(found.scans.begin(), found.scans.end(), [](const ScanJob& a, const ScanJob& b) { return a.relative < b.relative; });
  std::sort(found.others.begin(), found.others.end(),
            [](const NotProcessed& a, const NotProcessed& b) { return a.relative < b.relative; });
  return found;
}

// Removes a scan's output folder (one checkOutputFolderIsOurs accepted) so
// that a batch killed at any moment leaves it still recognisably apo's: its
// manifest and log go last. fs::remove_all alone removes in directory order
// and could leave, say, render/ without them, a folder the rerun would then
// have to leave alone.
void removeOurFolder(const fs::path& folder, std::error_code& error) {
  if (!fs::is_directory(fs::symlink_status(folder, error))) return;
  std::vector<fs::path> contents, markers;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    (name == "manifest.json" || name == "run.log" ? markers : contents).push_back(entry.path());
  }
  for (const fs::path& path : contents) fs::remove_all(path, error);
  for (const fs::path& path : markers) fs::remove(path, error);
  fs::remove(folder, error);
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

// Two batches writing the same scan folders would undo each other's work.
// A whole batch locks OUTDIR/.apo-batch.lock, a shard its own
// OUTDIR/.apo-batch-I-of-N.lock (shards write disjoint scan folders, so no
// lock is held by every shard: docs/cluster.md). Having taken its own, each
// probes the other kind's and gives way if one is held; when both start at
// once both may give way, never both run. The lock goes with the process.
class OutputLock {
 public:
  static Result<OutputLock> take(const fs::path& outDir, const std::optional<Shard>& shard) {
    std::error_code error;
    fs::create_directories(outDir, error);
    if (error) return internalError("{}: cannot create the output folder: {}", outDir.string(), error.message());
    const fs::path own = shard ? outDir / fmt::format(".apo-batch-{}-of-{}.lock", shard->index, shard->count)
                               : outDir / kWholeBatchLock;
    const std::string busy = fmt::format("{}: another apo batch is writing to this folder", outDir.string());
    const int fd = open(own.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return internalError("{}: cannot open: {}", own.string(), std::strerror(errno));
    OutputLock lock(fd);
    auto taken = tryLock(fd, own, LOCK_EX);
    if (!taken) return taken.error();
    if (!*taken) return usageError("{}{}", busy, shard ? fmt::format(" (shard {}/{})", shard->index, shard->count) : "");
    if (shard) {
      // Shared: shards probing at the same moment do not see each other.
      auto free = isFree(outDir / kWholeBatchLock, LOCK_SH);
      if (!free) return free.error();
      if (!*free) return usageError("{} without --shard", busy);
      return lock;
    }
    for (const fs::directory_entry& entry : fs::directory_iterator(outDir, error)) {
      const std::string name = entry.path().filename().string();
      if (!name.starts_with(".apo-batch-") || !name.ends_with(".lock")) continue;
      auto free = isFree(entry.path(), LOCK_EX);
      if (!free) return free.error();
      if (!*free) return usageError("{} (a shard: {})", busy, name);
    }
    return lock;
  }
  OutputLock(OutputLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  OutputLock& operator=(OutputLock&&) = delete;
  ~OutputLock() {
    if (fd_ >= 0) close(fd_);
  }

 private:
  static constexpr const char* kWholeBatchLock = ".apo-batch.lock";

  explicit OutputLock(int fd) : fd_(fd) {}

  // False when another process holds a conflicting lock.
  static Result<bool> tryLock(int fd, const fs::path& path, int mode) {
    if (flock(fd, mode | LOCK_NB) == 0) return true;
    if (errno == EWOULDBLOCK) return false;
    return internalError("{}: cannot lock: {}", path.string(), std::strerror(errno));
  }

  // Whether nobody holds a lock on `path` that `mode` conflicts with (an
  // absent file: nobody); the probe's own lock is released at once.
  static Result<bool> isFree(const fs::path& path, int mode) {
    const int fd = open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) return true;
    if (fd < 0) return internalError("{}: cannot open: {}", path.string(), std::strerror(errno));
    auto free = tryLock(fd, path, mode);
    close(fd);
    return free;
  }

  int fd_;
};

// The worker's command line: `apo run SCAN -o DIR --threads N` and the
// batch's stage options.
std::vector<std::string> workerCommand(const BatchSettings& settings, const ScanJob& job, int threads) {
  std::vector<std::string> arguments = {"apo", "run", job.scan.string(), "-o", job.outDir.string(), "--threads",
                                        std::to_string(threads)};
  arguments.insert(arguments.end(), settings.workerArguments.begin(), settings.workerArguments.end());
  return arguments;
}

// The scans, N at a time; the summary counts how each ended.
class Batch {
 public:
  Batch(const BatchSettings& settings, std::vector<ScanJob> jobs)
      : settings_(settings),
        jobs_(std::move(jobs)),
        options_(optionsJson(*settings.options)),
        workers_(std::max(1, std::min(settings.jobs, static_cast<int>(jobs_.size())))),
        pool_(settings.scanTimeout) {
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    threadsEach_ = settings.threads > 0 ? settings.threads : std::max(1, cores / workers_);
    summary_.scans = jobs_.size();
  }

  Status run() {
    spdlog::info("batch: {} scans under {}, {} at a time with {} thread(s) each -> {}", jobs_.size(),
                 settings_.scanDir.string(), workers_, threadsEach_, settings_.outDir.string());
    std::size_t next = 0;
    while (next < jobs_.size() || pool_.running() > 0) {
      while (next < jobs_.size() && static_cast<int>(pool_.running()) < workers_) APO_RETURN_IF_ERROR(startOrSkip(jobs_[next++]));
      if (pool_.running() == 0) continue;
      const Result<ProcessPool::Ended> ended = pool_.waitForOne();
      if (!ended) return ended.error();
      const auto it = running_.find(ended->pid);
      if (it == running_.end()) continue;
      const ScanJob& job = *it->second;
      running_.erase(it);
      recordEnd(job, *ended);
    }
    return okStatus();
  }

  const std::vector<ScanJob>& jobs() const { return jobs_; }
  BatchSummary& summary() { return summary_; }

 private:
  // Skips a scan whose finished run stands, else starts its worker afresh.
  Status startOrSkip(const ScanJob& job) {
    auto digest = sha256OfFile(job.scan);
    const std::optional<Json> previous = manifest::read(job.outDir);
    if (digest && previous && manifest::upToDate(*previous, *digest, options_)) {
      ++summary_.upToDate;
      finish(job, "up to date, skipped");
      return okStatus();
    }
    // Redone from scratch: whatever an earlier, interrupted run left goes.
    if (Status ours = checkOutputFolderIsOurs(job.outDir); !ours.ok()) {
      ++summary_.failed;
      finish(job, "FAILED: " + ours.error().message);
      return okStatus();
    }
    std::error_code error;
    removeOurFolder(job.outDir, error);
    fs::create_directories(job.outDir, error);
    if (error) return internalError("{}: cannot create: {}", job.outDir.string(), error.message());
    auto pid = pool_.start(workerCommand(settings_, job, threadsEach_), job.outDir / "run.log");
    if (!pid) return pid.error();
    running_.emplace(*pid, &job);
    return okStatus();
  }

  // Counts the scan by its manifest; a worker that ended without recording
  // its end (a crash, a kill) gets a manifest saying so.
  void recordEnd(const ScanJob& job, const ProcessPool::Ended& ended) {
    if (!WIFEXITED(ended.status) || WEXITSTATUS(ended.status) != 0) {
      const Json previous = manifest::read(job.outDir).value_or(manifest::placeholder(job.scan));
      const std::string reason = describeEnd(ended, settings_.scanTimeout) + " (see run.log)";
      if (Status s = manifest::write(job.outDir, manifest::markAbnormalEnd(previous, reason)); !s.ok())
        spdlog::warn("{}", s.error().message);
    }
    const std::optional<Json> written = manifest::read(job.outDir);
    if (written && written->value("status", "") == "succeeded") {
      ++summary_.succeeded;
      finish(job, "succeeded");
      return;
    }
    ++summary_.failed;
    const Json error = written && written->contains("error") ? (*written)["error"] : Json();
    finish(job, error.is_object() ? fmt::format("FAILED at {}: {}", error.value("stage", "?"), error.value("message", "?"))
                                  : "FAILED");
  }

  void finish(const ScanJob& job, const std::string& outcome) {
    ++done_;
    spdlog::info("[{}/{}] {}: {}", done_, jobs_.size(), job.relative, outcome);
  }

  const BatchSettings& settings_;
  const std::vector<ScanJob> jobs_;
  const Json options_;
  const int workers_;
  int threadsEach_ = 1;
  ProcessPool pool_;
  std::map<pid_t, const ScanJob*> running_;
  std::size_t done_ = 0;
  BatchSummary summary_;
};

Json summaryJson(const BatchSummary& summary, const std::vector<NotProcessed>& others) {
  Json notProcessed = Json::array();
  for (const NotProcessed& other : others) notProcessed.push_back({{"file", other.relative}, {"reason", other.reason}});
  return {{"scans", summary.scans},
          {"succeeded", summary.succeeded},
          {"failed", summary.failed},
          {"skipped_up_to_date", summary.upToDate},
          {"not_processed", summary.notProcessed},
          {"not_processed_files", notProcessed},
          {"seconds", summary.seconds}};
}

// index.html's rows: each scan's manifest (an empty object when it has
// none), then the files not processed with their reasons.
std::vector<BatchRow> batchRows(const std::vector<ScanJob>& jobs, const std::vector<NotProcessed>& others) {
  std::vector<BatchRow> rows;
  for (const ScanJob& job : jobs) {
    const std::optional<Json> found = manifest::read(job.outDir);
    rows.push_back({job.relative, found ? nlohmann::json::parse(found->dump()) : nlohmann::json::object()});
  }
  for (const NotProcessed& other : others)
    rows.push_back({other.relative, {{"status", "not_processed"},
                                     {"input", {{"name", fs::path(other.relative).filename().string()}}},
                                     {"reason", other.reason}}});
  return rows;
}

Status writeBatchPages(const fs::path& outDir, const std::vector<BatchRow>& rows, const Json& summary) {
  const nlohmann::json page = nlohmann::json::parse(summary.dump());
  APO_RETURN_IF_ERROR(writeFileAtomically(outDir / "index.html", batchIndexHtml(rows, page)));
  return writeFileAtomically(outDir / "summary.json", summary.dump(2) + "\n");
}

constexpr const char* kShardsFolder = ".apo-shards";

fs::path shardSummaryPath(const fs::path& outDir, const Shard& shard) {
  return outDir / kShardsFolder / fmt::format("{}-of-{}.json", shard.index, shard.count);
}

// The scans found, or those of one shard.
std::vector<ScanJob> shareOf(std::vector<ScanJob> scans, const std::optional<Shard>& shard) {
  if (!shard) return scans;
  std::erase_if(scans, [&](const ScanJob& job) { return shardOf(job.relative, shard->count) != shard->index; });
  return scans;
}

// "I/N" -> N; 0 when unreadable.
int shardCount(const Json& summary) {
  const std::string shard = summary.value("shard", "");
  const std::size_t slash = shard.find('/');
  return slash == std::string::npos ? 0 : std::atoi(shard.c_str() + slash + 1);
}

// The shards' own summaries under OUTDIR/.apo-shards, by file name: those of
// the latest partition only (the N of the newest summary), so that the shards
// of an earlier run with another N are not counted twice; those left out are
// named in the log.
std::vector<Json> shardSummaries(const fs::path& outDir) {
  struct Found {
    std::string name;
    fs::file_time_type written;
    Json summary;
  };
  std::vector<Found> found;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(outDir / kShardsFolder, error)) {
    if (entry.path().extension() != ".json") continue;
    auto text = readFileBytes(entry.path());
    Json summary = text ? Json::parse(*text, nullptr, false) : Json();
    if (summary.is_discarded() || !summary.is_object() || shardCount(summary) <= 0) {
      spdlog::warn("batch: {}: not a shard summary, left out", entry.path().string());
      continue;
    }
    found.push_back({entry.path().filename().string(), entry.last_write_time(error), std::move(summary)});
  }
  if (found.empty()) return {};
  const auto newest = std::max_element(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.written < b.written; });
  const int count = shardCount(newest->summary);
  std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.name < b.name; });
  std::vector<Json> summaries;
  for (Found& f : found) {
    if (shardCount(f.summary) == count)
      summaries.push_back(std::move(f.summary));
    else
      spdlog::warn("batch: {}: a shard of an earlier partition (the latest is {} shards), left out", f.name, count);
  }
  return summaries;
}

Result<FolderContents> scansOrError(const BatchSettings& settings) {
  auto found = findScans(settings.scanDir, settings.outDir);
  if (!found) return found.error();
  for (const NotProcessed& other : found->others) spdlog::warn("batch: {} not processed: {}", other.relative, other.reason);
  if (found->scans.empty())
    return badInput("{}: no scans found (extensions: {}){}", settings.scanDir.string(), scanExtensionList(),
                    found->others.empty() ? "" : fmt::format("; {} other files not processed", found->others.size()));
  return found;
}

}  // namespace

Result<BatchSummary> runBatch(const BatchSettings& settings) {
  const Stopwatch stopwatch;
  auto lock = OutputLock::take(settings.outDir, settings.shard);
  if (!lock) return lock.error();
  auto found = scansOrError(settings);
  if (!found) return found.error();
  Batch batch(settings, shareOf(std::move(found->scans), settings.shard));
  APO_RETURN_IF_ERROR(batch.run());
  BatchSummary& summary = batch.summary();
  summary.notProcessed = found->others.size();
  summary.seconds = stopwatch.seconds();
  Json written = summaryJson(summary, found->others);
  if (settings.shard) {
    written["shard"] = fmt::format("{}/{}", settings.shard->index, settings.shard->count);
    const fs::path path = shardSummaryPath(settings.outDir, *settings.shard);
    std::error_code error;
    fs::create_directories(path.parent_path(), error);
    APO_RETURN_IF_ERROR(writeFileAtomically(path, written.dump(2) + "\n"));
  } else {
    APO_RETURN_IF_ERROR(writeBatchPages(settings.outDir, batchRows(batch.jobs(), found->others), written));
  }
  spdlog::info("batch{}: {} succeeded, {} failed, {} up to date, {} files not processed in {:.1f} s -> {}",
               settings.shard ? fmt::format(" shard {}/{}", settings.shard->index, settings.shard->count) : "",
               summary.succeeded, summary.failed, summary.upToDate, summary.notProcessed, summary.seconds,
               settings.shard ? shardSummaryPath(settings.outDir, *settings.shard).string()
                              : (settings.outDir / "index.html").string());
  return summary;
}

Result<BatchSummary> mergeBatch(const BatchSettings& settings) {
  auto found = scansOrError(settings);
  if (!found) return found.error();
  const std::vector<BatchRow> rows = batchRows(found->scans, found->others);
  BatchSummary summary;
  summary.scans = found->scans.size();
  summary.notProcessed = found->others.size();
  for (std::size_t i = 0; i < found->scans.size(); ++i)
    ++(rows[i].manifest.value("status", "") == "succeeded" ? summary.succeeded : summary.failed);
  Json shards = Json::array();
  for (const Json& shard : shardSummaries(settings.outDir)) {
    summary.seconds += shard.value("seconds", 0.0);
    summary.upToDate += shard.value("skipped_up_to_date", std::uint64_t{0});
    shards.push_back({{"shard", shard.value("shard", "")}, {"scans", shard.value("scans", 0)},
                      {"succeeded", shard.value("succeeded", 0)}, {"failed", shard.value("failed", 0)},
                      {"skipped_up_to_date", shard.value("skipped_up_to_date", 0)}, {"seconds", shard.value("seconds", 0.0)}});
  }
  Json written = summaryJson(summary, found->others);
  written["seconds_are"] = "the sum of the shards' wall times";
  written["shards"] = std::move(shards);
  APO_RETURN_IF_ERROR(writeBatchPages(settings.outDir, rows, written));
  spdlog::info("batch merge: {} scans, {} succeeded, {} failed, from {} shard summaries -> {}", summary.scans,
               summary.succeeded, summary.failed, written["shards"].size(), (settings.outDir / "index.html").string());
  return summary;
}

int shardOf(std::string_view relativePath, int count) {
  const std::string digest = sha256OfBytes(relativePath);  // hex
  const std::uint64_t first8 = std::stoull(digest.substr(0, 16), nullptr, 16);
  return static_cast<int>(first8 % static_cast<std::uint64_t>(count));
}

Result<Shard> parseShard(std::string_view text) {
  const std::size_t slash = text.find('/');
  Shard shard;
  const auto number = [](std::string_view digits, int& out) {
    if (digits.empty() || digits.size() > 6 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
      return false;
    out = std::stoi(std::string(digits));
    return true;
  };
  if (slash == std::string_view::npos || !number(text.substr(0, slash), shard.index) ||
      !number(text.substr(slash + 1), shard.count) || shard.count < 1 || shard.count > kMostShards ||
      shard.index >= shard.count)
    return usageError("--shard {}: expected I/N with 0 <= I < N <= {} (Slurm: $SLURM_ARRAY_TASK_ID/N)", text, kMostShards);
  return shard;
}

}  // namespace apo
