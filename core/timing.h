// Wall-clock and memory figures for reports.
#pragma once

#include <chrono>
#include <cstdint>

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

}  // namespace apo
