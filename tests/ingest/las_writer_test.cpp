// The LAS and LAZ writer (ingest/las_writer.cpp, ingest/laz_encoder.cpp):
// the LAZ encoder re-encodes LASzip's own files byte for byte; synthetic
// scans of several chunks come back through our reader (LAZ records equal to
// the LAS file's) and through laz-perf, the independent decoder; the header
// holds the counts and bounds, and the points their attributes.
#include "core/file_io.h"
#include "ingest/ingest.h"
#include "ingest/laz_encoder.h"
#include "ingest/readers.h"

#include "tests/ingest/lazperf.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

namespace apo {
namespace {
namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(APO_SOURCE_DIR) / "fuzz" / "corpus" / "laz";

template <class T>
T get(std::string_view bytes, std::size_t at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof value);
  return value;
}

std::size_t firstDifference(std::string_view a, std::string_view b) {
  std::size_t i = 0;
  while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
  return i;
}

// A scan of `count` points along a noisy spiral (neighbours close, as a
// scanner's are), in `stations` stations, with optional colours and
// fractional intensities; fixed seed.
Scan spiralScan(std::size_t count, bool colors, bool intensities, std::uint16_t stations = 3) {
  std::mt19937 random(7);
  std::normal_distribution<float> noise(0.0f, 1e-4f);
  Scan scan;
  PointSet& points = scan.points;
  for (std::size_t i = 0; i < count; ++i) {
    const float t = 0.001f * static_cast<float>(i);
    points.positions.emplace_back(0.1f * std::cos(t) + noise(random), 0.1f * std::sin(t) + noise(random),
                                  0.00002f * static_cast<float>(i) - 0.5f);
    if (colors)
      points.colors.push_back({static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>((i / 7) % 256),
                               static_cast<std::uint8_t>(i % 3 == 0 ? i % 256 : 40)});
    if (intensities) points.intensities.push_back(0.25f + 0.5f * std::sin(0.01f * static_cast<float>(i)));
    points.stations.push_back(static_cast<std::uint16_t>(i * stations / count));
  }
  scan.origin = {500000.0, 4000000.0, 120.0};
  return scan;
}

fs::path writeTemp(const std::string& name, std::string_view bytes) {
  const fs::path path = fs::path(testing::TempDir()) / name;
  EXPECT_TRUE(writeFileAtomically(path, bytes).ok()) << path;
  return path;
}

// LASzip-written files (compressor 2, items POINT10, GPSTIME11, RGB12
// version 2, formats 0 to 3): their records compressed again give their
// point data and chunk table back, byte for byte. The strongest check that
// the encoder is LASzip's, chunk boundaries (lone-star-split-4: 3 chunks)
// and GPS time sequences included.
TEST(LazEncoder, CompressesLaszipsFilesToTheirOwnBytes) {
  for (const char* name : {"simple.laz", "laszip-generated.laz", "lone-star-split-4.laz", "point-color.las.laz",
                           "point-time-1.4.las.laz", "point10-1.0.laz"}) {
    SCOPED_TRACE(name);
    const auto original = readFileBytes(kCorpus / name);
    ASSERT_TRUE(original.ok());
    const std::string records = readers::lasPointRecords(*original);
    const auto pointsAt = get<std::uint32_t>(*original, 96);
    const int format = static_cast<std::uint8_t>((*original)[104]) & 0x3F;
    const auto recordLength = get<std::uint16_t>(*original, 105);
    std::string ours = original->substr(0, pointsAt);
    laz::PointCompressor compressor(format, ours);
    for (std::size_t at = 0; at < records.size(); at += recordLength)
      compressor.add(reinterpret_cast<const std::uint8_t*>(records.data()) + at);
    compressor.finish();
    // LAS 1.4 files may hold EVLRs after the chunk table.
    ASSERT_LE(ours.size(), original->size());
    EXPECT_EQ(firstDifference(ours, *original), ours.size()) << "of " << ours.size() << " bytes";
  }
}

// Synthetic scans of three chunks and a bit, with and without colours and
// intensities: the LAZ file decompresses to the LAS file's records exactly,
// by our decoder and by laz-perf.
TEST(LasWriter, LazDecompressesToTheLasRecordsByOursAndByLazPerf) {
  for (const bool colors : {false, true})
    for (const bool intensities : {false, true}) {
      SCOPED_TRACE(testing::Message() << "colors " << colors << ", intensities " << intensities);
      const Scan scan = spiralScan(3 * laz::kChunkPoints + 1234, colors, intensities);
      const std::string las = readers::encodeLas(scan, readers::LasEncoding::Las);
      const std::string laz = readers::encodeLas(scan, readers::LasEncoding::Laz);
      const std::string records = readers::lasPointRecords(las);
      ASSERT_EQ(records.size(), scan.points.size() * (colors ? 26 : 20));
      EXPECT_EQ(readers::lasPointRecords(laz), records);
      EXPECT_LT(laz.size(), las.size() / 2);
      const fs::path file =
          writeTemp("writer_" + std::to_string(colors) + std::to_string(intensities) + ".laz", laz);
      const nlohmann::json theirs = test::decodedByLazPerf(file);
      ASSERT_TRUE(theirs.contains("sha256")) << theirs.dump().substr(0, 300);
      EXPECT_EQ(theirs["points"].get<std::size_t>(), scan.points.size());
      EXPECT_EQ(theirs["sha256"].get<std::string>(), sha256OfBytes(records));
    }
}

// The chunks also decode one after another without the table (the encoder
// ends each chunk where the decoder stops reading), and the read notes
// count them.
TEST(LasWriter, LazChunksEndWhereTheDecoderStops) {
  const Scan scan = spiralScan(2 * laz::kChunkPoints + 1, true, true);
  std::string laz = readers::encodeLas(scan, readers::LasEncoding::Laz);
  const std::string records = readers::lasPointRecords(laz);
  const auto pointsAt = get<std::uint32_t>(laz, 96);
  const auto pointsAt64 = static_cast<std::int64_t>(pointsAt);
  std::memcpy(laz.data() + pointsAt, &pointsAt64, 8);  // "no table"
  EXPECT_EQ(readers::lasPointRecords(laz), records);
  EXPECT_THAT(readers::readLas(readers::encodeLas(scan, readers::LasEncoding::Laz)).readNotes,
              testing::Contains(testing::HasSubstr("compressor 2: chunked, 3 chunks of up to 50000 points")));
}

// What a reader finds: the points in file coordinates (origin + position)
// within half a step of the grid, colours, intensities scaled to 16 bits,
// the header's count, bounds and format.
TEST(LasWriter, HeaderAndPointsSayWhatTheScanHolds) {
  const Scan scan = spiralScan(1000, true, true);
  for (const auto encoding : {readers::LasEncoding::Las, readers::LasEncoding::Laz}) {
    const std::string bytes = readers::encodeLas(scan, encoding);
    EXPECT_EQ(bytes.substr(0, 4), "LASF");
    EXPECT_EQ(bytes[24], 1);
    EXPECT_EQ(bytes[25], 2);
    EXPECT_EQ(static_cast<std::uint8_t>(bytes[104]), encoding == readers::LasEncoding::Laz ? 0x82 : 2);
    EXPECT_EQ(get<std::uint32_t>(bytes, 107), 1000u);
    EXPECT_EQ(get<std::uint32_t>(bytes, 111), 1000u);  // all first returns
    const double scale = get<double>(bytes, 131);
    EXPECT_EQ(scale, 1e-8);  // largest |coordinate| 0.52: 0.52 * 2^-24 = 3.1e-8
    const Scan read = readers::readLas(bytes);
    ASSERT_EQ(read.points.size(), scan.points.size());
    double worst = 0.0, lowestZ = 1e300, highestZ = -1e300;
    for (std::size_t i = 0; i < scan.points.size(); ++i)
      for (int axis = 0; axis < 3; ++axis) {
        const double written = scan.origin[axis] + scan.points.positions[i][axis];
        const double back = read.origin[axis] + read.points.positions[i][axis];
        worst = std::max(worst, std::abs(written - back));
        if (axis != 2) continue;
        lowestZ = std::min(lowestZ, back);
        highestZ = std::max(highestZ, back);
      }
    // Half a grid step, and the float of the local frame the reader picks.
    EXPECT_LT(worst, 1e-5);
    EXPECT_NEAR(get<double>(bytes, 219), lowestZ, 1e-5);   // min z
    EXPECT_NEAR(get<double>(bytes, 211), highestZ, 1e-5);  // max z
    EXPECT_EQ(read.points.colors, scan.points.colors);
    ASSERT_EQ(read.points.intensities.size(), 1000u);
    float largest = 0.0f;
    for (const float v : read.points.intensities) largest = std::max(largest, v);
    EXPECT_EQ(largest, 65535.0f);
    EXPECT_EQ(read.points.returnNumbers, std::vector<std::uint8_t>(1000, 1));
  }
}

// Whole-number intensities (read from LAS or E57) stay as they are.
TEST(LasWriter, KeepsWholeNumberIntensities) {
  Scan scan = spiralScan(10, false, false);
  for (std::size_t i = 0; i < 10; ++i) scan.points.intensities.push_back(static_cast<float>(100 * i));
  const Scan read = readers::readLas(readers::encodeLas(scan, readers::LasEncoding::Laz));
  EXPECT_EQ(read.points.intensities, scan.points.intensities);
}

TEST(LasWriter, WriteLasRefusesWhatLasCannotHold) {
  const fs::path path = fs::path(testing::TempDir()) / "refused.las";
  Scan scan = spiralScan(10, false, false);
  scan.points.positions[3].x() = std::nanf("");
  const Status status = writeLas(path, scan, true);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().message, path.string() + ": LAS cannot hold point 3's non-finite coordinates");
  EXPECT_FALSE(writeLas(path, Scan{}, false).ok());
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace apo
