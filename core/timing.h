// Wall-clock and memory figures for reports, and progress of long steps.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>

namespace apo {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Peak resident set size of this process so far, in bytes (getrusage).
std::uint64_t peakResidentBytes();

// A stage's own peak: resetPeakResident() before it, peakResidentSinceReset()
// after (Linux: /proc/self/clear_refs and VmHWM). Where the reset is refused,
// the peak is the process's since its start.
void resetPeakResident();
std::uint64_t peakResidentSinceReset();

// Fraction of a long step done, in [0, 1], reported as it goes (possibly from
// worker threads, so it must be thread-safe); it never changes a result.
using ProgressCallback = std::function<void(double)>;

inline void reportProgress(const ProgressCallback& callback, double fraction) {
  if (callback) callback(fraction);
}

}  // namespace apo
