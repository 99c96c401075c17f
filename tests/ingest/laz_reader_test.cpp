// The LAZ decoder (ingest/laz_decoder.cpp, through the LAS reader) against
// real files from other writers (fuzz/corpus/laz/, from ../shared/data/laz/:
// PDAL's, LAZperf's, laspy's and LASzip's test data; its README lists each
// file's facts): every readable file decompresses to the same bytes as the
// LAZperf decoder (npm laz-perf, WASM, pinned in package-lock.json), reads to
// its header's point count, and the broken ones, truncations and corruptions
// are refused naming the byte.
#include "core/file_io.h"
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include "tests/ingest/lazperf.h"
#include "tests/ingest/reader_failure.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace apo {
namespace {
namespace fs = std::filesystem;

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using ::testing::StartsWith;

const fs::path kCorpus = fs::path(APO_SOURCE_DIR) / "fuzz" / "corpus" / "laz";
// The 2.7 MB COPC file stays out of git: read where the lab keeps it.
const fs::path kSharedLaz = fs::path(APO_SHARED_DATA) / "laz";

std::string fileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::string corpusFile(const std::string& name) { return fileBytes(kCorpus / name); }

std::string lasFailure(std::string_view bytes) { return test::readerFailure(readers::readLas, bytes); }

template <class T>
void put(std::string& bytes, std::size_t at, T value) {
  std::memcpy(bytes.data() + at, &value, sizeof(T));  // little-endian machine
}

// Our records of `file` byte for byte against laz-perf's (by their hash; on a
// mismatch, the count and length say which side differs).
void expectSameRecordsAsLazPerf(const fs::path& file) {
  SCOPED_TRACE(file.filename().string());
  const nlohmann::json theirs = test::decodedByLazPerf(file);
  ASSERT_TRUE(theirs.contains("sha256")) << theirs.dump().substr(0, 300);
  const std::string ours = readers::lasPointRecords(fileBytes(file));
  const auto points = theirs["points"].get<std::size_t>();
  const auto recordLength = theirs["recordLength"].get<std::size_t>();
  ASSERT_EQ(ours.size(), points * recordLength) << points << " points of " << recordLength << " bytes";
  EXPECT_EQ(sha256OfBytes(ours), theirs["sha256"].get<std::string>());
}

// Every readable LAZ file of the corpus but one: compressors 2 (LAS 1.0 to
// 1.4 headers, point formats 0 to 3, extra bytes, several chunks) and 3
// (formats 6 to 8, COPC's variable chunks, RGB, NIR, extra bytes, EVLRs).
// laz-perf has no decoder for compressor 1 (LASzip 1.x's pointwise coding,
// item versions 1), so simple-laszip-compressor-version-1.2r0.laz is checked
// against simple.las, the uncompressed file its points came from, below.
// no-points-1.3.laz has nothing to compare (laz-perf reads 0 points, we
// refuse it as the LAS reader refuses an empty LAS file).
TEST(LazReader, DecompressesTheRealFilesAsLazPerfDoes) {
  for (const char* name : {"simple.laz", "laszip-generated.laz", "point10-1.0.laz", "point-color.las.laz",
                           "point-time-1.4.las.laz", "lone-star-split-4.laz", "extra.laz", "1.2-with-color.copc.laz",
                           "1_4_w_evlr.laz", "append-bug.laz"})
    expectSameRecordsAsLazPerf(kCorpus / name);
}

TEST(LazReader, DecompressesTheLargeCopcFileAsLazPerfDoes) {
  const fs::path file = kSharedLaz / "lone-star.copc.laz";
  if (!fs::exists(file)) GTEST_SKIP() << file << " is not here (it stays out of git: 2.7 MB)";
  expectSameRecordsAsLazPerf(file);
}

// The uncompressed twins: PDAL's simple.las and two LASzip compressions of it.
TEST(LazReader, ReadsTheSamePointsAsTheUncompressedTwin) {
  const std::string las = fileBytes(fs::path(APO_SOURCE_DIR) / "fuzz" / "corpus" / "las" / "simple.las");
  const Scan expected = readers::readLas(las);
  for (const char* name : {"simple.laz", "simple-laszip-compressor-version-1.2r0.laz"}) {
    SCOPED_TRACE(name);
    const std::string laz = corpusFile(name);
    EXPECT_EQ(readers::lasPointRecords(laz), readers::lasPointRecords(las));
    const Scan scan = readers::readLas(laz);
    ASSERT_EQ(scan.points.size(), expected.points.size());
    EXPECT_EQ(scan.origin, expected.origin);
    EXPECT_EQ(scan.points.positions, expected.points.positions);
    EXPECT_EQ(scan.points.intensities, expected.points.intensities);
    EXPECT_EQ(scan.points.classifications, expected.points.classifications);
    EXPECT_EQ(scan.points.returnNumbers, expected.points.returnNumbers);
    EXPECT_EQ(scan.points.returnCounts, expected.points.returnCounts);
    ASSERT_EQ(scan.points.colors.size(), expected.points.colors.size());
    for (std::size_t i = 0; i < scan.points.colors.size(); ++i)
      ASSERT_EQ(scan.points.colors[i].r + 256 * scan.points.colors[i].g + 65536 * scan.points.colors[i].b,
                expected.points.colors[i].r + 256 * expected.points.colors[i].g + 65536 * expected.points.colors[i].b)
          << "point " << i;
  }
}

// Each of the 15 files: read with its header's point count, and said so in
// the notes, or refused naming the byte and the reason.
TEST(LazReader, ReadsEachRealFileToItsHeadersCountOrSaysWhy) {
  struct Readable {
    const char* name;
    std::size_t points;
    const char* compression;  // in the read note
  };
  for (const Readable& file :
       {Readable{"simple.laz", 1065, "compressor 2: chunked, 1 chunk of up to 50000 points"},
        Readable{"simple-laszip-compressor-version-1.2r0.laz", 1065, "compressor 1: pointwise, one stream"},
        Readable{"laszip-generated.laz", 1065, "items POINT10 v2, GPSTIME11 v2, RGB12 v2"},
        Readable{"point10-1.0.laz", 1, "items POINT10 v2)"}, Readable{"point-color.las.laz", 1065, "RGB12 v2"},
        Readable{"point-time-1.4.las.laz", 1065, "GPSTIME11 v2"},
        Readable{"lone-star-split-4.laz", 108715, "3 chunks of up to 50000 points"},
        Readable{"extra.laz", 1065, "BYTE v2"},
        Readable{"1.2-with-color.copc.laz", 1065, "compressor 3: LAS 1.4 layered chunks, 65 chunks of varying size"},
        Readable{"1_4_w_evlr.laz", 1000, "items POINT14 v3)"},
        Readable{"append-bug.laz", 37805, "items POINT14 v3, RGBNIR14 v3, BYTE14 v3"}}) {
    SCOPED_TRACE(file.name);
    Scan scan;
    ASSERT_NO_THROW(scan = readers::readLas(corpusFile(file.name)));
    EXPECT_EQ(scan.points.size(), file.points);
    EXPECT_THAT(scan.readNotes, testing::Contains(AllOf(StartsWith("points decompressed from LAZ (LASzip "),
                                                        HasSubstr(file.compression))));
  }
  EXPECT_EQ(lasFailure(corpusFile("broken_compressor.laz")),
            "byte 281: LASzip VLR: compressor 16 is unknown (1 pointwise, 2 chunked, 3 LAS 1.4 layered chunks)");
  EXPECT_EQ(lasFailure(corpusFile("broken_type.laz")),
            "byte 321: LASzip VLR item 1: type 22 is unknown (LASzip defines 0 and 6 to 14)");
  // As an uncompressed LAS file with no points is.
  EXPECT_THAT(lasFailure(corpusFile("no-points-1.3.laz")), StartsWith("byte 107: no points"));
}

TEST(LazReader, ReadsTheLargeCopcFileToItsHeadersCount) {
  const fs::path file = kSharedLaz / "lone-star.copc.laz";
  if (!fs::exists(file)) GTEST_SKIP() << file << " is not here (it stays out of git: 2.7 MB)";
  const Scan scan = readers::readLas(fileBytes(file));
  EXPECT_EQ(scan.points.size(), 518862u);
  EXPECT_THAT(scan.readNotes, testing::Contains(HasSubstr("15 chunks of varying size")));
}

// LASzip's chunk table offset of -1 (a writer that could not seek back wrote
// the offset at the file's end instead), and a missing table (the offset
// points at itself: the writer was interrupted), which fixed-size chunks can
// do without but COPC's variable ones cannot.
TEST(LazReader, FindsTheChunkTableAtTheEndOrReadsTheChunksWithoutIt) {
  const std::string good = corpusFile("lone-star-split-4.laz");  // 3 chunks, points at 586
  const std::string expected = readers::lasPointRecords(good);
  std::int64_t tableAt = 0;
  std::memcpy(&tableAt, good.data() + 586, 8);
  std::string atTheEnd = good + std::string(8, '\0');
  put<std::int64_t>(atTheEnd, 586, -1);
  put<std::int64_t>(atTheEnd, good.size(), tableAt);
  EXPECT_EQ(readers::lasPointRecords(atTheEnd), expected);
  std::string withoutTable = good;
  put<std::int64_t>(withoutTable, 586, 586);
  EXPECT_EQ(readers::lasPointRecords(withoutTable), expected);
  EXPECT_THAT(readers::readLas(withoutTable).readNotes,
              testing::Contains(HasSubstr("the LAZ chunk table is missing (its writer was interrupted); the chunks "
                                          "were read one after another")));
  std::string copc = corpusFile("1.2-with-color.copc.laz");  // points at 1709
  put<std::int64_t>(copc, 1709, 1709);
  EXPECT_EQ(lasFailure(copc), "byte 1709: the LAZ chunks vary in size, which only the chunk table says, and the LAZ "
                              "chunk table is missing (its writer was interrupted)");
}

// Every cut of a real file (past its header and VLRs) is refused, never read
// past its end: the chunk table is gone, the chunks are read in sequence and
// the one the cut falls in runs dry.
TEST(LazReader, RefusesTruncatedFilesNamingTheChunk) {
  for (const char* name : {"simple.laz", "lone-star-split-4.laz", "append-bug.laz", "1.2-with-color.copc.laz",
                           "simple-laszip-compressor-version-1.2r0.laz"}) {
    SCOPED_TRACE(name);
    const std::string whole = corpusFile(name);
    std::uint32_t pointsAt = 0;
    std::memcpy(&pointsAt, whole.data() + 96, 4);
    // Compressor 1 has no chunk table: its points run to the end.
    std::int64_t tableAt = static_cast<std::int64_t>(whole.size());
    if (std::string_view(name).find("compressor-version-1") == std::string_view::npos)
      std::memcpy(&tableAt, whole.data() + pointsAt, 8);
    for (int cut = 0; cut < 40; ++cut) {
      const std::size_t size = pointsAt + static_cast<std::size_t>((tableAt - pointsAt) * cut / 40);
      EXPECT_THAT(lasFailure(std::string_view(whole).substr(0, size)), MatchesRegex("byte [0-9]+: .*")) << size;
    }
  }
  // A cut inside a chunk of a file read in sequence names that chunk.
  const std::string whole = corpusFile("lone-star-split-4.laz");
  EXPECT_THAT(lasFailure(std::string_view(whole).substr(0, whole.size() / 2)),
              AllOf(StartsWith("byte "), HasSubstr("LAZ chunk 1 is truncated or corrupt: its compressed data ends "
                                                   "before its last point")));
}

// Counts the file cannot hold are refused before anything is allocated for them.
TEST(LazReader, RefusesHugeClaimedCountsUnread) {
  std::string bytes = corpusFile("point-time-1.4.las.laz");  // LAS 1.4: the 64-bit count at 247
  put<std::uint64_t>(bytes, 247, 100000000000ULL);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 247: the header claims 100000000000 points, more than LASzip could "
                                            "code in the 14294 bytes of point data"));
  bytes = corpusFile("simple.laz");
  put<std::uint32_t>(bytes, 107, 4000000000u);
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 107: the header claims 4000000000 points"));
  put<std::uint32_t>(bytes, 107, 50001);  // one more than its only chunk holds
  EXPECT_EQ(lasFailure(bytes), "byte 107: the header claims 50001 points, the LAZ chunk table's 1 chunks hold 50000");
  bytes = corpusFile("1.2-with-color.copc.laz");  // variable chunks: the table counts the points
  put<std::uint64_t>(bytes, 247, 1066);
  EXPECT_EQ(lasFailure(bytes), "byte 247: the header claims 1066 points, the LAZ chunk table's 65 chunks hold 1065");
}

