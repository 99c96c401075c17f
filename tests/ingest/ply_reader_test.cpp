// readPly on hand-written fixtures: every encoding, the property and element
// variants met in the wild, and malformed files, whose messages must name the
// position and the problem.
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace apo::readers {
namespace {

using ::testing::HasSubstr;

std::string failureOf(std::string_view bytes) { return test::readerFailure(readPly, bytes); }

// A binary body built value by value in a chosen byte order.
class BinaryBytes {
 public:
  explicit BinaryBytes(bool bigEndian) : bigEndian_(bigEndian) {}

  template <class T>
  BinaryBytes& put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (bigEndian_ != (std::endian::native == std::endian::big)) std::reverse(raw, raw + sizeof(T));
    bytes_.append(raw, sizeof(T));
    return *this;
  }
  const std::string& str() const { return bytes_; }

 private:
  bool bigEndian_;
  std::string bytes_;
};

const std::vector<Triangle> kQuadTriangles = {{0, 1, 2}, {0, 2, 3}};

// --- Accepted files ------------------------------------------------------------

TEST(PlyReader, AsciiWithObjInfoCommentsAndUnknownHeaderLines) {
  const Scan scan = readPly(
      "ply\n"
      "format ascii 1.0\n"
      "comment made by hand\n"
      "obj_info scanner 7\n"
      "some_future_keyword 1 2\n"
      "element vertex 2\n"
      "property float x\n"
      "comment between properties\n"
      "property float y\n"
      "property float z\n"
      "end_header\n"
      "1.5 -2 3e2\n"
      "0 0.25 -0\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1.5f, -2.0f, 300.0f));
  EXPECT_EQ(scan.points.positions[1], Vec3f(0.0f, 0.25f, 0.0f));
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_FALSE(scan.points.hasColors());
  EXPECT_FALSE(scan.points.hasIntensities());
  EXPECT_FALSE(scan.isMesh());
}

TEST(PlyReader, BinaryLittleEndianDoubleCoordinates) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
      "property double x\nproperty double y\nproperty double z\nend_header\n";
  const std::string body = BinaryBytes(false).put(1.5).put(-2.25).put(1e10).put(0.1).put(0.0).put(-7.0).str();
  const Scan scan = readPly(header + body);
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1.5f, -2.25f, 1e10f));
  EXPECT_EQ(scan.points.positions[1], Vec3f(static_cast<float>(0.1), 0.0f, -7.0f));
}

TEST(PlyReader, BinaryBigEndianMeshWithColors) {
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  BinaryBytes body(true);
  body.put(1.0f).put(2.0f).put(3.0f).put<std::uint8_t>(255).put<std::uint8_t>(0).put<std::uint8_t>(7);
  body.put(-1.0f).put(0.5f).put(0.0f).put<std::uint8_t>(1).put<std::uint8_t>(2).put<std::uint8_t>(3);
  body.put(4.0f).put(5.0f).put(6.0f).put<std::uint8_t>(10).put<std::uint8_t>(20).put<std::uint8_t>(30);
  body.put<std::uint8_t>(3).put<std::int32_t>(2).put<std::int32_t>(0).put<std::int32_t>(1);
  const Scan scan = readPly(header + body.str());
  ASSERT_EQ(scan.points.size(), 3u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1, 2, 3));
  EXPECT_EQ(scan.points.positions[1], Vec3f(-1, 0.5f, 0));
  EXPECT_EQ(scan.points.positions[2], Vec3f(4, 5, 6));
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{255, 0, 7}, {1, 2, 3}, {10, 20, 30}}));
  EXPECT_EQ(scan.triangles, (std::vector<Triangle>{{2, 0, 1}}));
}

