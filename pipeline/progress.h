// What `apo run` shows while it works: on a terminal, one live line per stage
// (elapsed seconds, and a percentage where the stage reports one), ended by
// its result; elsewhere (a log file, a batch's child), plain log lines at the
// start and end of each stage. Quiet: nothing but errors.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace apo {

enum class ProgressStyle { LiveLine, LogLines, Quiet };

// The style for stderr: a live line on a terminal, log lines otherwise.
ProgressStyle progressStyleForStderr(bool quiet);

class Progress {
 public:
  Progress(ProgressStyle style, int stageCount) : style_(style), stageCount_(stageCount) {}
  ~Progress() { stopTicker(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void startStage(const std::string& name);
  // Fraction done of the current stage, in [0, 1]; callable from any thread.
  void setFraction(double fraction);
  void finishStage(const std::string& outcome);  // "12.3 s, 1.2 GiB"; "failed", ...

 private:
  void drawLine(bool final, const std::string& outcome);
  void stopTicker();

  ProgressStyle style_;
  int stageCount_;
  int stage_ = 0;
  std::string name_;
  std::chrono::steady_clock::time_point started_;
  std::atomic<double> fraction_{-1.0};
  std::atomic<int> printedTenth_{-1};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread ticker_;
};

}  // namespace apo
