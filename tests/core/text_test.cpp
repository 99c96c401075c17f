#include "core/text.h"

#include <gtest/gtest.h>

namespace apo {
namespace {

TEST(GroupedDigits, CommasEveryThreeDigitsFromTheRight) {
  EXPECT_EQ(groupedDigits(0), "0");
  EXPECT_EQ(groupedDigits(999), "999");
  EXPECT_EQ(groupedDigits(1000), "1,000");
  EXPECT_EQ(groupedDigits(281068), "281,068");
  EXPECT_EQ(groupedDigits(1206528), "1,206,528");
  EXPECT_EQ(groupedDigits(18446744073709551615ull), "18,446,744,073,709,551,615");
}

}  // namespace
}  // namespace apo
