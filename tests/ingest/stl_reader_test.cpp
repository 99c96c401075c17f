#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace apo {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;

std::string stlFailure(std::string_view bytes) { return test::readerFailure(readers::readStl, bytes); }

void appendLittleEndian(std::string& bytes, std::uint32_t value, int byteCount) {
  for (int i = 0; i < byteCount; ++i) bytes.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

void appendFloat(std::string& bytes, float value) { appendLittleEndian(bytes, std::bit_cast<std::uint32_t>(value), 4); }

using StlCorners = std::array<float, 9>;

// A binary STL built byte by byte: an 80-byte header starting with
// `headerText`, the count, then per triangle a normal, three corners and a
// zero attribute byte count.
std::string binaryStl(std::string_view headerText, std::uint32_t declaredCount,
                      const std::vector<StlCorners>& triangles) {
  std::string bytes(headerText);
  bytes.resize(80, ' ');
  appendLittleEndian(bytes, declaredCount, 4);
  for (const StlCorners& corners : triangles) {
    for (int i = 0; i < 3; ++i) appendFloat(bytes, 9.0f);  // a facet normal that must be ignored
    for (float value : corners) appendFloat(bytes, value);
    appendLittleEndian(bytes, 0, 2);
  }
  return bytes;
}

const std::vector<StlCorners> kTwoTriangles = {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 1, 1, 2, 2, 2, -3, 0.5f, 4}};

void expectTwoTriangles(const Scan& scan) {
  ASSERT_EQ(scan.points.size(), 6u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(0, 0, 0));
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.positions[2], Vec3f(0, 1, 0));
  EXPECT_EQ(scan.points.positions[5], Vec3f(-3, 0.5f, 4));
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{3, 4, 5}));
  EXPECT_FALSE(scan.points.hasNormals());
}

constexpr std::string_view kAsciiTwoTriangles =
    "solid part\r\n"
    "  facet normal 0 0 1\r\n"
    "    outer loop\r\n"
    "      vertex 0 0 0\r\n"
    "      vertex 1 0 0\r\n"
    "      vertex 0 1 0\r\n"
    "    endloop\r\n"
    "  endfacet\r\n"
    "\r\n"
    "  facet normal 0 0 0\r\n"
    "    outer loop\r\n"
    "      vertex 1 1 1\r\n"
    "      vertex 2e0 2 2\r\n"
    "      vertex -3 0.5 4\r\n"
    "    endloop\r\n"
    "  endfacet\r\n"
    "endsolid part\r\n";

// One facet with `vertexLines` between "outer loop" and "endloop".
std::string asciiFacet(std::string_view vertexLines) {
  return "solid s\nfacet normal 0 0 1\nouter loop\n" + std::string(vertexLines) + "endloop\nendfacet\nendsolid s\n";
}

TEST(StlReader, ReadsAscii) { expectTwoTriangles(readers::readStl(kAsciiTwoTriangles)); }

TEST(StlReader, ReadsAsciiWithSeveralSolidsAndUppercaseKeywords) {
  const Scan scan = readers::readStl(
      "SOLID A\nFACET NORMAL 0 0 1\nOUTER LOOP\nVERTEX 0 0 0\nVERTEX 1 0 0\nVERTEX 0 1 0\nENDLOOP\nENDFACET\n"
      "ENDSOLID A\n" +
      asciiFacet("vertex 5 5 5\nvertex 6 5 5\nvertex 5 6 5\n"));
  ASSERT_EQ(scan.triangles.size(), 2u);
  EXPECT_EQ(scan.points.positions[4], Vec3f(6, 5, 5));
  EXPECT_THAT(scan.triangles[1], (Triangle{3, 4, 5}));
}

TEST(StlReader, ReadsBinary) { expectTwoTriangles(readers::readStl(binaryStl("exported", 2, kTwoTriangles))); }

TEST(StlReader, ReadsBinaryWhoseHeaderStartsWithSolid) {
  expectTwoTriangles(readers::readStl(binaryStl("solid part made by a CAD tool", 2, kTwoTriangles)));
}

TEST(StlReader, KeepsNanCoordinates) {
  const Scan ascii = readers::readStl(asciiFacet("vertex nan 0 0\nvertex 0 inf 0\nvertex 0 0 1\n"));
  EXPECT_TRUE(std::isnan(ascii.points.positions[0].x()));
  EXPECT_EQ(ascii.points.positions[1].y(), INFINITY);
  const Scan binary = readers::readStl(binaryStl("", 1, {{NAN, 0, 0, 0, 0, 0, 0, 0, 0}}));
  EXPECT_TRUE(std::isnan(binary.points.positions[0].x()));
}

