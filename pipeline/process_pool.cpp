#include "pipeline/process_pool.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

namespace apo {

Result<pid_t> ProcessPool::start(const std::vector<std::string>& arguments, const std::filesystem::path& logPath) {
  // Everything the child needs is prepared before fork: after it, only
  // async-signal-safe calls.
  std::vector<char*> argv;
  for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  const std::string log = logPath.string();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) return internalError("cannot start a worker process: {}", std::strerror(errno));
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);  // the parent died before prctl
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDERR_FILENO);
      dup2(fd, STDOUT_FILENO);
      close(fd);
    }
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  workers_.emplace(pid, Worker{});
  return pid;
}

void ProcessPool::stopOverdueWorkers() {
  for (auto& [pid, worker] : workers_)
    if (!worker.timedOut && worker.started.seconds() > timeoutSeconds_) {
      kill(pid, SIGKILL);
      worker.timedOut = true;
    }
}

Result<ProcessPool::Ended> ProcessPool::waitForOne() {
  if (workers_.empty()) return internalError("waiting for a worker, but none is running");
  for (;;) {
    int status = 0;
    // With a time limit, poll so that a worker over it can be stopped; without, block.
    const pid_t pid = waitpid(-1, &status, timeoutSeconds_ > 0.0 ? WNOHANG : 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      return internalError("waiting for the workers: {}", std::strerror(errno));
    }
    if (pid == 0) {
      stopOverdueWorkers();
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    const auto it = workers_.find(pid);
    if (it == workers_.end()) continue;  // not one of ours
    const Ended ended{pid, status, it->second.timedOut};
    workers_.erase(it);
    return ended;
  }
}

std::string describeEnd(const ProcessPool::Ended& ended, double timeoutSeconds) {
  if (ended.timedOut) return fmt::format("the scan took longer than --scan-timeout {} s and was stopped", timeoutSeconds);
  if (WIFSIGNALED(ended.status))
    return fmt::format("the worker was killed by signal {} ({})", WTERMSIG(ended.status), strsignal(WTERMSIG(ended.status)));
  return fmt::format("the worker exited with code {}", WEXITSTATUS(ended.status));
}

}  // namespace apo
