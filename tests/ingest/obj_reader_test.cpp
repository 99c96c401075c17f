#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <cmath>
#include <string>

namespace apo {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;

std::string objFailure(std::string_view bytes) { return test::readerFailure(readers::readObj, bytes); }

constexpr std::string_view kObjSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

TEST(ObjReader, ReadsTrianglesAndFanTriangulatesPolygons) {
  const Scan scan = readers::readObj(
      "# square and pentagon\r\n"
      "mtllib scan.mtl\r\n"
      "o part\r\n"
      "v 0 0 0\r\n"
      "v 1 0 0\r\n"
      "v 1 1 0.5\r\n"
      "v 0 1 0\r\n"
      "v 0.5 2 0\r\n"
      "vt 0 0\r\n"
      "g group\r\n"
      "usemtl skin\r\n"
      "s 1\r\n"
      "f 1 2 3\r\n"
      "f 1 2 3 5 4\r\n"
      "l 1 2\r\n"
      "p 3\r\n"
      "unknownkeyword 1 2\r\n");
  ASSERT_EQ(scan.points.size(), 5u);
  EXPECT_EQ(scan.points.positions[2], Vec3f(1, 1, 0.5f));
  EXPECT_EQ(scan.points.positions[4], Vec3f(0.5f, 2, 0));
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{0, 1, 2}, Triangle{0, 2, 4},
                                          Triangle{0, 4, 3}));
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_FALSE(scan.points.hasColors());
}

TEST(ObjReader, ReadsAllCornerForms) {
  const Scan scan = readers::readObj(std::string(kObjSquare) +
                                     "vt 0 0\nvn 0 0 1\n"
                                     "f 1 2/1 3//1\n"
                                     "f 1/1/1 3/1 4\n");
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{0, 2, 3}));
}

TEST(ObjReader, ResolvesNegativeIndicesAgainstVerticesSoFar) {
  const Scan scan = readers::readObj(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
      "f -3 -2 -1\n"
      "v 1 1 0\n"
      "f -3 -1 -2\n");
  EXPECT_THAT(scan.triangles, ElementsAre(Triangle{0, 1, 2}, Triangle{1, 3, 2}));
}

TEST(ObjReader, ReadsPerVertexNormalsFromTheFirstCornerWithOne) {
  const Scan scan = readers::readObj(std::string(kObjSquare) +
                                     "vn 0 0 1\nvn 0 1 0\n"
                                     "f 1//1 2//1 3//-1\n"
                                     "f 1//2 3 4//2\n");
  ASSERT_TRUE(scan.points.hasNormals());
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[1], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[2], Vec3f(0, 1, 0));
  EXPECT_EQ(scan.points.normals[3], Vec3f(0, 1, 0));
}

TEST(ObjReader, GivesUnreferencedVerticesZeroNormals) {
  const Scan scan = readers::readObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nv 5 5 5\n");
  ASSERT_EQ(scan.points.normals.size(), 4u);
  EXPECT_EQ(scan.points.normals[2], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[3], Vec3f::Zero());
}

TEST(ObjReader, DropsNormalsWhenAReferencedVertexHasNone) {
  const Scan scan = readers::readObj(std::string(kObjSquare) + "vn 0 0 1\nf 1//1 2//1 3//1\nf 1//1 3//1 4\n");
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_EQ(scan.triangles.size(), 2u);
}

TEST(ObjReader, ReadsVertexColorsAndIgnoresW) {
  const Scan scan = readers::readObj(
      "v 0 0 0 1 0 0.5\n"
      "v 1 0 0 1.0 0 1 0\n"
      "v 0 1 0 0 0 0\n"
      "f 1 2 3\n");
  ASSERT_TRUE(scan.points.hasColors());
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 0, 0));
  EXPECT_EQ(scan.points.colors[0], (Rgb8{255, 0, 128}));
  EXPECT_EQ(scan.points.colors[1], (Rgb8{0, 255, 0}));
  EXPECT_EQ(scan.points.colors[2], (Rgb8{0, 0, 0}));
}

