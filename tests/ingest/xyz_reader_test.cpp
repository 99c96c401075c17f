#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <cmath>
#include <string>

namespace apo {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

std::string xyzFailure(std::string_view bytes) { return test::readerFailure(readers::readXyz, bytes); }

TEST(XyzReader, ReadsThreeColumnsSkippingCommentsAndBlankLines) {
  const Scan scan = readers::readXyz(
      "# exported by a scanner\r\n"
      "// another comment style\r\n"
      "\r\n"
      "1 2 3\r\n"
      "  -0.5\t1e2 +4  \r\n"
      "\r\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1, 2, 3));
  EXPECT_EQ(scan.points.positions[1], Vec3f(-0.5f, 100, 4));
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_FALSE(scan.points.hasColors());
  EXPECT_FALSE(scan.points.hasIntensities());
  EXPECT_FALSE(scan.isMesh());
}

TEST(XyzReader, ReadsSixColumnsAsNormalsLikeCgalXyzn) {
  const Scan scan = readers::readXyz(
      "0.25 0.5 0.75 0 0 1\n"
      "1 1 1 0 -1 0\n");
  ASSERT_EQ(scan.points.size(), 2u);
  ASSERT_TRUE(scan.points.hasNormals());
  EXPECT_EQ(scan.points.positions[0], Vec3f(0.25f, 0.5f, 0.75f));
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[1], Vec3f(0, -1, 0));
  EXPECT_FALSE(scan.points.hasColors());
}

TEST(XyzReader, ReadsPtsCountLineWithIntensityAndColors) {
  const Scan scan = readers::readXyz(
      "2\n"
      "1.5 2.5 3.5 -1200 255 128 0\n"
      "4 5 6 17 0 1 2\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1.5f, 2.5f, 3.5f));
  EXPECT_EQ(scan.points.positions[1], Vec3f(4, 5, 6));
  ASSERT_TRUE(scan.points.hasIntensities());
  EXPECT_EQ(scan.points.intensities[0], -1200.0f);
  EXPECT_EQ(scan.points.intensities[1], 17.0f);
  ASSERT_TRUE(scan.points.hasColors());
  EXPECT_EQ(scan.points.colors[0], (Rgb8{255, 128, 0}));
  EXPECT_EQ(scan.points.colors[1], (Rgb8{0, 1, 2}));
  EXPECT_FALSE(scan.points.hasNormals());
}

TEST(XyzReader, ReadsSixColumnsAsColorsAfterPtsCountLine) {
  const Scan scan = readers::readXyz("1\n1 2 3 10 20 30\n");
  ASSERT_EQ(scan.points.size(), 1u);
  EXPECT_FALSE(scan.points.hasNormals());
  ASSERT_TRUE(scan.points.hasColors());
  EXPECT_EQ(scan.points.colors[0], (Rgb8{10, 20, 30}));
}

TEST(XyzReader, ReadsFourColumnsAsIntensity) {
  const Scan scan = readers::readXyz("1 2 3 0.5\n4 5 6 0.25\n");
  ASSERT_EQ(scan.points.intensities.size(), 2u);
  EXPECT_EQ(scan.points.intensities[0], 0.5f);
  EXPECT_EQ(scan.points.intensities[1], 0.25f);
}

TEST(XyzReader, PointCountIsOnlyAHint) {
  const Scan scan = readers::readXyz("4000000000\n1 2 3\n");
  EXPECT_EQ(scan.points.size(), 1u);
}

TEST(XyzReader, KeepsNanAndInfinityCoordinates) {
  const Scan scan = readers::readXyz("nan 1 2\n3 inf -inf\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_TRUE(std::isnan(scan.points.positions[0].x()));
  EXPECT_EQ(scan.points.positions[1].y(), INFINITY);
  EXPECT_EQ(scan.points.positions[1].z(), -INFINITY);
}

TEST(XyzReader, FailsOnEmptyFile) { EXPECT_THAT(xyzFailure(""), StartsWith("line 1: empty file")); }

TEST(XyzReader, FailsOnOnlyComments) {
  EXPECT_THAT(xyzFailure("# nothing\n\n// here\n"), StartsWith("line 3: no points"));
}

TEST(XyzReader, FailsOnCountLineWithoutPoints) {
  EXPECT_THAT(xyzFailure("12\n# no data\n"), StartsWith("line 2: no points"));
}

TEST(XyzReader, FailsOnNonNumericToken) {
  const std::string message = xyzFailure("1 2 3\n4 five 6\n");
  EXPECT_THAT(message, StartsWith("line 2: "));
  EXPECT_THAT(message, HasSubstr("non-numeric"));
  EXPECT_THAT(message, HasSubstr("'five'"));
}

TEST(XyzReader, FailsOnInconsistentColumns) {
  EXPECT_THAT(xyzFailure("1 2 3\n4 5 6\n# c\n7 8 9 0 0 1\n"), StartsWith("line 4: expected 3 columns, got 6"));
}

TEST(XyzReader, FailsOnUnsupportedColumnCount) {
  const std::string message = xyzFailure("# header\n1 2 3 4 5\n");
  EXPECT_THAT(message, StartsWith("line 2: "));
  EXPECT_THAT(message, HasSubstr("got 5"));
}

TEST(XyzReader, FailsOnNegativePointCount) {
  EXPECT_THAT(xyzFailure("-3\n1 2 3\n"), StartsWith("line 1: negative point count -3"));
}

TEST(XyzReader, FailsOnNonIntegerPointCount) {
  const std::string message = xyzFailure("2.5\n1 2 3\n");
  EXPECT_THAT(message, StartsWith("line 1: "));
  EXPECT_THAT(message, HasSubstr("'2.5'"));
}

TEST(XyzReader, FailsOnColorOutOfRange) {
  const std::string message = xyzFailure("1\n1 2 3 0 300 0 0\n");
  EXPECT_THAT(message, StartsWith("line 2: "));
  EXPECT_THAT(message, HasSubstr("'300' out of range 0..255"));
}

}  // namespace
}  // namespace apo