TEST(PlyReader, BinaryBigEndianDoubleAndShortIndices) {
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
      "property float64 x\nproperty float64 y\nproperty float64 z\n"
      "element face 1\nproperty list uint16 uint16 vertex_indices\nend_header\n";
  BinaryBytes body(true);
  body.put(0.5).put(1.0).put(2.0).put(3.0).put(4.0).put(5.0).put(6.0).put(7.0).put(8.0);
  body.put<std::uint16_t>(3).put<std::uint16_t>(0).put<std::uint16_t>(1).put<std::uint16_t>(2);
  const Scan scan = readPly(header + body.str());
  ASSERT_EQ(scan.points.size(), 3u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(0.5f, 1, 2));
  EXPECT_EQ(scan.points.positions[2], Vec3f(6, 7, 8));
  EXPECT_EQ(scan.triangles, (std::vector<Triangle>{{0, 1, 2}}));
}

TEST(PlyReader, QuadsAndPentagonsAreFanTriangulated) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 6\n"
      "property float x\nproperty float y\nproperty float z\n"
      "element face 3\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 2 0\n1 2 0\n"
      "4 0 1 2 3\n"
      "5 1 2 3 4 5\n"
      "3 5 4 3\n");
  EXPECT_EQ(scan.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {1, 2, 3}, {1, 3, 4}, {1, 4, 5}, {5, 4, 3}}));
}

// Little-endian triangles of uchar count and 32-bit indices are decoded
// straight from the bytes (BinaryBody::triangleFaces) until a face is not
// such a triangle; the generic path, which big-endian files take
// throughout, goes on from that face. Both must give the same triangles.
TEST(PlyReader, BinaryTrianglesBeforeAndAfterAQuadReadAsTheGenericPathReadsThem) {
  const auto file = [](bool bigEndian, const char* indexType) {
    std::string bytes = fmt::format(
        "ply\nformat {} 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 4\nproperty list uchar {} vertex_indices\nend_header\n",
        bigEndian ? "binary_big_endian" : "binary_little_endian", indexType);
    BinaryBytes body(bigEndian);
    for (int i = 0; i < 15; ++i) body.put(static_cast<float>(i));
    body.put<std::uint8_t>(3).put<std::uint32_t>(0).put<std::uint32_t>(1).put<std::uint32_t>(2);
    body.put<std::uint8_t>(4).put<std::uint32_t>(1).put<std::uint32_t>(2).put<std::uint32_t>(3).put<std::uint32_t>(4);
    body.put<std::uint8_t>(3).put<std::uint32_t>(4).put<std::uint32_t>(3).put<std::uint32_t>(0);
    body.put<std::uint8_t>(3).put<std::uint32_t>(2).put<std::uint32_t>(4).put<std::uint32_t>(1);
    return bytes + body.str();
  };
  const std::vector<Triangle> expected = {{0, 1, 2}, {1, 2, 3}, {1, 3, 4}, {4, 3, 0}, {2, 4, 1}};
  for (const char* indexType : {"int", "uint"}) {
    EXPECT_EQ(readPly(file(false, indexType)).triangles, expected) << indexType;
    EXPECT_EQ(readPly(file(true, indexType)).triangles, expected) << indexType;
  }
}

TEST(PlyReader, VertexIndexNameAndOtherFaceProperties) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 4\n"
      "property float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty uchar flags\nproperty list uchar uint vertex_index\n"
      "property list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
      "9 4 0 1 2 3 2 0.5 0.5\n");
  EXPECT_EQ(scan.triangles, kQuadTriangles);
}

TEST(PlyReader, UcharColors) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
      "0 0 0 255 128 0\n1 1 1 1 2 3\n");
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{255, 128, 0}, {1, 2, 3}}));
}

TEST(PlyReader, FloatColorsAreScaledRoundedAndClamped) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float red\nproperty double green\nproperty float blue\nend_header\n"
      "0 0 0 0 0.5 1\n1 1 1 1.2 -0.1 nan\n");
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{0, 128, 255}, {255, 0, 0}}));
}

TEST(PlyReader, DiffuseColorNames) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar diffuse_red\nproperty uchar diffuse_green\nproperty uchar diffuse_blue\nend_header\n"
      "0 0 0 9 8 7\n");
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{9, 8, 7}}));
}