TEST(StlReader, FailsOnEmptyFile) { EXPECT_THAT(stlFailure(""), StartsWith("byte 0: empty file")); }

TEST(StlReader, FailsOnShortFileThatIsNotAscii) {
  const std::string message = stlFailure("hello");
  EXPECT_THAT(message, StartsWith("byte 0: not an STL file: it is shorter than the 84-byte binary header"));
  EXPECT_THAT(message, HasSubstr("does not start with 'solid'"));
}

TEST(StlReader, FailsOnTruncatedBinary) {
  std::string bytes = binaryStl("exported", 2, kTwoTriangles);
  bytes.resize(bytes.size() - 10);
  EXPECT_THAT(stlFailure(bytes),
              StartsWith("byte 80: not an STL file: its size does not match the binary triangle count "
                         "(2 triangles need 184 bytes, file has 174) and it does not start with 'solid'"));
}

TEST(StlReader, FailsOnTruncatedBinaryWhoseHeaderStartsWithSolid) {
  std::string bytes = binaryStl("solid part", 2, kTwoTriangles);
  bytes.resize(bytes.size() - 1);
  const std::string message = stlFailure(bytes);
  EXPECT_THAT(message, StartsWith("byte 80: not an STL file: it starts with 'solid' but holds binary data"));
  EXPECT_THAT(message, HasSubstr("2 triangles need 184 bytes, file has 183"));
}

TEST(StlReader, FailsOnHugeTriangleCountInSmallFile) {
  const std::string message = stlFailure(binaryStl("exported", 4000000000u, kTwoTriangles));
  EXPECT_THAT(message, StartsWith("byte 80: not an STL file"));
  EXPECT_THAT(message, HasSubstr("4000000000 triangles need 200000000084 bytes, file has 184"));
}

TEST(StlReader, FailsOnBinaryWithZeroTriangles) {
  EXPECT_THAT(stlFailure(binaryStl("exported", 0, {})), StartsWith("byte 80: no triangles"));
}

TEST(StlReader, FailsOnAsciiWithoutTriangles) {
  EXPECT_THAT(stlFailure("solid empty\nendsolid empty\n"), StartsWith("line 2: no triangles"));
}

TEST(StlReader, FailsOnMisspelledKeyword) {
  EXPECT_THAT(stlFailure(asciiFacet("vertex 0 0 0\nvertx 1 0 0\nvertex 0 1 0\n")),
              StartsWith("line 5: expected 'vertex', got 'vertx'"));
}

TEST(StlReader, FailsOnMissingOuterLoop) {
  EXPECT_THAT(stlFailure("solid s\nfacet normal 0 0 1\nouter\n"),
              StartsWith("line 3: expected 'outer loop', got nothing after it"));
}

TEST(StlReader, FailsOnFacetWithFourVertices) {
  EXPECT_THAT(stlFailure(asciiFacet("vertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nvertex 1 1 0\n")),
              StartsWith("line 7: facet has more than 3 vertices"));
}

TEST(StlReader, FailsOnFacetWithTwoVertices) {
  EXPECT_THAT(stlFailure(asciiFacet("vertex 0 0 0\nvertex 1 0 0\n")),
              StartsWith("line 6: facet has 2 vertices, expected 3"));
}

TEST(StlReader, FailsOnNonNumericCoordinate) {
  EXPECT_THAT(stlFailure(asciiFacet("vertex 0 0 0\nvertex 1 O 0\nvertex 0 1 0\n")),
              StartsWith("line 5: non-numeric token 'O'"));
}

TEST(StlReader, FailsOnVertexWithTwoCoordinates) {
  EXPECT_THAT(stlFailure(asciiFacet("vertex 0 0\nvertex 1 0 0\nvertex 0 1 0\n")),
              StartsWith("line 4: expected 3 coordinates after 'vertex', got 2"));
}

TEST(StlReader, FailsOnAsciiEndingInsideFacet) {
  EXPECT_THAT(stlFailure("solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"),
              StartsWith("line 4: file ends inside a facet, expected 'vertex'"));
}

TEST(StlReader, FailsOnAsciiWithoutEndsolid) {
  const std::string text(kAsciiTwoTriangles.substr(0, kAsciiTwoTriangles.rfind("endsolid")));
  EXPECT_THAT(stlFailure(text), StartsWith("line 16: file ends before 'endsolid'"));
}

}  // namespace
}  // namespace apo
