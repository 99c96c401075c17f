#include "ingest/parse_util.h"
#include "ingest/readers.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/ingest/reader_failure.h"
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

namespace apo::readers {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

// The per-field header lines; defaults describe x y z as 4-byte floats.
struct HeaderSpec {
  std::string fields = "x y z";
  std::string size = "4 4 4";
  std::string type = "F F F";
  std::string count = "1 1 1";
  std::string width = "";  // empty: WIDTH = POINTS
  std::string height = "1";
  std::string points = "1";
  std::string data = "ascii";
};

// A v0.7 header: 11 lines, so ascii points start on line 12.
std::string pcdHeader(const HeaderSpec& spec) {
  return "# .PCD v0.7 - Point Cloud Data file format\n"
         "VERSION 0.7\n"
         "FIELDS " + spec.fields + "\n"
         "SIZE " + spec.size + "\n"
         "TYPE " + spec.type + "\n"
         "COUNT " + spec.count + "\n"
         "WIDTH " + (spec.width.empty() ? spec.points : spec.width) + "\n"
         "HEIGHT " + spec.height + "\n"
         "VIEWPOINT 0 0 0 1 0 0 0\n"
         "POINTS " + spec.points + "\n"
         "DATA " + spec.data + "\n";
}

template <class T>
void appendBytes(std::string& out, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  out.append(raw, sizeof(T));
}

// The binary_compressed body: sizes, then `plain` (field-major) LZF-compressed.
std::string compressedBody(const std::string& plain) {
  std::string compressed(plain.size() * 2 + 64, '\0');
  const unsigned size = pcl::lzfCompress(plain.data(), static_cast<unsigned>(plain.size()), compressed.data(),
                                         static_cast<unsigned>(compressed.size()));
  EXPECT_GT(size, 0u);
  compressed.resize(size);
  std::string body;
  appendBytes<std::uint32_t>(body, size);
  appendBytes<std::uint32_t>(body, static_cast<std::uint32_t>(plain.size()));
  return body + compressed;
}

std::string failureOf(std::string_view bytes) { return test::readerFailure(readPcd, bytes); }

std::string fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Bitwise float equality, so that NaN payloads and -0 count.
bool sameBits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }

// ---- reading valid files ----

TEST(PcdReader, ReadsAsciiWithCommentsNormalsPackedRgbAndIntensity) {
  const std::string text =
      "# .PCD v0.7 - Point Cloud Data file format\n"
      "# a second comment\n"
      "VERSION 0.7\n"
      "FIELDS x y z normal_x normal_y normal_z rgb intensity\n"
      "SIZE 4 4 4 4 4 4 4 4\n"
      "TYPE F F F F F F F F\n"
      "COUNT 1 1 1 1 1 1 1 1\n"
      "WIDTH 2\n"
      "HEIGHT 1\n"
      "\n"
      "POINTS 2\n"
      "DATA ascii\n"
      "1.5 -2 0.25 0 0 1 4.2108e+06 0.5\n"
      "\n"
      "nan 3 4 1 0 0 0 12\r\n";
  const Scan scan = readPcd(text);
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points.positions[0], Vec3f(1.5f, -2.0f, 0.25f));
  EXPECT_TRUE(std::isnan(scan.points.positions[1].x()));
  EXPECT_EQ(scan.points.positions[1].tail<2>(), Eigen::Vector2f(3.0f, 4.0f));
  ASSERT_TRUE(scan.points.hasNormals());
  EXPECT_EQ(scan.points.normals[0], Vec3f(0, 0, 1));
  EXPECT_EQ(scan.points.normals[1], Vec3f(1, 0, 0));
  // 4.2108e+06f has the bits 0x4a8080e0.
  ASSERT_TRUE(scan.points.hasColors());
  EXPECT_EQ(scan.points.colors[0], (Rgb8{0x80, 0x80, 0xe0}));
  EXPECT_EQ(scan.points.colors[1], (Rgb8{0, 0, 0}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{0.5f, 12.0f}));
  EXPECT_FALSE(scan.viewpoint.has_value());
  EXPECT_FALSE(scan.isMesh());
}

