// The LAS reader against files written here field by field (LAS 1.2 and
// 1.4, point formats 0 to 10) and against real files from other writers
// (fuzz/corpus/las/, PDAL's test data): what each header declares is the
// ground truth, and the broken ones must be refused naming the problem.
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include "tests/ingest/reader_failure.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace apo {
namespace {
namespace fs = std::filesystem;

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

std::string lasFailure(std::string_view bytes) { return test::readerFailure(readers::readLas, bytes); }

template <class T>
void put(std::string& bytes, std::size_t at, T value) {
  if (bytes.size() < at + sizeof(T)) bytes.resize(at + sizeof(T), '\0');
  std::memcpy(bytes.data() + at, &value, sizeof(T));  // little-endian machine
}

struct LasPoint {
  std::array<std::int32_t, 3> xyz{};
  std::uint16_t intensity = 0;
  int returnNumber = 1, returnCount = 1;
  std::uint8_t classification = 0;
  std::array<std::uint16_t, 3> rgb{};
};

constexpr std::array<std::uint16_t, 11> kFormatSize = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
constexpr std::array<std::uint16_t, 11> kRgbAt = {0, 0, 20, 28, 0, 28, 0, 30, 30, 0, 30};

// A LAS file as the specification lays it out: the public header (227 bytes
// for 1.2, 375 for 1.4), one VLR of `vlrPayload` bytes, then the points.
std::string lasFile(int minor, int format, const std::vector<LasPoint>& points, std::array<double, 3> scale,
                    std::array<double, 3> offset, int extraBytes = 0, std::size_t vlrPayload = 10) {
  const std::size_t headerSize = minor >= 4 ? 375 : 227;
  const std::uint16_t recordLength = static_cast<std::uint16_t>(kFormatSize[format] + extraBytes);
  std::string bytes(headerSize, '\0');
  std::memcpy(bytes.data(), "LASF", 4);
  bytes[24] = 1;
  bytes[25] = static_cast<char>(minor);
  std::memcpy(bytes.data() + 26, "apo test", 8);
  put<std::uint16_t>(bytes, 94, static_cast<std::uint16_t>(headerSize));
  const std::uint32_t pointOffset = static_cast<std::uint32_t>(headerSize + 54 + vlrPayload);
  put<std::uint32_t>(bytes, 96, pointOffset);
  put<std::uint32_t>(bytes, 100, 1);
  bytes[104] = static_cast<char>(format);
  put<std::uint16_t>(bytes, 105, recordLength);
  put<std::uint32_t>(bytes, 107, minor >= 4 ? 0 : static_cast<std::uint32_t>(points.size()));
  for (int axis = 0; axis < 3; ++axis) {
    put<double>(bytes, 131 + 8 * axis, scale[axis]);
    put<double>(bytes, 155 + 8 * axis, offset[axis]);
  }
  if (minor >= 4) put<std::uint64_t>(bytes, 247, points.size());
  // One VLR: 54 bytes of header, then its payload.
  std::string vlr(54 + vlrPayload, '\0');
  std::memcpy(vlr.data() + 2, "apo", 3);
  put<std::uint16_t>(vlr, 52, static_cast<std::uint16_t>(vlrPayload));
  bytes += vlr;
  const bool extended = format >= 6;
  for (const LasPoint& p : points) {
    std::string record(recordLength, '\x7f');  // extra bytes and unread fields hold garbage
    for (int axis = 0; axis < 3; ++axis) put<std::int32_t>(record, 4 * axis, p.xyz[axis]);
    put<std::uint16_t>(record, 12, p.intensity);
    record[14] = static_cast<char>(extended ? (p.returnNumber | p.returnCount << 4) : (p.returnNumber | p.returnCount << 3));
    if (extended)
      record[16] = static_cast<char>(p.classification);
    else
      record[15] = static_cast<char>(p.classification | 0x20);  // a flag bit above the class
    if (kRgbAt[format] != 0)
      for (int c = 0; c < 3; ++c) put<std::uint16_t>(record, kRgbAt[format] + 2 * c, p.rgb[c]);
    bytes += record;
  }
  return bytes;
}

std::vector<LasPoint> threePoints() {
  return {{{1000, 2000, 3000}, 100, 1, 2, 2, {65535, 0, 32768}},
          {{-500, 0, 250}, 200, 2, 2, 5, {0, 65535, 256}},
          {{0, 0, 0}, 65535, 1, 1, 9, {0, 0, 0}}};
}

TEST(LasReader, EveryPointFormatOfLas12And14KeepsCoordinatesAndAttributes) {
  for (int minor : {2, 4})
    for (int format = 0; format <= 10; ++format) {
      if (minor < 4 && format > 5) continue;
      SCOPED_TRACE(testing::Message() << "LAS 1." << minor << " format " << format);
      const Scan scan = readers::readLas(lasFile(minor, format, threePoints(), {0.01, 0.01, 0.001}, {10, 20, 30}));
      ASSERT_EQ(scan.points.size(), 3u);
      EXPECT_EQ(scan.origin, (std::array<double, 3>{0, 0, 0}));  // near zero for its extent
      EXPECT_FLOAT_EQ(scan.points.positions[0].x(), 20.0f);       // 1000 * 0.01 + 10
      EXPECT_FLOAT_EQ(scan.points.positions[0].y(), 40.0f);
      EXPECT_FLOAT_EQ(scan.points.positions[0].z(), 33.0f);
      EXPECT_FLOAT_EQ(scan.points.positions[1].x(), 5.0f);
      EXPECT_FLOAT_EQ(scan.points.positions[1].z(), 30.25f);
      EXPECT_EQ(scan.points.intensities, (std::vector<float>{100, 200, 65535}));
      EXPECT_EQ(scan.points.classifications, (std::vector<std::uint8_t>{2, 5, 9}));
      EXPECT_EQ(scan.points.returnNumbers, (std::vector<std::uint8_t>{1, 2, 1}));
      EXPECT_EQ(scan.points.returnCounts, (std::vector<std::uint8_t>{2, 2, 1}));
      if (kRgbAt[format] != 0) {
        ASSERT_EQ(scan.points.colors.size(), 3u);
        EXPECT_EQ(scan.points.colors[0], (Rgb8{255, 0, 128}));  // 16-bit channels, top byte
        EXPECT_EQ(scan.points.colors[1], (Rgb8{0, 255, 1}));
      } else {
        EXPECT_TRUE(scan.points.colors.empty());
      }
    }
}

TEST(LasReader, EightBitColoursInSixteenBitChannelsAreTakenAsTheyAre) {
  std::vector<LasPoint> points = threePoints();
  for (LasPoint& p : points) p.rgb = {200, 100, 50};
  const Scan scan = readers::readLas(lasFile(2, 3, points, {1, 1, 1}, {0, 0, 0}));
  EXPECT_EQ(scan.points.colors[0], (Rgb8{200, 100, 50}));
}

TEST(LasReader, GeoreferencedCoordinatesMoveToALocalFrameInDouble) {
  // An airborne tile in UTM metres, at millimetre resolution.
  std::vector<LasPoint> points;
  for (int i = 0; i < 100; ++i) points.push_back({{i * 997, i * 1009, i * 13}});
  const std::array<double, 3> offset = {512000.0, 5403000.0, 300.0};
  const Scan scan = readers::readLas(lasFile(2, 1, points, {0.001, 0.001, 0.001}, offset));
  // The centre of [512000, 512098.7] x [5403000, 5403099.9] x [300, 301.3], rounded.
  EXPECT_EQ(scan.origin, (std::array<double, 3>{512049.0, 5403050.0, 301.0}));
  for (int i = 0; i < 100; ++i) {
    // Exact to the millimetre (float at 50 m has 4 micrometres of resolution).
    EXPECT_NEAR(scan.points.positions[i].x(), i * 0.997 + 512000.0 - 512049.0, 1e-5) << i;
    EXPECT_NEAR(scan.points.positions[i].y(), i * 1.009 + 5403000.0 - 5403050.0, 1e-5) << i;
  }
  EXPECT_THAT(scan.readNotes, testing::Contains(HasSubstr("local frame")));
}

TEST(LasReader, AWholeUnitShiftGivesTheSameLocalPositions) {
  std::vector<LasPoint> points;
  for (int i = 0; i < 50; ++i) points.push_back({{i * 12345 % 100000, i * 777, i * 31}});
  const Scan a = readers::readLas(lasFile(2, 0, points, {0.001, 0.001, 0.001}, {512000.0, 5403000.0, 300.0}));
  const Scan b = readers::readLas(lasFile(2, 0, points, {0.001, 0.001, 0.001}, {513000.0, 5404000.0, 310.0}));
  EXPECT_EQ(a.points.positions, b.points.positions);
  EXPECT_EQ(b.origin[0] - a.origin[0], 1000.0);
}

TEST(LasReader, ExtraBytesAreSkippedByTheRecordLengthAndSaidSo) {
  const Scan scan = readers::readLas(lasFile(4, 3, threePoints(), {0.01, 0.01, 0.01}, {0, 0, 0}, 27));
  ASSERT_EQ(scan.points.size(), 3u);
  EXPECT_FLOAT_EQ(scan.points.positions[2].x(), 0.0f);
  EXPECT_THAT(scan.readNotes, testing::Contains(HasSubstr("27 extra bytes per point")));
}

TEST(LasReader, RefusesWhatItCannotReadNamingTheByte) {
  const std::string good = lasFile(2, 1, threePoints(), {0.01, 0.01, 0.01}, {0, 0, 0});
  EXPECT_THAT(lasFailure("LASF"), HasSubstr("ends inside the 227-byte LAS header"));
  EXPECT_THAT(lasFailure("PK\x03\x04" + std::string(300, '\0')), StartsWith("byte 0: not a LAS file"));
  std::string bytes = good;
  bytes[24] = 2;
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 24: LAS version 2.2"));
  bytes = good;
  bytes[104] = static_cast<char>(0x81);  // LASzip's compression bit, without LASzip's VLR
  EXPECT_THAT(lasFailure(bytes), AllOf(StartsWith("byte 104:"), HasSubstr("LASzip-compressed"),
                                       HasSubstr("no LASzip VLR (user id 'laszip encoded', record 22204)")));
  bytes = good;
  bytes[104] = 11;
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 104: point data format 11"));
  bytes = good;
  put<std::uint16_t>(bytes, 105, 19);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 105: point record length 19 is shorter"));
  bytes = good;
  put<std::uint32_t>(bytes, 96, 100000);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 96: offset to point data 100000"));
  bytes = good;
  put<double>(bytes, 139, 0.0);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 139: scale factor 0"));
  bytes = good;
  put<std::uint32_t>(bytes, 107, 4000000000u);  // far more points than bytes
  EXPECT_THAT(lasFailure(bytes), HasSubstr("header claims 4000000000 LAS points in format 1 (28 bytes each)"));
  bytes = good;
  put<std::uint32_t>(bytes, 107, 0);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 107: no points"));
  // Every truncation of the body is refused, never read past the end.
  for (std::size_t size = good.size() - 1; size > good.size() - 3 * 28; size -= 7)
    EXPECT_THAT(lasFailure(good.substr(0, size)), HasSubstr("header claims 3 LAS points")) << size;
}

TEST(LasReader, AVlrCountThatDoesNotAddUpIsNotedNotFatal) {
  std::string bytes = lasFile(2, 0, threePoints(), {1, 1, 1}, {0, 0, 0});
  put<std::uint32_t>(bytes, 100, 1000000000);
  const Scan scan = readers::readLas(bytes);
  EXPECT_EQ(scan.points.size(), 3u);
  EXPECT_THAT(scan.readNotes, testing::Contains(HasSubstr("declares 1000000000 variable-length records, but 1 fit")));
}

// ---- Real files from other writers ------------------------------------------------

std::string realFile(const std::string& name) {
  std::ifstream in(fs::path(APO_SOURCE_DIR) / "fuzz" / "corpus" / "las" / name, std::ios::binary);
  EXPECT_TRUE(in) << name;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// The header's bounding box (max x at 179, min x at 187, ...), in the file's
// coordinates: every point read must lie in it.
void expectInsideHeaderBox(const std::string& bytes, const Scan& scan) {
  std::array<double, 3> lo{}, hi{};
  for (int axis = 0; axis < 3; ++axis) {
    std::memcpy(&hi[axis], bytes.data() + 179 + 16 * axis, 8);
    std::memcpy(&lo[axis], bytes.data() + 187 + 16 * axis, 8);
  }
  for (const Vec3f& p : scan.points.positions)
    for (int axis = 0; axis < 3; ++axis) {
      const double world = scan.origin[axis] + p[axis];
      // A thousandth of the extent, or float's step at the coordinate when
      // the frame did not move (a single point has no extent to recentre).
      const double slack = std::max(1e-3 * std::max(1.0, hi[axis] - lo[axis]), 1e-7 * std::abs(world));
      ASSERT_GE(world, lo[axis] - slack) << "axis " << axis;
      ASSERT_LE(world, hi[axis] + slack) << "axis " << axis;
    }
}

TEST(LasReader, ReadsTheRealFilesTheirHeadersDescribe) {
  struct Expected {
    const char* name;
    std::size_t points;
  };
  for (const Expected& file : {Expected{"simple.las", 1065}, Expected{"1.2-with-color.las", 1065},
                               Expected{"100-points.las", 100}, Expected{"extrabytes.las", 1065},
                               Expected{"test1_4.las", 1000}, Expected{"prec3.las", 110}, Expected{"hextest.las", 8},
                               Expected{"gps-time-nan.las", 1}, Expected{"utm15.las", 1}, Expected{"spec_3.las", 10},
                               Expected{"bad_vlr_count.las", 10}, Expected{"permutations_1.0_0.las", 1},
                               Expected{"permutations_1.1_1.las", 1}, Expected{"permutations_1.2_2.las", 1},
                               Expected{"permutations_1.2_3.las", 1}, Expected{"lots_of_vlr.las", 1}}) {
    SCOPED_TRACE(file.name);
    const std::string bytes = realFile(file.name);
    Scan scan;
    ASSERT_NO_THROW(scan = readers::readLas(bytes));
    EXPECT_EQ(scan.points.size(), file.points);
    expectInsideHeaderBox(bytes, scan);
  }
}

TEST(LasReader, RefusesTheBrokenRealFilesSayingWhy) {
  EXPECT_THAT(lasFailure(realFile("permutations_1.2-no-points.las")),
              HasSubstr("header claims 1065 LAS points in format 3 (34 bytes each) but only 0 bytes follow"));
  EXPECT_THAT(lasFailure(realFile("garbage_nVariableLength.las")),
              HasSubstr("header claims 719 LAS points in format 0 (20 bytes each) but only 14374 bytes follow"));
  EXPECT_THAT(lasFailure(realFile("no-points.las")), HasSubstr("no points"));
}

// What @loaders.gl/las (an independent reader, npm, pinned in
// package-lock.json and installed by setup.sh) reads from a real file.
nlohmann::json readByLoadersGl(const std::string& name) {
  const fs::path source(APO_SOURCE_DIR);
  const fs::path output = fs::path(testing::TempDir()) / (name + ".loadersgl.json");
  const std::string command = "node '" + (source / "tests/ingest/loadersgl_las.mjs").string() + "' '" +
                              (source / "fuzz/corpus/las" / name).string() + "' > '" + output.string() + "'";
  const int status = std::system(command.c_str());
  std::ifstream in(output);
  const nlohmann::json read = nlohmann::json::parse(in, nullptr, false);
  EXPECT_EQ(status, 0) << command << ": " << read.dump().substr(0, 300);
  return read;
}

// Every real file of LAS 1.0 to 1.3 that both read (loaders.gl refuses 1.4,
// whose point formats 6 to 10 the test above writes field by field): the
// same points in the same order, at the same world coordinates (ours are a
// double origin plus float offsets), with the same intensity,
// classification and colour (loaders.gl turns 16-bit channels into bytes
// by dividing by 256, as we do by shifting).
TEST(LasReader, AgreesWithLoadersGlOnTheRealFiles) {
  for (const char* name : {"simple.las", "1.2-with-color.las", "100-points.las", "prec3.las",
                           "hextest.las", "gps-time-nan.las", "utm15.las", "spec_3.las", "bad_vlr_count.las",
                           "interesting.las", "lots_of_vlr.las", "permutations_1.0_0.las", "permutations_1.0_1.las",
                           "permutations_1.1_0.las", "permutations_1.1_1.las", "permutations_1.2_0.las",
                           "permutations_1.2_1.las", "permutations_1.2_2.las", "permutations_1.2_3.las"}) {
    SCOPED_TRACE(name);
    const nlohmann::json theirs = readByLoadersGl(name);
    ASSERT_TRUE(theirs.contains("positions")) << theirs.dump().substr(0, 300);
    const Scan ours = readers::readLas(realFile(name));
    ASSERT_EQ(ours.points.size(), theirs["points"].get<std::size_t>());
    ASSERT_EQ(theirs["positions"].size(), 3 * ours.points.size());
    for (std::size_t i = 0; i < ours.points.size(); ++i)
      for (int axis = 0; axis < 3; ++axis) {
        const float local = ours.points.positions[i][axis];
        const double world = ours.origin[axis] + local;
        // float's step at the offset from the origin, and double's rounding
        // of scale x integer + offset.
        const double slack = 1e-7 * std::abs(local) + 1e-12 * std::max(1.0, std::abs(world));
        ASSERT_NEAR(world, theirs["positions"][3 * i + axis].get<double>(), slack) << "point " << i << " axis " << axis;
      }
    ASSERT_EQ(ours.points.intensities.size(), ours.points.size());
    for (std::size_t i = 0; i < ours.points.size(); ++i) {
      ASSERT_EQ(ours.points.intensities[i], theirs["intensity"][i].get<double>()) << "point " << i;
      ASSERT_EQ(ours.points.classifications[i], theirs["classification"][i].get<int>()) << "point " << i;
    }
    ASSERT_EQ(ours.points.hasColors(), !theirs["colors"].is_null());
    for (std::size_t i = 0; i < ours.points.colors.size(); ++i) {
      const Rgb8 colour = ours.points.colors[i];
      ASSERT_EQ((std::array<int, 3>{colour.r, colour.g, colour.b}),
                (std::array<int, 3>{theirs["colors"][3 * i].get<int>(), theirs["colors"][3 * i + 1].get<int>(),
                                    theirs["colors"][3 * i + 2].get<int>()}))
          << "point " << i;
    }
  }
}

}  // namespace
}  // namespace apo
