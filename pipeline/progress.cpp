#include "pipeline/progress.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <unistd.h>

namespace apo {

ProgressStyle progressStyleForStderr(bool quiet) {
  if (quiet) return ProgressStyle::Quiet;
  return isatty(STDERR_FILENO) ? ProgressStyle::LiveLine : ProgressStyle::LogLines;
}

void Progress::startStage(const std::string& name) {
  stopTicker();
  ++stage_;
  name_ = name;
  fraction_ = -1.0;
  printedTenth_ = -1;
  started_ = std::chrono::steady_clock::now();
  if (style_ == ProgressStyle::LogLines) spdlog::info("[{}/{}] {}: started", stage_, stageCount_, name_);
  if (style_ != ProgressStyle::LiveLine) return;
  drawLine(false, "");
  stopping_ = false;
  // Redraws the line twice a second, so that a long step shows it is alive.
  ticker_ = std::thread([this] {
    std::unique_lock lock(mutex_);
    while (!wake_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stopping_; })) drawLine(false, "");
  });
}

void Progress::setFraction(double fraction) {
  fraction_ = fraction;
  if (style_ != ProgressStyle::LogLines) return;
  // A log line per tenth reached, however often the stage reports.
  const int tenth = static_cast<int>(10.0 * fraction);
  int printed = printedTenth_.load();
  while (tenth > printed)
    if (printedTenth_.compare_exchange_weak(printed, tenth)) {
      spdlog::info("[{}/{}] {}: {}%", stage_, stageCount_, name_, 10 * tenth);
      break;
    }
}

void Progress::finishStage(const std::string& outcome) {
  stopTicker();
  if (style_ == ProgressStyle::LiveLine) drawLine(true, outcome);
  if (style_ == ProgressStyle::LogLines) spdlog::info("[{}/{}] {}: {}", stage_, stageCount_, name_, outcome);
}

void Progress::drawLine(bool final, const std::string& outcome) {
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const double fraction = fraction_;
  std::string line = fmt::format("[{}/{}] {:<12}", stage_, stageCount_, name_);
  if (final)
    line += outcome;
  else
    line += fraction >= 0.0 ? fmt::format("{:3.0f}%  {:.1f} s", 100.0 * fraction, seconds) : fmt::format("{:.1f} s", seconds);
  // \r and erase-to-end: the line is redrawn in place.
  std::fprintf(stderr, "\r%s\033[K%s", line.c_str(), final ? "\n" : "");
  std::fflush(stderr);
}

void Progress::stopTicker() {
  if (!ticker_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  ticker_.join();
}

}  // namespace apo