TEST(PcdReader, ReadsUnsignedRgbaInAscii) {
  const std::string text = pcdHeader({.fields = "x y z rgba", .size = "4 4 4 4", .type = "F F F U",
                                      .count = "1 1 1 1", .points = "1"}) +
                           "0 0 0 4286595136\n";  // 0xff804040
  const Scan scan = readPcd(text);
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{0x80, 0x40, 0x40}}));
  EXPECT_FALSE(scan.points.hasNormals());
  EXPECT_FALSE(scan.points.hasIntensities());
}

TEST(PcdReader, ReadsOldVersionWithoutSizeTypeWidthOrViewpoint) {
  const std::string text =
      "VERSION .5\n"
      "COLUMNS x y z\n"
      "POINTS 2\n"
      "DATA ascii\n"
      "1 2 3\n"
      "4 5 6\n";
  const Scan scan = readPcd(text);
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_FALSE(scan.viewpoint.has_value());
}

TEST(PcdReader, ReadsBinaryWithPaddingField) {
  // Old PCL writers pad records with a field named "_".
  std::string bytes = pcdHeader({.fields = "x y z _ rgba intensity", .size = "4 4 4 1 4 2",
                                 .type = "F F F U U U", .count = "1 1 1 4 1 1", .points = "2", .data = "binary"});
  const float coords[2][3] = {{1.25f, -3.5f, 1e-7f}, {-0.0f, 1e30f, std::numeric_limits<float>::infinity()}};
  const std::uint32_t colors[2] = {0xff102030, 0x00a0b0c0};
  const std::uint16_t intensities[2] = {7, 65535};
  for (int i = 0; i < 2; ++i) {
    for (float c : coords[i]) appendBytes(bytes, c);
    appendBytes<std::uint32_t>(bytes, 0xdeadbeef);  // padding
    appendBytes(bytes, colors[i]);
    appendBytes(bytes, intensities[i]);
  }
  const Scan scan = readPcd(bytes);
  ASSERT_EQ(scan.points.size(), 2u);
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(sameBits(scan.points.positions[i][k], coords[i][k])) << i << "," << k;
  EXPECT_EQ(scan.points.colors, (std::vector<Rgb8>{{0x10, 0x20, 0x30}, {0xa0, 0xb0, 0xc0}}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{7.0f, 65535.0f}));
}

TEST(PcdReader, ReadsEveryScalarTypeInBinary) {
  std::string bytes = pcdHeader({.fields = "x y z intensity", .size = "8 2 1 4", .type = "F I U I",
                                 .count = "1 1 1 1", .points = "1", .data = "binary"});
  appendBytes<double>(bytes, 0.125);
  appendBytes<std::int16_t>(bytes, -300);
  appendBytes<std::uint8_t>(bytes, 200);
  appendBytes<std::int32_t>(bytes, -70000);
  const Scan scan = readPcd(bytes);
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{{0.125f, -300.0f, 200.0f}}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{-70000.0f}));
}

TEST(PcdReader, ReadsHandMadeBinaryCompressed) {
  std::string bytes = pcdHeader({.fields = "x y z _ intensity", .size = "4 4 4 1 4", .type = "F F F U F",
                                 .count = "1 1 1 3 1", .points = "3", .data = "binary_compressed"});
  // Field-major, and the padding field is not stored.
  std::string plain;
  for (float v : {1.0f, 2.0f, 3.0f}) appendBytes(plain, v);     // x
  for (float v : {4.0f, 5.0f, 6.0f}) appendBytes(plain, v);     // y
  for (float v : {7.0f, 8.0f, 9.0f}) appendBytes(plain, v);     // z
  for (float v : {0.1f, 0.2f, 0.3f}) appendBytes(plain, v);     // intensity
  bytes += compressedBody(plain);
  const Scan scan = readPcd(bytes);
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{{1, 4, 7}, {2, 5, 8}, {3, 6, 9}}));
  EXPECT_EQ(scan.points.intensities, (std::vector<float>{0.1f, 0.2f, 0.3f}));
}

