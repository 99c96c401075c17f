// encodePly: the exact header, determinism, and round trips through readPly
// in both encodings that must give back the same bits.
#include "ingest/readers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace apo::readers {
namespace {

// Floats that a careless printer would not round-trip.
const std::vector<float> kAwkwardFloats = {
    0.1f, -1.0f / 3.0f, 123456.789f, 1e-30f, std::numeric_limits<float>::denorm_min(),
    std::numeric_limits<float>::max(), -0.0f, 16777217.0f, 3.14159274f,
};

Scan pointCloud(bool normals, bool colors, bool intensities) {
  Scan scan;
  PointSet& points = scan.points;
  for (std::size_t i = 0; i < kAwkwardFloats.size(); ++i) {
    const float a = kAwkwardFloats[i];
    const float b = kAwkwardFloats[(i + 1) % kAwkwardFloats.size()];
    const float c = kAwkwardFloats[(i + 4) % kAwkwardFloats.size()];
    points.positions.emplace_back(a, b, c);
    if (normals) points.normals.emplace_back(Vec3f(static_cast<float>(i), 1.0f, -2.0f).normalized());
    if (colors) points.colors.push_back({static_cast<std::uint8_t>(i * 31), 255, static_cast<std::uint8_t>(i)});
    if (intensities) points.intensities.push_back(b * 0.5f);
  }
  return scan;
}

Scan mesh() {
  Scan scan = pointCloud(/*normals=*/true, /*colors=*/false, /*intensities=*/false);
  scan.triangles = {{0, 1, 2}, {2, 1, 3}, {4, 5, 6}, {8, 7, 6}, {0, 8, 4}};
  return scan;
}

// Bit-exact comparison, so that -0.0 and 0.0 differ.
bool sameBits(const Vec3f& a, const Vec3f& b) {
  for (int k = 0; k < 3; ++k)
    if (std::bit_cast<std::uint32_t>(a[k]) != std::bit_cast<std::uint32_t>(b[k])) return false;
  return true;
}
bool sameBits(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                    [](const Vec3f& p, const Vec3f& q) { return sameBits(p, q); });
}

void expectSameScan(const Scan& expected, const Scan& actual) {
  EXPECT_TRUE(sameBits(expected.points.positions, actual.points.positions));
  EXPECT_TRUE(sameBits(expected.points.normals, actual.points.normals));
  EXPECT_EQ(expected.points.colors, actual.points.colors);
  EXPECT_EQ(expected.points.intensities, actual.points.intensities);
  EXPECT_EQ(expected.points.classifications, actual.points.classifications);
  EXPECT_EQ(expected.points.returnNumbers, actual.points.returnNumbers);
  EXPECT_EQ(expected.points.returnCounts, actual.points.returnCounts);
  EXPECT_EQ(expected.triangles, actual.triangles);
  EXPECT_EQ(expected.origin, actual.origin);
}

class PlyRoundTrip : public ::testing::TestWithParam<PlyEncoding> {};

TEST_P(PlyRoundTrip, PositionsOnly) {
  const Scan scan = pointCloud(false, false, false);
  expectSameScan(scan, readPly(encodePly(scan, GetParam())));
}

TEST_P(PlyRoundTrip, PointCloudWithAllAttributes) {
  const Scan scan = pointCloud(true, true, true);
  expectSameScan(scan, readPly(encodePly(scan, GetParam())));
}

TEST_P(PlyRoundTrip, LidarAttributesAndTheLocalFrame) {
  Scan scan = pointCloud(false, true, true);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    scan.points.classifications.push_back(static_cast<std::uint8_t>(i % 7));
    scan.points.returnNumbers.push_back(static_cast<std::uint8_t>(1 + i % 3));
    scan.points.returnCounts.push_back(3);
  }
  scan.origin = {512049.0, 5403050.25, -0.1};
  expectSameScan(scan, readPly(encodePly(scan, GetParam())));
}

