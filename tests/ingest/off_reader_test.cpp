#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <cmath>
#include <string>
#include <vector>

namespace apo {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;

std::string offFailure(std::string_view bytes) { return test::readerFailure(readers::readOff, bytes); }

// The corners of a unit square, long enough that the header checks (at
// least 6 bytes per vertex, 8 per face) pass with a few faces declared.
constexpr std::string_view kSquareVertices = "0.0 0.0 0.0\n1.0 0.0 0.0\n1.0 1.0 0.0\n0.0 1.0 0.0\n";

TEST(OffReader, ReadsTrianglesWithCommentsAndCrlf) {
  const Scan scan = readers::readOff(
      "OFF\r\n"
      "# a square\r\n"
      "4 2 0  # counts\r\n"
      "\r\n"
      "0 0 0\r\n"
      "1 0 0 # first corner\r\n"
      "1 1 0\r\n"
      "0 1 0.5\r\n"
      "3 0 1 2\r\n"
      "3 0 2 3\r\n");
  ASSERT_EQ(scan.points.size(), 4u);
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.positions[3], Vec3f(0, 1, 0.5f));
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{0, 2, 3}));
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_FALSE(scan.points.hasColors());
}

TEST(OffReader, FanTriangulatesPolygons) {
  const Scan scan = readers::readOff(
      "OFF\n5 2 0\n0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 1 0\n"
      "4 0 1 2 3\n"
      "5 4 3 2 1 0\n");
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{0, 2, 3}, Triangle{4, 3, 2},
                                          Triangle{4, 2, 1}, Triangle{4, 1, 0}));
}

TEST(OffReader, ReadsCountsOnTheKeywordLine) {
  const Scan scan = readers::readOff(std::string("OFF 4 1 0\n") + std::string(kSquareVertices) + "3 1 2 3\n");
  EXPECT_EQ(scan.points.size(), 4u);
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{1, 2, 3}));
}

TEST(OffReader, ReadsElementsSplitAcrossLines) {
  const Scan scan = readers::readOff(
      "OFF\n3\n1 0\n"
      "0 0\n0\n"
      "1\n0 0\n"
      "0\n1 0\n"
      "3 0\n1\n2\n");
  ASSERT_EQ(scan.points.size(), 3u);
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.positions[2], Vec3f(0, 1, 0));
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}));
}

TEST(OffReader, ReadsNoffVertexNormals) {
  const Scan scan = readers::readOff(
      "NOFF\n3 1 0\n"
      "0 0 0 0 0 1\n"
      "1 0 0 0 0.5 0.5\n"
      "0 1 0 -1 0 0\n"
      "3 0 1 2\n");
  ASSERT_TRUE(scan.points.hasNormals());
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[1], Vec3f(0, 0.5f, 0.5f));
  EXPECT_EQ(scan.points.normals[2], Vec3f(-1, 0, 0));
}

TEST(OffReader, ReadsCoffIntegerAndRealColorsAndIgnoresFaceColors) {
  const Scan scan = readers::readOff(
      "COFF\n3 1 0\n"
      "0 0 0 255 0 10 255\n"
      "1 0 0 1.0 0.5 0\n"
      "0 1 0 0 0 0 1\n"
      "3 0 1 2 0.2 0.3 0.4 1\n");
  ASSERT_TRUE(scan.points.hasColors());
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.colors[0], (Rgb8{255, 0, 10}));
  EXPECT_EQ(scan.points.colors[1], (Rgb8{255, 128, 0}));
  EXPECT_EQ(scan.points.colors[2], (Rgb8{0, 0, 0}));
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}));
}

TEST(OffReader, ReadsCnoffNormalsThenColors) {
  const Scan scan = readers::readOff("CNOFF\n1 0 0\n1 2 3 0 0 1 9 8 7\n");
  EXPECT_EQ(scan.points.positions[0], Vec3f(1, 2, 3));
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.colors[0], (Rgb8{9, 8, 7}));
}

TEST(OffReader, ReadsVerticesWithoutFacesAsPointCloud) {
  const Scan scan = readers::readOff(std::string("OFF\n4 0 0\n") + std::string(kSquareVertices));
  EXPECT_EQ(scan.points.size(), 4u);
  EXPECT_FALSE(scan.isMesh());
}

TEST(OffReader, AcceptsLastLineWithoutNewline) {
  const Scan scan = readers::readOff("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2");
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}));
}

TEST(OffReader, KeepsNanCoordinates) {
  const Scan scan = readers::readOff("OFF\n2 0 0\nnan 0 0\n0 inf 0\n");
  EXPECT_TRUE(std::isnan(scan.points.positions[0].x()));
  EXPECT_EQ(scan.points.positions[1].y(), INFINITY);
}

TEST(OffReader, FailsOnEmptyFile) { EXPECT_THAT(offFailure(""), StartsWith("line 1: empty file")); }

TEST(OffReader, FailsOnOnlyComments) { EXPECT_THAT(offFailure("# nothing\n\n"), StartsWith("line 2: empty file")); }

TEST(OffReader, FailsOnWrongMagic) {
  EXPECT_THAT(offFailure("PLY\n3 1 0\n"), StartsWith("line 1: wrong magic: expected OFF, got 'PLY'"));
}