// A cloud with values every encoding writes exactly (PCL's ascii writer
// keeps 8 significant digits).
pcl::PointCloud<pcl::PointXYZRGBNormal> exactCloud() {
  pcl::PointCloud<pcl::PointXYZRGBNormal> cloud;
  for (int i = 0; i < 50; ++i) {
    pcl::PointXYZRGBNormal p;
    p.x = 0.25f * static_cast<float>(i);
    p.y = -1.5f + static_cast<float>(i % 7);
    p.z = 1000.0f + 0.125f * static_cast<float>(i);
    p.r = static_cast<std::uint8_t>(i * 5);
    p.g = static_cast<std::uint8_t>(255 - i);
    p.b = static_cast<std::uint8_t>(i * 3 + 1);
    p.a = 255;
    p.normal_x = 0.0f;
    p.normal_y = i % 2 ? 1.0f : -1.0f;
    p.normal_z = 0.5f;
    p.curvature = 0.0f;
    cloud.push_back(p);
  }
  return cloud;
}

void expectSameAsCloud(const Scan& scan, const pcl::PointCloud<pcl::PointXYZRGBNormal>& cloud) {
  ASSERT_EQ(scan.points.size(), cloud.size());
  ASSERT_TRUE(scan.points.hasNormals());
  ASSERT_TRUE(scan.points.hasColors());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud[i];
    // Far from zero for its extent (z about 1000): in a local frame, as every reader does.
    const Vec3f local(static_cast<float>(p.x - scan.origin[0]), static_cast<float>(p.y - scan.origin[1]),
                      static_cast<float>(p.z - scan.origin[2]));
    EXPECT_EQ(scan.points.positions[i], local) << "point " << i;
    EXPECT_EQ(scan.points.normals[i], Vec3f(p.normal_x, p.normal_y, p.normal_z)) << "point " << i;
    EXPECT_EQ(scan.points.colors[i], (Rgb8{p.r, p.g, p.b})) << "point " << i;
  }
}

TEST(PcdReader, ReadsFilesWrittenByPclInEveryEncoding) {
  const auto dir = test::freshTempDir();
  const auto cloud = exactCloud();
  ASSERT_EQ(pcl::io::savePCDFileASCII((dir / "ascii.pcd").string(), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinary((dir / "binary.pcd").string(), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed((dir / "compressed.pcd").string(), cloud), 0);
  for (const char* name : {"ascii.pcd", "binary.pcd", "compressed.pcd"}) {
    SCOPED_TRACE(name);
    expectSameAsCloud(readPcd(fileBytes(dir / name)), cloud);
  }
}

TEST(PcdReader, ReadsPclCompressedIntensityCloud) {
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (int i = 0; i < 1000; ++i)
    cloud.push_back(pcl::PointXYZI(std::sin(0.1f * i), std::cos(0.3f * i), 0.001f * i, 1.0f / (1.0f + i)));
  const auto path = test::freshTempDir() / "xyzi.pcd";
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(path.string(), cloud), 0);
  const Scan scan = readPcd(fileBytes(path));
  ASSERT_EQ(scan.points.size(), cloud.size());
  ASSERT_TRUE(scan.points.hasIntensities());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_EQ(scan.points.positions[i], Vec3f(cloud[i].x, cloud[i].y, cloud[i].z)) << "point " << i;
    EXPECT_EQ(scan.points.intensities[i], cloud[i].intensity) << "point " << i;
  }
}

TEST(PcdReader, KeepsNanPointsOfOrganizedCloudAndReadsViewpoint) {
  std::string text =
      "VERSION 0.7\n"
      "FIELDS x y z\n"
      "SIZE 4 4 4\n"
      "TYPE F F F\n"
      "COUNT 1 1 1\n"
      "WIDTH 4\n"
      "HEIGHT 3\n"
      "VIEWPOINT 1 2 3 0.5 -0.5 0.5 -0.5\n"
      "POINTS 12\n"
      "DATA ascii\n";
  for (int i = 0; i < 12; ++i) text += i % 3 == 1 ? "nan nan nan\n" : fmt::format("{} {} 1\n", i % 4, i / 4);
  const Scan scan = readPcd(text);
  ASSERT_EQ(scan.points.size(), 12u);
  for (int i = 0; i < 12; ++i) {
    if (i % 3 == 1) {
      EXPECT_TRUE(scan.points.positions[i].array().isNaN().all()) << "point " << i;
    } else {
      EXPECT_EQ(scan.points.positions[i], Vec3f(i % 4, i / 4, 1)) << "point " << i;
    }
  }
  ASSERT_TRUE(scan.viewpoint.has_value());
  EXPECT_EQ(scan.viewpoint->origin, Vec3f(1, 2, 3));
  EXPECT_EQ(scan.viewpoint->orientationWxyz, (std::array<float, 4>{0.5f, -0.5f, 0.5f, -0.5f}));
}

