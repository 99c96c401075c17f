// Internal to pipeline/: worker processes for `apo batch`. Each worker runs
// this executable (/proc/self/exe) with its own arguments, its stdout and
// stderr to a log file, and dies with its parent (PR_SET_PDEATHSIG), so a
// killed batch leaves no worker writing behind it.
#pragma once

#include "core/error.h"
#include "core/timing.h"

#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace apo {

class ProcessPool {
 public:
  // How a worker ended: its wait status, and whether the pool stopped it for
  // running longer than the time limit.
  struct Ended {
    pid_t pid = 0;
    int status = 0;
    bool timedOut = false;
  };

  // `timeoutSeconds` > 0: workers running longer are killed (SIGKILL).
  explicit ProcessPool(double timeoutSeconds) : timeoutSeconds_(timeoutSeconds) {}

  // Starts a worker; `arguments` are its argv (argv[0] included).
  Result<pid_t> start(const std::vector<std::string>& arguments, const std::filesystem::path& logPath);

  // Waits until a worker ends (there must be one running), stopping those
  // over the time limit meanwhile.
  Result<Ended> waitForOne();

  std::size_t running() const { return workers_.size(); }

 private:
  struct Worker {
    Stopwatch started;
    bool timedOut = false;
  };
  void stopOverdueWorkers();

  double timeoutSeconds_;
  std::map<pid_t, Worker> workers_;
};

// A worker's end in words: the time limit, the signal that killed it, or its
// exit code.
std::string describeEnd(const ProcessPool::Ended& ended, double timeoutSeconds);

}  // namespace apo
