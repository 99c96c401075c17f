// Internal to ingest: scans with more points than ingest keeps (--max-points)
// are read a run of records at a time (readers.h, RecordLayout) and reduced,
// in memory bounded by the points kept, to one point per occupied voxel: the
// centroid of the voxel's points, their normals, colours and intensities
// averaged. The voxel is the smallest power of two (in the file's units) at
// which at most --max-points voxels are occupied, found while reading: the
// voxels coarsen by halves whenever one more would exceed the limit, which
// merges centroids exactly (docs/ingest.md, "Large scans").
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "ingest/ingest.h"
#include "ingest/readers.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace apo::large_scan {

// Bytes read from a file's start to find its record layout: a PLY header or
// a LAS header and its variable-length records longer than this are read
// whole, as smaller files are.
inline constexpr std::size_t kHeadBytes = std::size_t{1} << 20;
// Points read per run of records.
inline constexpr std::uint64_t kChunkPoints = std::uint64_t{1} << 20;

// A file read a run at a time: its layout, its header, and the reader of a
// run of its records.
struct RecordFile {
  std::filesystem::path path;
  readers::RecordLayout layout;
  std::string head;  // bytes [0, layout.recordsAt)
  std::function<Scan(std::string_view head, std::string_view records, const readers::RecordLayout&)> readRecords;
};

// The file as a RecordFile when its format and body allow (binary PLY of
// vertices alone, uncompressed LAS), else nullopt.
Result<std::optional<RecordFile>> openRecordFile(const std::filesystem::path& path, ScanFormat format);

// Progress of the read: points read so far of the file's count.
using Progress = std::function<void(std::uint64_t read, std::uint64_t total)>;

struct VoxelSubsample {
  Scan scan;                        // the voxels' centroids, in voxel order; the file's first run's read notes
  double voxelSize = 0.0;           // in the file's units, a power of two
  std::uint64_t pointsRead = 0;     // records read
  std::uint64_t nonFinite = 0;      // of them, dropped for a non-finite coordinate
  std::uint64_t runs = 0;           // runs of records read
  std::uint64_t coarsenings = 0;    // times the voxels were halved while reading
};

// Reads every record of the file and keeps at most `maxPoints` voxel
// centroids. Deterministic: the same file gives the same points whatever the
// run length. BadInput when a run of records is malformed (the message names
// the file and the byte).
Result<VoxelSubsample> voxelSubsample(const RecordFile& file, std::uint64_t maxPoints, std::uint64_t chunkPoints,
                                      const Progress& progress);

}  // namespace apo::large_scan
