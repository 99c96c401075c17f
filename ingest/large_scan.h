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
#include <vector>

namespace apo::large_scan {

// Bytes read from a file's start to find its record layout: a PLY header or
// a LAS header and its variable-length records longer than this are read
// whole, as smaller files are.
inline constexpr std::size_t kHeadBytes = std::size_t{1} << 20;
// Points read per run.
inline constexpr std::uint64_t kRunPoints = std::uint64_t{1} << 20;

// A point file read a run of points at a time.
struct PointRuns {
  std::filesystem::path path;
  std::uint64_t count = 0;  // points its header declares
  // Reads the file's points in order, in runs of at least `runPoints` (the
  // last may hold fewer), handing each to `take`; returns the read notes
  // (how the file was stored) or a BadInput error naming the file.
  std::function<Result<std::vector<std::string>>(std::uint64_t runPoints, const std::function<void(Scan& run)>& take)>
      read;
};

// The file as PointRuns when its format allows: binary PLY of vertices alone,
// uncompressed LAS and binary PCD of one row (runs of records read from disk,
// each as a file of its own: readers.h, RecordLayout), LAZ (the compressed
// file mapped, its chunks decompressed a run at a time), ASCII PLY of
// vertices alone, ASCII PCD of one row, and XYZ/CSV/PTS text that may hold
// more than `maxPoints` points (its data lines counted in a first pass): runs
// of whole lines, each read behind the file's head (readers.h, TextLayout);
// E57 (mapped, read twice through: readers::readE57Runs; `count` is the
// records its XML declares, valid or not); binary_compressed PCD of one row
// (its body decoded through a scratch file in TMPDIR, runs gathered from its
// fields); else nullopt.
Result<std::optional<PointRuns>> openPointRuns(const std::filesystem::path& path, ScanFormat format,
                                               std::uint64_t maxPoints);

// Progress of the read: points read so far of the file's count.
using Progress = std::function<void(std::uint64_t read, std::uint64_t total)>;

struct VoxelSubsample {
  Scan scan;                        // the voxels' centroids, in voxel order; the file's first run's read notes,
                                    // viewpoint (PCD) and scan positions (E57), each centroid with
                                    // the scan position of one of its points (VoxelSums::station)
  double voxelSize = 0.0;           // in the file's units, a power of two
  std::uint64_t pointsRead = 0;     // records read
  std::uint64_t nonFinite = 0;      // of them, dropped for a non-finite coordinate (or one
                                    // beyond 2^62 voxels, as only a corrupt file has)
  std::uint64_t runs = 0;           // runs of records read
  std::uint64_t coarsenings = 0;    // times the voxels were halved while reading
};

// Reads every point of the file and keeps at most `maxPoints` voxel
// centroids. Runs hold at least kStartPoints points (runPoints is raised to
// it), so that the starting voxel, and so the result, is the same whatever
// the run length. BadInput when a run is malformed (the message names the
// file and the byte).
inline constexpr std::uint64_t kStartPoints = 65536;
Result<VoxelSubsample> voxelSubsample(const PointRuns& file, std::uint64_t maxPoints, std::uint64_t runPoints,
                                      const Progress& progress);

}  // namespace apo::large_scan