// The LASzip VLR's fields, each broken in a real file: refused naming its byte.
TEST(LazReader, RefusesLaszipVlrsItCannotDecodeNamingTheByte) {
  const std::string good = corpusFile("simple.laz");  // its VLR's record at 281, items at 315
  std::string bytes = good;
  put<std::uint16_t>(bytes, 283, 1);
  EXPECT_EQ(lasFailure(bytes), "byte 283: LASzip VLR: coder 1 is unknown (0: arithmetic)");
  bytes = good;
  put<std::uint16_t>(bytes, 315 + 4, 3);
  EXPECT_EQ(lasFailure(bytes), "byte 319: LASzip VLR item 0: POINT10 version 3 is not supported (versions 1 and 2)");
  bytes = good;
  put<std::uint16_t>(bytes, 315 + 6, 10);
  EXPECT_EQ(lasFailure(bytes), "byte 321: LASzip VLR item 1: POINT14 cannot be coded by compressor 2 (chunked)");
  bytes = good;
  put<std::uint16_t>(bytes, 315 + 12, 9);
  EXPECT_EQ(lasFailure(bytes), "byte 327: LASzip VLR item 2: WAVEPACKET13 (waveform packets) is not supported");
  bytes = good;
  put<std::uint16_t>(bytes, 315 + 2, 21);
  EXPECT_EQ(lasFailure(bytes), "byte 317: LASzip VLR item 0: POINT10 takes 20 bytes, not 21");
  bytes = good;
  put<std::uint16_t>(bytes, 105, 35);  // the record length
  EXPECT_EQ(lasFailure(bytes),
            "byte 313: LASzip VLR: the items add up to 34 bytes a point, the header's point record length is 35");
  bytes = good;
  bytes[227 + 2] = 'X';  // the user id
  EXPECT_THAT(lasFailure(bytes), StartsWith("byte 104: the point format byte marks LASzip-compressed points (LAZ), "
                                            "but no LASzip VLR"));
}