TEST(PlyReader, NormalsAndConfidence) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty float confidence\nend_header\n"
      "0 0 0 0 0 1 0.75\n1 1 1 1 0 0 0.25\n");
  EXPECT_EQ(scan.points.normals, (std::vector<Vec3f>{Vec3f(0, 0, 1), Vec3f(1, 0, 0)}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{0.75f, 0.25f}));
}

TEST(PlyReader, ScalarIntensityAndIncompleteNormals) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty ushort scalar_intensity\nend_header\n"
      "0 0 0 1 0 1000\n");
  EXPECT_FALSE(scan.points.hasNormals());  // nz is missing
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{1000.0f}));
}

TEST(PlyReader, UnknownVertexPropertiesIncludingListsAreSkipped) {
  const Scan ascii = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float quality\nproperty float x\nproperty list uchar float texcoord\n"
      "property float y\nproperty float z\nproperty int label\nend_header\n"
      "0.5 1 2 0.1 0.2 2 3 7\n"
      "0.5 4 0 5 6 -1\n");
  EXPECT_EQ(ascii.points.positions, (std::vector<Vec3f>{Vec3f(1, 2, 3), Vec3f(4, 5, 6)}));

  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
      "property float quality\nproperty float x\nproperty list uchar double texcoord\n"
      "property float y\nproperty float z\nproperty int label\nend_header\n";
  BinaryBytes body(false);
  body.put(0.5f).put(1.0f).put<std::uint8_t>(2).put(0.1).put(0.2).put(2.0f).put(3.0f).put<std::int32_t>(7);
  body.put(0.5f).put(4.0f).put<std::uint8_t>(0).put(5.0f).put(6.0f).put<std::int32_t>(-1);
  const Scan binary = readPly(header + body.str());
  EXPECT_EQ(binary.points.positions, ascii.points.positions);
}

const char kEdgeElement[] =
    "element edge 2\nproperty int vertex1\nproperty int vertex2\nproperty list uchar int extra\n";

std::string meshWithEdges(bool edgesBeforeFaces, std::string_view format) {
  const std::string faces = "element face 2\nproperty list uchar int vertex_indices\n";
  return fmt::format(
      "ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n{}{}end_header\n",
      format, edgesBeforeFaces ? kEdgeElement : faces, edgesBeforeFaces ? faces : kEdgeElement);
}

TEST(PlyReader, AsciiUnknownElementBeforeAndAfterFaces) {
  const std::string vertices = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  const std::string faces = "3 0 1 2\n3 0 2 3\n";
  const std::string edges = "0 1 0\n1 2 2 5 6\n";
  EXPECT_EQ(readPly(meshWithEdges(true, "ascii") + vertices + edges + faces).triangles, kQuadTriangles);
  EXPECT_EQ(readPly(meshWithEdges(false, "ascii") + vertices + faces + edges).triangles, kQuadTriangles);
}

