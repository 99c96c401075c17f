// Internal to ingest: raw LAS point records of formats 0 to 3 to LAZ point
// data, the inverse of laz_decoder.h for what LASzip 2 and later write by
// default: compressor 2 (chunked, 50,000 points a chunk), items POINT10 v2,
// GPSTIME11 v2 (formats 1 and 3) and RGB12 v2 (formats 2 and 3). A port of
// LASzip's encoding (laswritepoint.cpp, laswriteitemcompressed_v2.cpp,
// arithmeticencoder.cpp, integercompressor.cpp), the exact mirror of our
// decoder: it writes byte for byte what LASzip writes for the same records.
//
// The point data it appends (laz_decoder.h has the whole layout):
//   [int64 file offset of the chunk table][chunk 0] ... [chunk n-1]
//   chunk: [first point raw][arithmetic-coded points ...]
//   chunk table: [uint32 version 0][uint32 chunks][arithmetic-coded bytes of
//                each chunk, each predicted from the previous one's]
#pragma once

#include "ingest/laz_arithmetic_encoder.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace apo::laz {

inline constexpr std::uint32_t kChunkPoints = 50000;

// The LASzip VLR for compressor 2 coding point format `format` (0 to 3): its
// 54-byte VLR header (user id "laszip encoded", record 22204) and its record
// (34 bytes and 6 per item), as it goes between the LAS header and the points.
std::string laszipVlr(int format);

class PointwiseItemEncoder;

// LASzip compressor 2, fed one point record at a time, appending to the file
// as it goes (no uncompressed copy of the points is kept).
class PointCompressor {
 public:
  // `file` holds the file up to its point data (header and VLRs): the chunk
  // table's offset written first is an offset in it. `format`: 0 to 3.
  PointCompressor(int format, std::string& file);
  ~PointCompressor();
  PointCompressor(const PointCompressor&) = delete;
  PointCompressor& operator=(const PointCompressor&) = delete;

  // One record of the format's size (20, 28, 26 or 34 bytes).
  void add(const std::uint8_t* record);
  // The last chunk and the chunk table; nothing may be added after.
  void finish();

 private:
  void startChunk(const std::uint8_t* record);
  void endChunk();
  void writeChunkTable();

  std::string& file_;
  std::size_t chunkTableOffsetAt_ = 0, chunkBegin_ = 0;
  std::size_t recordLength_ = 0;
  std::uint32_t pointsInChunk_ = 0;
  std::vector<std::uint32_t> chunkBytes_;
  std::vector<std::unique_ptr<PointwiseItemEncoder>> items_;
  std::vector<std::size_t> itemOffsets_;
  ArithmeticEncoder encoder_;  // of the current chunk, then of the table
};

}  // namespace apo::laz