TEST(PcdReader, SkipsFieldWithCountAboveOneInAscii) {
  const std::string text = pcdHeader({.fields = "x fpfh y z", .size = "4 4 4 4", .type = "F F F F",
                                      .count = "1 3 1 1", .points = "2"}) +
                           "1 9 9 9 2 3\n"
                           "4 8 8 8 5 6\n";
  const Scan scan = readPcd(text);
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}}));
}

TEST(PcdReader, SkipsFieldWithCountAboveOneInBinary) {
  std::string bytes = pcdHeader({.fields = "x fpfh y z", .size = "4 8 4 4", .type = "F F F F",
                                 .count = "1 3 1 1", .points = "2", .data = "binary"});
  for (float base : {1.0f, 4.0f}) {
    appendBytes(bytes, base);
    for (int k = 0; k < 3; ++k) appendBytes(bytes, 99.0);
    appendBytes(bytes, base + 1);
    appendBytes(bytes, base + 2);
  }
  const Scan scan = readPcd(bytes);
  EXPECT_EQ(scan.points.positions, (std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}}));
}

TEST(PcdReader, ReadsEmptyCloud) {
  const Scan scan = readPcd(pcdHeader({.points = "0", .data = "binary"}));
  EXPECT_EQ(scan.points.size(), 0u);
}

// ---- refusing malformed files ----

TEST(PcdReader, FailsOnEmptyFile) {
  EXPECT_THAT(failureOf(""), StartsWith("line 1: empty file"));
}

TEST(PcdReader, FailsOnWrongMagic) {
  const std::string message = failureOf("# comment\nply\nformat ascii 1.0\n");
  EXPECT_THAT(message, StartsWith("line 2: "));
  EXPECT_THAT(message, HasSubstr("not a PCD header"));
  EXPECT_THAT(message, HasSubstr("'ply'"));
}

TEST(PcdReader, FailsWithoutDataLine) {
  const std::string header = pcdHeader({});
  EXPECT_THAT(failureOf(header.substr(0, header.rfind("DATA"))), StartsWith("line 10: header ends without a DATA line"));
}

TEST(PcdReader, FailsOnUnknownKeywordInHeader) {
  EXPECT_THAT(failureOf("VERSION 0.7\nFIELDS x y z\nCOLOUR red\n"),
              StartsWith("line 3: unknown PCD header keyword 'COLOUR'"));
}

TEST(PcdReader, FailsOnRepeatedKeyword) {
  EXPECT_THAT(failureOf("VERSION 0.7\nPOINTS 1\nPOINTS 2\nDATA ascii\n"),
              StartsWith("line 3: second POINTS line (the first is line 2)"));
}

TEST(PcdReader, FailsOnFieldsSizeMismatch) {
  const std::string message = failureOf(pcdHeader({.size = "4 4"}) + "1 2 3\n");
  EXPECT_THAT(message, StartsWith("line 4: "));
  EXPECT_THAT(message, HasSubstr("SIZE lists 2 values but FIELDS (line 3) lists 3"));
}

TEST(PcdReader, FailsOnInvalidSize) {
  EXPECT_THAT(failureOf(pcdHeader({.size = "4 3 4"})), StartsWith("line 4: SIZE 3 is not a valid element size"));
}

TEST(PcdReader, FailsOnTwoByteFloat) {
  const std::string message = failureOf(pcdHeader({.size = "4 2 4"}));
  EXPECT_THAT(message, StartsWith("line 5: "));
  EXPECT_THAT(message, HasSubstr("field 'y' has TYPE F and SIZE 2"));
}

TEST(PcdReader, FailsOnUnknownType) {
  EXPECT_THAT(failureOf(pcdHeader({.type = "F D F"})), StartsWith("line 5: TYPE 'D' is not I, U or F"));
}

TEST(PcdReader, FailsOnNegativeCount) {
  const std::string message = failureOf(pcdHeader({.count = "1 -1 1"}));
  EXPECT_THAT(message, StartsWith("line 6: "));
  EXPECT_THAT(message, HasSubstr("COUNT must not be negative, got -1"));
}