TEST(ObjReader, DropsColorsWhenSomeVertexHasNone) {
  const Scan scan = readers::readObj("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 1 0\n");
  EXPECT_EQ(scan.points.size(), 3u);
  EXPECT_FALSE(scan.points.hasColors());
}

TEST(ObjReader, ReadsPointCloudWithNormalsPairedByOrder) {
  const Scan scan = readers::readObj("v 0 0 0\nvn 0 0 1\nv 1 2 3\nvn 1 0 0\n");
  EXPECT_FALSE(scan.isMesh());
  ASSERT_TRUE(scan.points.hasNormals());
  EXPECT_EQ(scan.points.positions[1], Vec3f(1, 2, 3));
  EXPECT_EQ(scan.points.normals[1], Vec3f(1, 0, 0));
}

TEST(ObjReader, DropsPointCloudNormalsWhenCountsDiffer) {
  const Scan scan = readers::readObj("v 0 0 0\nv 1 2 3\nvn 1 0 0\n");
  EXPECT_FALSE(scan.points.hasNormals());
}

TEST(ObjReader, KeepsNanCoordinates) {
  const Scan scan = readers::readObj("v nan 0 0\nv 0 -inf 0\n");
  EXPECT_TRUE(std::isnan(scan.points.positions[0].x()));
  EXPECT_EQ(scan.points.positions[1].y(), -INFINITY);
}

TEST(ObjReader, FailsOnEmptyFile) { EXPECT_THAT(objFailure(""), StartsWith("line 1: empty file")); }

TEST(ObjReader, FailsWithoutVertices) {
  EXPECT_THAT(objFailure("# only\nvt 0 0\ng x\n"), StartsWith("line 3: no points"));
}

TEST(ObjReader, FailsOnVertexIndexZero) {
  EXPECT_THAT(objFailure(std::string(kObjSquare) + "f 0 1 2\n"),
              StartsWith("line 5: vertex index 0 out of range (4 vertices defined so far)"));
}

TEST(ObjReader, FailsOnVertexIndexOutOfRange) {
  EXPECT_THAT(objFailure(std::string(kObjSquare) + "f 1 2 3\nf 1 3 5\n"),
              StartsWith("line 6: vertex index 5 out of range"));
}

TEST(ObjReader, FailsOnVertexIndexDefinedOnlyLater) {
  EXPECT_THAT(objFailure("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n"), StartsWith("line 3: vertex index 3 out of range"));
}

TEST(ObjReader, FailsOnRelativeIndexBeforeFirstVertex) {
  EXPECT_THAT(objFailure(std::string(kObjSquare) + "f -1 -2 -5\n"), StartsWith("line 5: vertex index -5 out of range"));
}

TEST(ObjReader, FailsOnNormalIndexOutOfRange) {
  EXPECT_THAT(objFailure(std::string(kObjSquare) + "vn 0 0 1\nf 1//1 2//2 3//1\n"),
              StartsWith("line 6: normal index 2 out of range (1 normals defined so far)"));
}

TEST(ObjReader, FailsOnFaceWithTwoVertices) {
  EXPECT_THAT(objFailure(std::string(kObjSquare) + "f 1 2\n"),
              StartsWith("line 5: face has 2 vertices, a face needs at least 3"));
}

TEST(ObjReader, FailsOnNonNumericCoordinate) {
  const std::string message = objFailure("v 0 0 0\nv 1 zero 0\n");
  EXPECT_THAT(message, StartsWith("line 2: non-numeric token 'zero'"));
}

TEST(ObjReader, FailsOnNonNumericIndex) {
  const std::string message = objFailure(std::string(kObjSquare) + "f 1 b/1 3\n");
  EXPECT_THAT(message, StartsWith("line 5: expected an integer, got 'b'"));
}

TEST(ObjReader, FailsOnVertexWithTwoCoordinates) {
  EXPECT_THAT(objFailure("v 1 2\n"), StartsWith("line 1: expected 'v x y z [w] [r g b]', got 2 values"));
}

TEST(ObjReader, FailsOnColorOutOfRange) {
  EXPECT_THAT(objFailure("v 0 0 0 255 0 0\n"), StartsWith("line 1: vertex color value '255' out of range 0..1"));
}

}  // namespace
}  // namespace apo
