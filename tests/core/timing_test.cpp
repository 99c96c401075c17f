#include "core/timing.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace apo {
namespace {

TEST(Stopwatch, MeasuresElapsedTime) {
  Stopwatch watch;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_GE(watch.seconds(), 0.019);
  EXPECT_LT(watch.seconds(), 5.0);
}

TEST(PeakResidentBytes, GrowsWithTouchedMemory) {
  const std::uint64_t before = peakResidentBytes();
  std::vector<char> block(256u << 20, 1);  // touched: resident
  const std::uint64_t after = peakResidentBytes();
  EXPECT_GE(after, before);
  EXPECT_GE(after, block.size());
}

}  // namespace
}  // namespace apo