TEST(PcdReader, FailsOnNonIntegerPoints) {
  const std::string message = failureOf(pcdHeader({.width = "2", .points = "2.5"}));
  EXPECT_THAT(message, StartsWith("line 10: "));
  EXPECT_THAT(message, HasSubstr("'2.5'"));
}

TEST(PcdReader, FailsWhenPointsIsNotWidthTimesHeight) {
  EXPECT_THAT(failureOf(pcdHeader({.width = "4", .height = "3", .points = "13"})),
              StartsWith("line 10: POINTS 13 does not match WIDTH 4 x HEIGHT 3 = 12"));
}

TEST(PcdReader, FailsWithoutCoordinateField) {
  EXPECT_THAT(failureOf(pcdHeader({.fields = "x y w"})), StartsWith("line 3: FIELDS has no 'z'"));
}

TEST(PcdReader, FailsOnUsedFieldWithCountAboveOne) {
  const std::string message =
      failureOf(pcdHeader({.fields = "x y z intensity", .size = "4 4 4 4", .type = "F F F F", .count = "1 1 1 2"}));
  EXPECT_THAT(message, StartsWith("line 6: field 'intensity' has COUNT 2"));
}

TEST(PcdReader, FailsOnUnknownDataEncoding) {
  EXPECT_THAT(failureOf(pcdHeader({.data = "compressed"})), StartsWith("line 11: unknown DATA encoding 'compressed'"));
}

TEST(PcdReader, FailsOnNonNumericAsciiToken) {
  const std::string message = failureOf(pcdHeader({.points = "2"}) + "1 2 3\n4 abc 6\n");
  EXPECT_THAT(message, StartsWith("line 13: non-numeric token 'abc' in point 1"));
}

TEST(PcdReader, FailsOnNonNumericTokenInSkippedField) {
  const std::string message = failureOf(
      pcdHeader({.fields = "x y z extra", .size = "4 4 4 4", .type = "F F F F", .count = "1 1 1 1"}) + "1 2 3 ?\n");
  EXPECT_THAT(message, StartsWith("line 12: non-numeric token '?' in point 0 (field 'extra')"));
}

TEST(PcdReader, FailsOnAsciiLineWithTooFewValues) {
  EXPECT_THAT(failureOf(pcdHeader({.points = "1"}) + "1 2\n"), StartsWith("line 12: point 0 has 2 values, expected 3"));
}

TEST(PcdReader, FailsWhenAsciiPointsExceedLines) {
  EXPECT_THAT(failureOf(pcdHeader({.points = "5"}) + "1 2 3\n4 5 6\n7 8 9\n"),
              StartsWith("line 14: file ends after 3 of 5 points"));
}

TEST(PcdReader, FailsOnAsciiDataAfterLastPoint) {
  EXPECT_THAT(failureOf(pcdHeader({.points = "1"}) + "1 2 3\n\n4 5 6\n"),
              StartsWith("line 14: more data after the 1 points"));
}

TEST(PcdReader, FailsWhenBinaryPointsExceedBody) {
  const std::string header = pcdHeader({.points = "3", .data = "binary"});
  std::string bytes = header;
  for (int i = 0; i < 6; ++i) appendBytes(bytes, 1.0f);  // two of three points
  const std::string message = failureOf(bytes);
  EXPECT_THAT(message, StartsWith(fmt::format("byte {}: ", header.size())));
  EXPECT_THAT(message, HasSubstr("header claims 3 points (12 bytes each) but only 24 bytes follow"));
}

TEST(PcdReader, FailsOnTruncatedBinaryBody) {
  const std::string header = pcdHeader({.points = "2", .data = "binary"});
  std::string bytes = header;
  for (int i = 0; i < 6; ++i) appendBytes(bytes, 1.0f);
  bytes.resize(bytes.size() - 1);  // cut inside the last float
  EXPECT_THAT(failureOf(bytes), StartsWith(fmt::format("byte {}: header claims 2 points", header.size())));
}