TEST(OffReader, FailsOnUnsupportedVariant) {
  const std::string message = offFailure("STOFF\n3 1 0\n");
  EXPECT_THAT(message, StartsWith("line 1: unsupported OFF variant 'STOFF'"));
}

TEST(OffReader, FailsOnBinaryOff) {
  EXPECT_THAT(offFailure("OFF BINARY\n\x01\x02"), StartsWith("line 1: binary OFF is not supported"));
}

TEST(OffReader, FailsOnNegativeVertexCount) {
  EXPECT_THAT(offFailure("OFF\n-4 1 0\n0 0 0\n"), StartsWith("line 2: negative vertex count -4"));
}

TEST(OffReader, FailsOnNegativeFaceCount) {
  EXPECT_THAT(offFailure("OFF\n3 -1 0\n0 0 0\n"), StartsWith("line 2: negative face count -1"));
}

TEST(OffReader, FailsOnZeroVertices) { EXPECT_THAT(offFailure("OFF\n0 0 0\n"), StartsWith("line 2: no points")); }

TEST(OffReader, FailsOnHugeVertexCountBeforeAllocating) {
  const std::string message = offFailure("OFF\n4000000000 1 0\n0 0 0\n3 0 0 0\n");
  // Byte 18 is the newline ending the counts line; 15 bytes follow from it.
  EXPECT_THAT(message, StartsWith("byte 18: header claims 4000000000 vertices"));
  EXPECT_THAT(message, HasSubstr("only 15 bytes follow"));
}

TEST(OffReader, FailsOnVertexCountLargerThanBody) {
  const std::string message = offFailure("OFF\n10 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_THAT(message, StartsWith("byte 10: header claims 10 vertices (6 bytes each) but only 27 bytes follow"));
}

TEST(OffReader, FailsOnHugeFaceCountBeforeAllocating) {
  const std::string message = offFailure(std::string("OFF\n4 4000000000 0\n") + std::string(kSquareVertices));
  EXPECT_THAT(message, StartsWith("byte "));
  EXPECT_THAT(message, HasSubstr("header claims 4000000000 faces"));
}

TEST(OffReader, FailsOnFewerVerticesThanDeclared) {
  const std::string message = offFailure(std::string("OFF\n5 0 0\n") + std::string(kSquareVertices));
  EXPECT_THAT(message, StartsWith("line 6: file ends after 4 of 5 vertices"));
}

TEST(OffReader, FailsOnFewerFacesThanDeclared) {
  const std::string message = offFailure(std::string("OFF\n4 3 0\n") + std::string(kSquareVertices) + "3 0 1 2\n");
  EXPECT_THAT(message, StartsWith("line 7: file ends after 1 of 3 faces"));
}

TEST(OffReader, FailsOnTruncatedFace) {
  const std::string message = offFailure(std::string("OFF\n4 1 0\n") + std::string(kSquareVertices) + "4 0 1 2\n");
  EXPECT_THAT(message, StartsWith("line 7: file ends inside face 0"));
}

TEST(OffReader, FailsOnFaceIndexOutOfRange) {
  const std::string message =
      offFailure(std::string("OFF\n4 2 0\n") + std::string(kSquareVertices) + "3 0 1 2\n3 0 2 4\n");
  EXPECT_THAT(message, StartsWith("line 8: face 1: vertex index 4 out of range (4 vertices)"));
}

TEST(OffReader, FailsOnNegativeFaceIndex) {
  const std::string message = offFailure(std::string("OFF\n4 1 0\n") + std::string(kSquareVertices) + "3 0 -1 2\n");
  EXPECT_THAT(message, StartsWith("line 7: face 0: vertex index -1 out of range"));
}

TEST(OffReader, FailsOnFaceWithTwoVertices) {
  const std::string message = offFailure(std::string("OFF\n4 1 0\n") + std::string(kSquareVertices) + "2 0 1\n");
  EXPECT_THAT(message, StartsWith("line 7: face 0 has 2 vertices, a face needs at least 3"));
}

TEST(OffReader, FailsOnNonNumericCoordinate) {
  const std::string message = offFailure("OFF\n3 0 0\n0 0 0\n1 x 0\n0 1 0\n");
  EXPECT_THAT(message, StartsWith("line 4: non-numeric token 'x'"));
}

TEST(OffReader, FailsOnNonNumericFaceIndex) {
  const std::string message = offFailure(std::string("OFF\n4 1 0\n") + std::string(kSquareVertices) + "3 0 one 2\n");
  EXPECT_THAT(message, StartsWith("line 7: expected an integer, got 'one'"));
}

TEST(OffReader, FailsOnNonNumericCount) {
  EXPECT_THAT(offFailure("OFF\nfour 1 0\n"), StartsWith("line 2: expected an integer, got 'four' in vertex count"));
}

TEST(OffReader, FailsOnCoffVertexWithoutColor) {
  const std::string message = offFailure("COFF\n2 0 0\n0 0 0 1 1 1 1\n1 0 0\n");
  EXPECT_THAT(message, StartsWith("line 4: vertex 1: expected a color"));
}

TEST(OffReader, FailsOnCoffColorOutOfRange) {
  const std::string message = offFailure("COFF\n1 0 0\n0 0 0 1.5 0 0\n");
  EXPECT_THAT(message, StartsWith("line 3: vertex 0: color value '1.5' out of range 0..1"));
}

}  // namespace
}  // namespace apo