// Random corruptions of the compressed bytes (fixed seed): each file either
// reads to its header's count or is refused with a message; never a crash, a
// hang or a read out of bounds (the sanitizer build checks the last).
TEST(LazReader, CorruptedChunksAreReadOrRefusedNeverCrash) {
  std::mt19937 random(20240611);
  for (const char* name : {"simple.laz", "simple-laszip-compressor-version-1.2r0.laz", "extra.laz",
                           "1.2-with-color.copc.laz", "1_4_w_evlr.laz"}) {
    SCOPED_TRACE(name);
    const std::string good = corpusFile(name);
    std::uint32_t pointsAt = 0;
    std::memcpy(&pointsAt, good.data() + 96, 4);
    std::uniform_int_distribution<std::size_t> anywhere(pointsAt, good.size() - 1);
    for (int trial = 0; trial < 60; ++trial) {
      std::string bytes = good;
      for (int flips = 1 + trial % 4; flips > 0; --flips)
        bytes[anywhere(random)] ^= static_cast<char>(1 + random() % 255);
      try {
        const Scan scan = readers::readLas(bytes);
        EXPECT_EQ(scan.points.size(), readers::readLas(good).points.size()) << "trial " << trial;
      } catch (const parse::ParseFailure& failure) {
        EXPECT_THAT(failure.what(), MatchesRegex("byte [0-9]+: .*")) << "trial " << trial;
      }
    }
  }
}

}  // namespace
}  // namespace apo