TEST(PlyReader, UnknownElementsAndPropertiesAreNotedNotSilentlyDropped) {
  const std::string vertices = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  const Scan scan = readPly(meshWithEdges(true, "ascii") + vertices + "0 1 0\n1 2 2 5 6\n" + "3 0 1 2\n3 0 2 3\n");
  EXPECT_THAT(scan.readNotes, testing::Contains("element 'edge' (2 items) skipped: apo reads vertices, faces and tristrips"));
  const Scan withQuality = readPly(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property float quality\nproperty float u\nend_header\n1 2 3 0.5 0.25\n");
  EXPECT_THAT(withQuality.readNotes, testing::Contains("vertex properties not kept: quality, u"));
}

// The winding of a strip alternates; the reader keeps every triangle's
// orientation the strip's: (0 1 2), (2 1 3), (2 3 4), ...
TEST(PlyReader, TristripsBecomeTrianglesWithTheStripsWinding) {
  const std::string header =
      "ply\nformat {} 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
      "element tristrips 1\nproperty list int int vertex_indices\nend_header\n";
  const std::string vertices = "0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n2 1 0\n";
  // One strip of four triangles, a restart, a strip of one, and a joining
  // triangle with a repeated vertex (5 5 4) that is counted, not kept.
  const Scan ascii = readPly(fmt::format(fmt::runtime(header), "ascii") + vertices + "10 0 1 2 3 4 -1 3 5 4 5\n");
  EXPECT_EQ(ascii.triangles, (std::vector<Triangle>{{0, 1, 2}, {2, 1, 3}, {2, 3, 4}, {3, 5, 4}}));
  EXPECT_THAT(ascii.readNotes, testing::Contains(HasSubstr("1 strips read as 4 triangles (1 strip-joining")));
  // Every triangle faces +z, like the strip: (b - a) x (c - a) . z < 0 for
  // this layout's clockwise order, the same for all.
  for (const Triangle& t : ascii.triangles) {
    const auto& p = ascii.points.positions;
    EXPECT_LT((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).z(), 0.0f);
  }
  BinaryBytes binary(false);
  for (float v : {0.f, 0.f, 0.f, 0.f, 1.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 2.f, 0.f, 0.f, 2.f, 1.f, 0.f}) binary.put(v);
  binary.put<std::int32_t>(4).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2).put<std::int32_t>(3);
  EXPECT_EQ(readPly(fmt::format(fmt::runtime(header), "binary_little_endian") + binary.str()).triangles,
            (std::vector<Triangle>{{0, 1, 2}, {2, 1, 3}}));
  EXPECT_THAT(failureOf(fmt::format(fmt::runtime(header), "ascii") + vertices + "3 0 1 9\n"), HasSubstr("vertex index 9 out of range"));
}

TEST(PlyReader, LidarAttributesAndApoOriginComeBack) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\ncomment apo_origin 512000 5403000.5 -2\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar classification\nproperty uchar return_number\n"
      "property uchar number_of_returns\nend_header\n1 2 3 2 1 2\n4 5 6 6 2 2\n");
  EXPECT_EQ(scan.origin, (std::array<double, 3>{512000.0, 5403000.5, -2.0}));
  EXPECT_EQ(scan.points.classifications, (std::vector<std::uint8_t>{2, 6}));
  EXPECT_EQ(scan.points.returnNumbers, (std::vector<std::uint8_t>{1, 2}));
  EXPECT_EQ(scan.points.returnCounts, (std::vector<std::uint8_t>{2, 2}));
  EXPECT_THAT(failureOf("ply\nformat ascii 1.0\ncomment apo_origin 1 nan 3\nelement vertex 1\nproperty float x\n"
                        "property float y\nproperty float z\nend_header\n1 2 3\n"),
              testing::StartsWith("line 3: apo_origin coordinate 'nan'"));
}

TEST(PlyReader, BinaryUnknownElementBeforeAndAfterFaces) {
  BinaryBytes vertices(false);
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f}) vertices.put(v);
  BinaryBytes faces(false);
  faces.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
  faces.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(2).put<std::int32_t>(3);
  BinaryBytes edges(false);
  edges.put<std::int32_t>(0).put<std::int32_t>(1).put<std::uint8_t>(0);
  edges.put<std::int32_t>(1).put<std::int32_t>(2).put<std::uint8_t>(2).put<std::int32_t>(5).put<std::int32_t>(6);

  const std::string before = meshWithEdges(true, "binary_little_endian") + vertices.str() + edges.str() + faces.str();
  const std::string after = meshWithEdges(false, "binary_little_endian") + vertices.str() + faces.str() + edges.str();
  EXPECT_EQ(readPly(before).triangles, kQuadTriangles);
  EXPECT_EQ(readPly(after).triangles, kQuadTriangles);
}

TEST(PlyReader, CrlfLineEndings) {
  const Scan ascii = readPly(
      "ply\r\nformat ascii 1.0\r\ncomment windows\r\nelement vertex 2\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\n"
      "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
      "1 2 3\r\n4 5 6\r\n3 0 1 1\r\n");
  EXPECT_EQ(ascii.points.positions, (std::vector<Vec3f>{Vec3f(1, 2, 3), Vec3f(4, 5, 6)}));
  EXPECT_EQ(ascii.triangles, (std::vector<Triangle>{{0, 1, 1}}));

  // The body starts right after "end_header\r\n", even when its first byte is '\n'.
  const std::string header =
      "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 1\r\n"
      "property uchar x\r\nproperty uchar y\r\nproperty uchar z\r\nend_header\r\n";
  const Scan binary = readPly(header + "\n\r\n");
  EXPECT_EQ(binary.points.positions, (std::vector<Vec3f>{Vec3f(10, 13, 10)}));
}

