#include "ingest/parse_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace apo::parse {
namespace {
using ::testing::HasSubstr;

std::string failureMessage(const std::function<void()>& body) {
  try {
    body();
  } catch (const ParseFailure& failure) {
    return failure.what();
  }
  return "(no failure)";
}

TEST(TextCursor, CountsLinesAcrossAllLineEndings) {
  TextCursor cursor("a\r\nb\rc\nd");
  std::string_view line;
  std::vector<std::string> lines;
  while (cursor.next(line)) lines.emplace_back(line);
  EXPECT_EQ(lines, (std::vector<std::string>{"a", "b", "c", "d"}));
  EXPECT_EQ(cursor.lineNumber(), 4u);
  EXPECT_TRUE(cursor.atEnd());
}

TEST(TextCursor, NonNumericTokenNamesLineTokenAndContext) {
  TextCursor cursor("1 2 3\n4 x5 6\n");
  std::string_view line;
  cursor.next(line);
  cursor.next(line);
  const std::string message = failureMessage([&] { cursor.number("x5", "point 2"); });
  EXPECT_THAT(message, HasSubstr("line 2"));
  EXPECT_THAT(message, HasSubstr("'x5'"));
  EXPECT_THAT(message, HasSubstr("point 2"));
}

TEST(ParseNumber, AcceptsPlusNanInfAndOverflow) {
  double value = 0;
  EXPECT_TRUE(parseNumber("+1.5", value));
  EXPECT_EQ(value, 1.5);
  EXPECT_TRUE(parseNumber("nan", value));
  EXPECT_TRUE(std::isnan(value));
  EXPECT_TRUE(parseNumber("-inf", value));
  EXPECT_TRUE(std::isinf(value) && value < 0);
  EXPECT_TRUE(parseNumber("1e999", value));
  EXPECT_TRUE(std::isinf(value));
  EXPECT_TRUE(parseNumber("1e-400", value));
  EXPECT_EQ(value, 0.0);
  float single = 1;
  EXPECT_TRUE(parseNumber("1e-50", single));
  EXPECT_EQ(single, 0.0f);
  EXPECT_TRUE(parseNumber("-1e50", single));
  EXPECT_TRUE(std::isinf(single) && single < 0);
  EXPECT_FALSE(parseNumber("1.5x", value));
  EXPECT_FALSE(parseNumber("", value));
}

TEST(ParseInteger, RejectsFractionsAndGarbage) {
  std::int64_t value = 0;
  EXPECT_TRUE(parseInteger("-42", value));
  EXPECT_EQ(value, -42);
  EXPECT_FALSE(parseInteger("4.0", value));
  EXPECT_FALSE(parseInteger("99999999999999999999999", value));
}

TEST(SplitWhitespace, SplitsOnTabsAndRuns) {
  std::vector<std::string_view> tokens;
  splitWhitespace("  a\t\tb  c \r", tokens);
  EXPECT_EQ(tokens, (std::vector<std::string_view>{"a", "b", "c"}));
}

TEST(BinaryCursor, ReadsBothEndiannesses) {
  const std::string bytes("\x01\x02\x03\x04\x01\x02\x03\x04", 8);
  BinaryCursor cursor(bytes, 0);
  EXPECT_EQ(cursor.read<std::uint32_t>(false, "x"), 0x04030201u);
  EXPECT_EQ(cursor.read<std::uint32_t>(true, "x"), 0x01020304u);
  EXPECT_EQ(cursor.remaining(), 0u);
}

TEST(BinaryCursor, TruncationNamesTheByteOffset) {
  const std::string bytes(6, '\0');
  BinaryCursor cursor(bytes, 4);
  const std::string message = failureMessage([&] { cursor.read<double>(false, "vertex 0"); });
  EXPECT_THAT(message, HasSubstr("byte 4"));
  EXPECT_THAT(message, HasSubstr("truncated vertex 0"));
}

TEST(CheckCountFits, RefusesHugeClaimsWithoutOverflow) {
  EXPECT_NO_THROW(checkCountFits(10, 12, 120, "vertices", 0));
  const std::string message = failureMessage([] { checkCountFits(4000000000ull, 12, 100, "vertices", 50); });
  EXPECT_THAT(message, HasSubstr("4000000000 vertices"));
  EXPECT_THAT(message, HasSubstr("byte 50"));
  EXPECT_THROW(checkCountFits(~0ull, ~0ull, 100, "x", 0), ParseFailure);
}

}  // namespace
}  // namespace apo::parse
