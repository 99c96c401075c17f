// Internal to ingest: LAZ (LASzip-compressed LAS) point data back to the raw
// point records an uncompressed LAS file would hold, so that the LAS reader
// handles both through one record path. A port of LASzip's decoding
// (LASzip/LASzip: laszip.cpp for the VLR, lasreadpoint.cpp for chunks and
// the chunk table, the item decoders in laz_items.cpp), checked byte for byte
// against LAZperf's (tests/ingest/laz_reader_test.cpp).
//
// The LAZ point data, after the LAS header and VLRs (one of which, user id
// "laszip encoded" and record 22204, describes the compression):
//
//   compressor 1 (pointwise):   [first point raw][arithmetic-coded points ...]
//   compressor 2 (chunked) and 3 (LAS 1.4 layered):
//     [int64 chunk table offset][chunk 0][chunk 1] ... [chunk table]
//     compressor 2 chunk: [first point raw][arithmetic-coded points ...]
//     compressor 3 chunk: [first point raw][uint32 points][uint32 bytes of each
//                          item's layers][the layers, in the same order]
//   chunk table: [uint32 version 0][uint32 chunks][arithmetic-coded: each
//                chunk's point count (variable-size chunks only) and bytes]
//
// A chunk table offset of -1 means the writer could not seek back: the offset
// is then in the file's last 8 bytes. With fixed-size chunks a missing or
// corrupt table is no loss (the chunks are read in sequence, as LASzip
// does); variable-size chunks (COPC) need it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace apo::laz {

// What the LAS header says about the points (all offsets in the file).
struct PointRecords {
  std::size_t vlrsAt = 0;         // the header's size: where the VLRs start
  std::uint32_t vlrCount = 0;
  std::size_t pointsAt = 0;       // the offset to point data
  int format = 0;                 // 0 to 10, compression bits masked off
  std::uint16_t recordLength = 0; // bytes per point record
  std::uint64_t pointCount = 0;
  std::size_t pointCountAt = 0;   // where the header holds the count (107 or 247)
};

struct Decompressed {
  std::string records;  // pointCount * recordLength bytes, as in a LAS file
  std::string summary;  // how it was compressed, for the scan's read notes
};

// The file's points decompressed. Throws parse::ParseFailure naming the byte
// and the problem: no or a bad LASzip VLR (an unknown compressor, item type
// or version), a count the file cannot hold, a truncated or corrupt chunk.
Decompressed decompressPoints(std::string_view file, const PointRecords& las);

// The same a run of whole chunks at a time, for files whose points are too
// many to hold: `take` gets the records of each run of chunks holding at
// least `runPoints` points (the last run may hold fewer), in order, and may
// move them away, and the byte where the run's chunks end (the bytes before
// it, but for the chunk table read first, are not read again). Returns the
// summary. Throws as decompressPoints does, after the runs before the bad
// chunk were taken.
std::string decompressPointsInRuns(std::string_view file, const PointRecords& las, std::uint64_t runPoints,
                                   const std::function<void(std::string& records, std::size_t end)>& take);

}  // namespace apo::laz