TEST(PlyReader, NonFiniteAsciiCoordinatesAreKept) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n"
      "nan inf -inf\n"
      "1 1e60 2\n");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_TRUE(std::isnan(scan.points.positions[0].x()));
  EXPECT_TRUE(std::isinf(scan.points.positions[0].y()) && scan.points.positions[0].y() > 0);
  EXPECT_TRUE(std::isinf(scan.points.positions[0].z()) && scan.points.positions[0].z() < 0);
  EXPECT_TRUE(std::isinf(scan.points.positions[1].y()));  // beyond float range
}

TEST(PlyReader, BinaryDoublesBeyondFloatRangeBecomeInfinite) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
      "property double x\nproperty double y\nproperty double z\nend_header\n";
  const Scan scan = readPly(header + BinaryBytes(false).put(1e300).put(-1e300).put(std::nan("")).str());
  EXPECT_EQ(scan.points.positions[0].x(), std::numeric_limits<float>::infinity());
  EXPECT_EQ(scan.points.positions[0].y(), -std::numeric_limits<float>::infinity());
  EXPECT_TRUE(std::isnan(scan.points.positions[0].z()));
}

TEST(PlyReader, BinaryTrailingBytesAreTolerated) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n";
  const Scan scan = readPly(header + BinaryBytes(false).put(1.0f).put(2.0f).put(3.0f).str() + "padding");
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{Vec3f(1, 2, 3)}));
}

TEST(PlyReader, AsciiBlankLinesAndElementsWithoutPropertiesAreTolerated) {
  const Scan scan = readPly(
      "ply\nformat ascii 1.0\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\nelement nothing 4000000000\nend_header\n"
      "\n1 2 3\n\n4 5 6\n\n");
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{Vec3f(1, 2, 3), Vec3f(4, 5, 6)}));
}

TEST(PlyReader, EmptyVertexElement) {
  const Scan scan = readPly(
      "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n");
  EXPECT_EQ(scan.points.size(), 0u);
}

// --- Malformed files -----------------------------------------------------------

const char kXyzHeader[] = "property float x\nproperty float y\nproperty float z\n";

TEST(PlyReaderFailure, EmptyFile) { EXPECT_THAT(failureOf(""), HasSubstr("empty file")); }

TEST(PlyReaderFailure, WrongMagic) {
  EXPECT_THAT(failureOf("solid cube\nfacet normal 0 0 1\n"),
              HasSubstr("byte 0: wrong magic: expected 'ply', got 'solid cube'"));
}

TEST(PlyReaderFailure, MissingEndHeader) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 1\n") + kXyzHeader + "1 2 3\n"),
              HasSubstr("line 7: header has no end_header line"));
}

TEST(PlyReaderFailure, MissingFormat) {
  EXPECT_THAT(failureOf(std::string("ply\nelement vertex 1\n") + kXyzHeader + "end_header\n1 2 3\n"),
              HasSubstr("line 6: header has no format line"));
}

TEST(PlyReaderFailure, UnknownFormat) {
  EXPECT_THAT(failureOf("ply\nformat binary_middle_endian 1.0\nend_header\n"),
              HasSubstr("line 2: unknown format 'binary_middle_endian'"));
}

