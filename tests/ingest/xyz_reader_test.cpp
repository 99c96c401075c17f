#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

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

// ---- CSV-style exports -----------------------------------------------------------

TEST(XyzReader, ReadsCommaSemicolonAndTabSeparatedValues) {
  for (const char* text : {"1.5,2,3\n4,5.25,6\n", "1.5;2;3\n4;5.25;6\n", "1.5\t2\t3\n4\t5.25\t6\n",
                           "1.5, 2, 3\r\n4 ,5.25 , 6\r\n"}) {
    const Scan scan = readers::readXyz(text);
    ASSERT_EQ(scan.points.size(), 2u) << text;
    EXPECT_EQ(scan.points.positions[0], Vec3f(1.5f, 2, 3)) << text;
    EXPECT_EQ(scan.points.positions[1], Vec3f(4, 5.25f, 6)) << text;
  }
}

TEST(XyzReader, AHeaderNamesTheColumnsInAnyOrderAndCase) {
  const Scan scan = readers::readXyz(
      "Intensity,NZ,X,ny,Y,nx,Z,R,G,B,Time\n"
      "7,1,0.5,0,1.5,0,2.5,255,128,0,12.5\n"
      "8,0,1,1,2,0,3,0,0,255,13.5\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(0.5f, 1.5f, 2.5f));
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[1], Vec3f(0, 1, 0));
  EXPECT_EQ(scan.points.colors[0], (Rgb8{255, 128, 0}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{7, 8}));
  // The column it does not know is said, not silently dropped.
  EXPECT_THAT(scan.readNotes, testing::Contains(HasSubstr("columns not kept (header line 1): 'Time'")));
}

TEST(XyzReader, ReadsCloudComparesCommentedHeader) {
  const Scan scan = readers::readXyz("//X,Y,Z,R,G,B\n1,2,3,10,20,30\n");
  ASSERT_EQ(scan.points.size(), 1u);
  EXPECT_EQ(scan.points.colors[0], (Rgb8{10, 20, 30}));
  // A comment that only mentions a column name is a comment.
  const Scan plain = readers::readXyz("# Generated by X\n1 2 3\n");
  EXPECT_EQ(plain.points.size(), 1u);
}

TEST(XyzReader, RefusesHeadersWithoutXyzOrWithHalfANormal) {
  EXPECT_THAT(xyzFailure("x,y,intensity\n1,2,3\n"), StartsWith("line 1: the header names no x, y and z columns"));
  EXPECT_THAT(xyzFailure("x y z nx ny\n1 2 3 0 0\n"), StartsWith("line 1: the header names part of a normal"));
  EXPECT_THAT(xyzFailure("x,y,z,x\n1,2,3,4\n"), StartsWith("line 1: column 'x' named twice"));
  EXPECT_THAT(xyzFailure("x,y,z\n"), StartsWith("line 1: no points after the header"));
  EXPECT_THAT(xyzFailure("x,y,z\n1,,3\n"), StartsWith("line 2: "));
  EXPECT_THAT(xyzFailure("x,y,z\n1,2,3,4\n"), StartsWith("line 2: expected 3 columns, got 4"));
}

TEST(XyzReader, GeoreferencedTextKeepsMillimetresInALocalFrame) {
  std::string text = "x,y,z\n";
  for (int i = 0; i < 10; ++i) text += fmt::format("{:.3f},{:.3f},{:.3f}\n", 512000.0 + i * 0.001, 5403000.0 + i, 300.5);
  const Scan scan = readers::readXyz(text);
  EXPECT_EQ(scan.origin, (std::array<double, 3>{512000.0, 5403005.0, 301.0}));  // centres rounded half away from zero
  for (int i = 0; i < 10; ++i) EXPECT_NEAR(scan.points.positions[i].x(), i * 0.001, 1e-6) << i;
}

}  // namespace
}  // namespace apo