// World coordinates (--keep-georeference): origin + position in double, no
// origin comment; the reader moves them back into a local frame of its own
// choosing, and origin + position is the same point to double precision.
TEST_P(PlyRoundTrip, WorldCoordinatesAreWrittenInDouble) {
  Scan scan;  // a metre-sized tetrahedron 5.4e6 m from zero
  scan.points.positions = {Vec3f(-0.5f, -0.25f, 0.125f), Vec3f(0.75f, 0.1f, -0.3f), Vec3f(0.2f, 0.9f, 0.4f),
                           Vec3f(0.1f, 0.2f, 1.0f)};
  scan.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  scan.origin = {512000.0, 5403000.0, 300.0};
  const std::string text = encodePly(scan, GetParam(), PlyFrame::World);
  EXPECT_NE(text.find("property double x\nproperty double y\nproperty double z\n"), std::string::npos);
  EXPECT_EQ(text.find("apo_origin"), std::string::npos);
  const Scan read = readPly(text);
  ASSERT_EQ(read.points.size(), scan.points.size());
  EXPECT_EQ(read.triangles, scan.triangles);
  for (std::size_t i = 0; i < scan.points.size(); ++i)
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_DOUBLE_EQ(read.origin[axis] + read.points.positions[i][axis],
                       scan.origin[axis] + scan.points.positions[i][axis]);
  // A scan near zero has no other frame: World writes it as Local does.
  EXPECT_EQ(encodePly(mesh(), GetParam(), PlyFrame::World), encodePly(mesh(), GetParam()));
}

TEST_P(PlyRoundTrip, Mesh) {
  const Scan scan = mesh();
  expectSameScan(scan, readPly(encodePly(scan, GetParam())));
}

TEST_P(PlyRoundTrip, EmptyScan) {
  const Scan read = readPly(encodePly(Scan{}, GetParam()));
  EXPECT_EQ(read.points.size(), 0u);
  EXPECT_FALSE(read.isMesh());
}

TEST_P(PlyRoundTrip, NonFiniteCoordinatesSurvive) {
  Scan scan;
  const float inf = std::numeric_limits<float>::infinity();
  scan.points.positions = {Vec3f(std::nanf(""), inf, -inf)};
  const Scan read = readPly(encodePly(scan, GetParam()));
  ASSERT_EQ(read.points.size(), 1u);
  EXPECT_TRUE(std::isnan(read.points.positions[0].x()));
  EXPECT_EQ(read.points.positions[0].y(), inf);
  EXPECT_EQ(read.points.positions[0].z(), -inf);
}

TEST_P(PlyRoundTrip, OutputIsDeterministic) {
  EXPECT_EQ(encodePly(mesh(), GetParam()), encodePly(mesh(), GetParam()));
}

INSTANTIATE_TEST_SUITE_P(Encodings, PlyRoundTrip,
                         ::testing::Values(PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian),
                         [](const ::testing::TestParamInfo<PlyEncoding>& info) {
                           return info.param == PlyEncoding::Ascii ? "Ascii" : "BinaryLittleEndian";
                         });

TEST(PlyWriter, AsciiPointCloudWithAllAttributes) {
  Scan scan;
  scan.points.positions = {Vec3f(0.1f, -2, 3e-5f)};
  scan.points.normals = {Vec3f(0, 0, 1)};
  scan.points.colors = {{255, 0, 12}};
  scan.points.intensities = {0.5f};
  EXPECT_EQ(encodePly(scan, PlyEncoding::Ascii),
            "ply\n"
            "format ascii 1.0\n"
            "comment written by apo\n"
            "element vertex 1\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "property float intensity\n"
            "end_header\n"
            "0.1 -2 3e-05 0 0 1 255 0 12 0.5\n");
}

TEST(PlyWriter, AsciiMesh) {
  Scan scan;
  scan.points.positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)};
  scan.triangles = {{0, 1, 2}};
  EXPECT_EQ(encodePly(scan, PlyEncoding::Ascii),
            "ply\nformat ascii 1.0\ncomment written by apo\nelement vertex 3\n"
            "property float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
}

TEST(PlyWriter, BinaryLayout) {
  const Scan scan = mesh();
  const std::string bytes = encodePly(scan, PlyEncoding::BinaryLittleEndian);
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment written by apo\nelement vertex 9\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "element face 5\nproperty list uchar int vertex_indices\nend_header\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  constexpr std::size_t kVertexBytes = 6 * 4, kFaceBytes = 1 + 3 * 4;
  ASSERT_EQ(bytes.size(), header.size() + 9 * kVertexBytes + 5 * kFaceBytes);

  // First vertex's x, then the first face's corner count and indices.
  float x = 0;
  std::memcpy(&x, bytes.data() + header.size(), sizeof x);
  EXPECT_EQ(x, kAwkwardFloats[0]);
  const std::size_t firstFace = header.size() + 9 * kVertexBytes;
  EXPECT_EQ(bytes[firstFace], 3);
  const unsigned char secondFaceIndices[] = {2, 0, 0, 0, 1, 0, 0, 0, 3, 0, 0, 0};
  EXPECT_EQ(std::memcmp(bytes.data() + firstFace + kFaceBytes + 1, secondFaceIndices, sizeof secondFaceIndices), 0);
}

}  // namespace
}  // namespace apo::readers
