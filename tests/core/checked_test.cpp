// Checked<Options>: made only by the options' own check, and its parts
// checked with the whole.
#include "core/checked.h"

#include <gtest/gtest.h>

namespace apo {

struct Depths {
  int least = 0, most = 4;
};
struct Stages {
  Depths depths;
  int retries = 1;
};

template <>
Result<Checked<Depths>> check(const Depths& depths) {
  if (depths.least > depths.most) return usageError("--least ({}) above --most ({})", depths.least, depths.most);
  return Checked<Depths>(depths);
}

template <>
Result<Checked<Stages>> check(const Stages& stages) {
  if (auto depths = check(stages.depths); !depths) return depths.error();
  if (stages.retries < 0) return usageError("--retries must not be negative, got {}", stages.retries);
  return Checked<Stages>(stages);
}

namespace {

// Usable only where an unchecked value cannot be passed.
int span(const Checked<Depths>& depths) { return depths->most - depths->least; }

TEST(Checked, HoldsTheValueItsCheckAccepted) {
  auto depths = check(Depths{1, 6});
  ASSERT_TRUE(depths.ok());
  EXPECT_EQ(span(*depths), 5);
  EXPECT_EQ((**depths).least, 1);
}

TEST(Checked, RefusesWhatItsCheckRefuses) {
  auto depths = check(Depths{7, 6});
  ASSERT_FALSE(depths.ok());
  EXPECT_EQ(depths.error().kind, ErrorKind::Usage);
  EXPECT_EQ(depths.error().message, "--least (7) above --most (6)");
}

TEST(Checked, AWholeIsRefusedForABadPartAndGivesItsPartsChecked) {
  EXPECT_FALSE(check(Stages{Depths{5, 2}, 0}).ok());
  EXPECT_FALSE(check(Stages{Depths{0, 2}, -1}).ok());
  auto stages = check(Stages{Depths{2, 9}, 3});
  ASSERT_TRUE(stages.ok());
  EXPECT_EQ(span(partOf(*stages, &Stages::depths)), 7);
}

// Not constructible from a plain value: only check<Depths> makes one.
static_assert(!std::is_constructible_v<Checked<Depths>, Depths>);
static_assert(!std::is_default_constructible_v<Checked<Depths>>);

}  // namespace
}  // namespace apo