TEST(PlyReaderFailure, PropertyBeforeAnyElement) {
  EXPECT_THAT(failureOf("ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
              HasSubstr("line 3: property declared before any element"));
}

TEST(PlyReaderFailure, UnknownPropertyType) {
  EXPECT_THAT(failureOf("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n"),
              HasSubstr("line 4: unknown property type 'float128'"));
}

TEST(PlyReaderFailure, MissingVertexElement) {
  EXPECT_THAT(failureOf("ply\nformat ascii 1.0\nelement point 1\nproperty float x\nend_header\n1\n"),
              HasSubstr("line 5: header declares no vertex element"));
}

TEST(PlyReaderFailure, VertexWithoutZ) {
  EXPECT_THAT(
      failureOf("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n"),
      HasSubstr("line 3: element vertex has no scalar property 'z'"));
}

TEST(PlyReaderFailure, FaceWithoutVertexIndices) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 1\n") + kXyzHeader +
                        "element face 1\nproperty list uchar int corners\nend_header\n0 0 0\n3 0 0 0\n"),
              HasSubstr("line 7: element face has no 'vertex_indices' list"));
}

TEST(PlyReaderFailure, NegativeCount) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex -1\n") + kXyzHeader + "end_header\n"),
              HasSubstr("line 3: negative count -1 for element 'vertex'"));
}

TEST(PlyReaderFailure, NonIntegerCount) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 2.5\n") + kXyzHeader + "end_header\n"),
              HasSubstr("line 3: count '2.5' of element 'vertex' is not an integer"));
}

TEST(PlyReaderFailure, HugeBinaryVertexCountFailsFast) {
  const std::string header =
      std::string("ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n") + kXyzHeader + "end_header\n";
  const auto start = std::chrono::steady_clock::now();
  const std::string message = failureOf(header + std::string(24, '\0'));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  EXPECT_THAT(message, HasSubstr(fmt::format("byte {}: header claims 4000000000 vertices", header.size())));
}

TEST(PlyReaderFailure, HugeAsciiVertexCountFailsFast) {
  const std::string message =
      failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 4000000000\n") + kXyzHeader + "end_header\n1 2 3\n");
  EXPECT_THAT(message, HasSubstr("line 3: header claims 4000000000 vertices"));
}

TEST(PlyReaderFailure, AsciiBodyShorterThanHeaderCount) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 3\n") + kXyzHeader +
                        "end_header\n0.5 0.5 0.5\n1.5 1.5 1.5\n"),
              HasSubstr("line 9: file ends after 2 of 3 vertices"));
}

TEST(PlyReaderFailure, BinaryBodyShorterThanHeaderCount) {
  const std::string header =
      std::string("ply\nformat binary_little_endian 1.0\nelement vertex 3\n") + kXyzHeader + "end_header\n";
  const std::string message = failureOf(header + std::string(24, '\0'));
  EXPECT_THAT(message, HasSubstr(fmt::format("byte {}: header claims 3 vertices", header.size())));
  EXPECT_THAT(message, HasSubstr("only 24 bytes follow"));
}

TEST(PlyReaderFailure, TruncatedBinaryBody) {
  // The list property lets the second vertex pass the count check, then end early.
  const std::string header = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 2\n") + kXyzHeader +
                             "property list uchar float texcoord\nend_header\n";
  BinaryBytes body(false);
  body.put(0.0f).put(0.0f).put(0.0f).put<std::uint8_t>(2).put(0.5f).put(0.5f);
  body.put(1.0f).put(1.0f).put(1.0f);
  EXPECT_THAT(failureOf(header + body.str()),
              HasSubstr(fmt::format("byte {}: truncated vertex data: need 1 bytes, 0 left", header.size() + 33)));
}

TEST(PlyReaderFailure, TruncatedBinaryFaceList) {
  const std::string header = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 3\n") + kXyzHeader +
                             "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  BinaryBytes body(false);
  for (int i = 0; i < 9; ++i) body.put(0.0f);
  body.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
  body.put<std::uint8_t>(3).put<std::int32_t>(0);  // second face cut short
  EXPECT_THAT(failureOf(header + body.str()),
              HasSubstr(fmt::format("byte {}: face 1 lists 3 values for 'vertex_indices' (4 bytes each) but only 4 "
                                    "bytes follow",
                                    header.size() + 36 + 13)));
}