TEST(PcdReader, FailsFastOnHugePointCountInSmallFile) {
  const std::string points = "4000000000";
  EXPECT_THAT(failureOf(pcdHeader({.points = points}) + "1 2 3\n"),
              StartsWith("line 12: file ends after 1 of 4000000000 points"));

  const std::string binaryHeader = pcdHeader({.points = points, .data = "binary"});
  EXPECT_THAT(failureOf(binaryHeader + std::string(12, '\0')),
              StartsWith(fmt::format("byte {}: header claims 4000000000 points", binaryHeader.size())));

  std::string plain;
  for (float v : {1.0f, 2.0f, 3.0f}) appendBytes(plain, v);
  const std::string compressedHeader = pcdHeader({.points = points, .data = "binary_compressed"});
  EXPECT_THAT(failureOf(compressedHeader + compressedBody(plain)),
              StartsWith(fmt::format("byte {}: uncompressed size 12 does not match POINTS 4000000000",
                                     compressedHeader.size() + 4)));
}

TEST(PcdReader, FailsOnWidthTimesHeightOverflow) {
  EXPECT_THAT(failureOf(pcdHeader({.width = "4294967296", .height = "4294967296", .points = "1"})),
              StartsWith("line 7: WIDTH 4294967296 x HEIGHT 4294967296 is too large"));
}

std::string compressedXyzHeader(int points) {
  return pcdHeader({.points = std::to_string(points), .data = "binary_compressed"});
}

TEST(PcdReader, FailsOnCorruptLzfData) {
  const std::string header = compressedXyzHeader(2);
  std::string bytes = header;
  appendBytes<std::uint32_t>(bytes, 4);
  appendBytes<std::uint32_t>(bytes, 24);
  bytes += "\xff\xff\xff\xff";  // a back reference before the start of the output
  EXPECT_THAT(failureOf(bytes), StartsWith(fmt::format("byte {}: corrupt LZF data", header.size() + 8)));
}

TEST(PcdReader, FailsOnLzfDataThatDecompressesShort) {
  const std::string header = compressedXyzHeader(1);
  std::string plain;
  for (float v : {1.0f, 2.0f}) appendBytes(plain, v);  // 8 of the 12 bytes
  std::string body = compressedBody(plain);
  const std::uint32_t claimed = 12;
  std::memcpy(body.data() + 4, &claimed, sizeof claimed);
  EXPECT_THAT(failureOf(header + body), StartsWith(fmt::format("byte {}: corrupt LZF data", header.size() + 8)));
}

TEST(PcdReader, FailsOnCompressedSizeBeyondFile) {
  const std::string header = compressedXyzHeader(1);
  std::string plain;
  for (float v : {1.0f, 2.0f, 3.0f}) appendBytes(plain, v);
  std::string body = compressedBody(plain);
  body.resize(body.size() - 2);
  const std::string message = failureOf(header + body);
  EXPECT_THAT(message, StartsWith(fmt::format("byte {}: compressed size", header.size())));
  EXPECT_THAT(message, HasSubstr("runs past the end of the file"));
}

TEST(PcdReader, FailsOnUncompressedSizeNotMatchingPoints) {
  const std::string header = compressedXyzHeader(2);
  std::string plain;
  for (float v : {1.0f, 2.0f, 3.0f}) appendBytes(plain, v);
  EXPECT_THAT(failureOf(header + compressedBody(plain)),
              StartsWith(fmt::format("byte {}: uncompressed size 12 does not match POINTS 2 x 12 bytes per point",
                                     header.size() + 4)));
}

TEST(PcdReader, FailsOnImplausibleUncompressedSize) {
  // Consistent with POINTS, but no small file can expand to 4 GiB.
  const std::string header = compressedXyzHeader(357913941);
  std::string bytes = header;
  appendBytes<std::uint32_t>(bytes, 4);
  appendBytes<std::uint32_t>(bytes, 357913941u * 12u);
  bytes += std::string(4, '\0');
  EXPECT_THAT(failureOf(bytes), StartsWith(fmt::format("byte {}: uncompressed size 4294967292 is implausible",
                                                       header.size() + 4)));
}

TEST(PcdReader, FailsOnTruncatedCompressedSizes) {
  const std::string header = compressedXyzHeader(1);
  EXPECT_THAT(failureOf(header + "\x01\x00"), StartsWith(fmt::format("byte {}: truncated compressed size", header.size())));
}

}  // namespace
}  // namespace apo::readers