TEST(PlyReaderFailure, HugeBinaryListCount) {
  const std::string header = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 3\n") + kXyzHeader +
                             "element face 1\nproperty list uint int vertex_indices\nend_header\n";
  BinaryBytes body(false);
  for (int i = 0; i < 9; ++i) body.put(0.0f);
  body.put<std::uint32_t>(4000000000u).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
  EXPECT_THAT(failureOf(header + body.str()),
              HasSubstr(fmt::format("byte {}: face 0 lists 4000000000 values for 'vertex_indices'",
                                    header.size() + 36)));
}

TEST(PlyReaderFailure, AsciiFaceIndexOutOfRange) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 3\n") + kXyzHeader +
                        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n"),
              HasSubstr("line 14: face 1: vertex index 7 out of range (3 vertices)"));
}

TEST(PlyReaderFailure, BinaryNegativeFaceIndex) {
  const std::string header = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 3\n") + kXyzHeader +
                             "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  BinaryBytes body(false);
  for (int i = 0; i < 9; ++i) body.put(0.0f);
  body.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(-1).put<std::int32_t>(2);
  EXPECT_THAT(failureOf(header + body.str()),
              HasSubstr(fmt::format("byte {}: face 0: vertex index -1 out of range (3 vertices)", header.size() + 36)));
}

// A bad index after good triangles: the face and its byte are named as
// when every face took the generic path.
TEST(PlyReaderFailure, BinaryFaceIndexOutOfRangeAfterGoodTriangles) {
  const std::string header = std::string("ply\nformat binary_little_endian 1.0\nelement vertex 3\n") + kXyzHeader +
                             "element face 3\nproperty list uchar uint vertex_indices\nend_header\n";
  BinaryBytes body(false);
  for (int i = 0; i < 9; ++i) body.put(0.0f);
  body.put<std::uint8_t>(3).put<std::uint32_t>(0).put<std::uint32_t>(1).put<std::uint32_t>(2);
  body.put<std::uint8_t>(3).put<std::uint32_t>(2).put<std::uint32_t>(1).put<std::uint32_t>(0);
  body.put<std::uint8_t>(3).put<std::uint32_t>(0).put<std::uint32_t>(3).put<std::uint32_t>(1);
  EXPECT_THAT(failureOf(header + body.str()),
              HasSubstr(fmt::format("byte {}: face 2: vertex index 3 out of range (3 vertices)", header.size() + 36 + 26)));
}

TEST(PlyReaderFailure, NonNumericAsciiToken) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 2\n") + kXyzHeader +
                        "end_header\n1 2 3\n4 five 6\n"),
              HasSubstr("line 9: non-numeric token 'five' in vertex 1"));
}

TEST(PlyReaderFailure, ExtraValuesOnAsciiLine) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 2\n") + kXyzHeader +
                        "end_header\n1 2 3\n4 5 6 7\n"),
              HasSubstr("line 9: vertex 1 has 1 more values than its vertex properties declare"));
}

TEST(PlyReaderFailure, TooFewValuesOnAsciiLine) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 2\n") + kXyzHeader +
                        "end_header\n1 2 3\n4 5\n"),
              HasSubstr("line 9: vertex 1 has no value for property 'z'"));
}

TEST(PlyReaderFailure, AsciiDataAfterLastElement) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 1\n") + kXyzHeader +
                        "end_header\n1 2 3\n4 5 6\n"),
              HasSubstr("line 9: unexpected data after the last element"));
}

TEST(PlyReaderFailure, PolygonWithTwoVertices) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 3\n") + kXyzHeader +
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n2 0 1\n"),
              HasSubstr("line 13: face 0 has 2 vertices, need at least 3"));
}

TEST(PlyReaderFailure, AsciiListCountBeyondLine) {
  EXPECT_THAT(failureOf(std::string("ply\nformat ascii 1.0\nelement vertex 3\n") + kXyzHeader +
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n"),
              HasSubstr("line 13: face 0 lists 4000000000 values for 'vertex_indices' but the line holds only 3"));
}

}  // namespace
}  // namespace apo::readers
