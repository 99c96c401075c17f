#include "ingest/large_scan.h"

#include "core/file_io.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace apo::large_scan {
namespace {

namespace fs = std::filesystem;


using VoxelKey = std::array<std::int64_t, 3>;

struct VoxelKeyHash {
  std::size_t operator()(const VoxelKey& key) const {
    std::uint64_t h = 0x9E3779B97F4A7C15ULL;
    for (const std::int64_t k : key) h = (h ^ static_cast<std::uint64_t>(k)) * 0xBF58476D1CE4E5B9ULL;
    return static_cast<std::size_t>(h ^ (h >> 31));
  }
};

// The sums a voxel's centroid and averages come from: they add exactly when
// voxels merge.
struct VoxelSums {
  std::array<double, 3> position{};
  std::array<double, 3> normal{};
  std::array<std::uint64_t, 3> color{};
  double intensity = 0.0;
  std::uint64_t count = 0;

  void add(const VoxelSums& other) {
    for (int axis = 0; axis < 3; ++axis) {
      position[axis] += other.position[axis];
      normal[axis] += other.normal[axis];
      color[axis] += other.color[axis];
    }
    intensity += other.intensity;
    count += other.count;
  }
};

using Voxels = std::unordered_map<VoxelKey, VoxelSums, VoxelKeyHash>;

// Which attributes the file's points carry (every run has the same).
struct Attributes {
  bool normals = false, colors = false, intensities = false;
};

// The run's points in the file's coordinates (double), one by one.
template <class Visit>
void forEachPoint(const Scan& run, const Visit& visit) {
  const PointSet& points = run.points;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points.positions[i];
    visit(std::array<double, 3>{run.origin[0] + p.x(), run.origin[1] + p.y(), run.origin[2] + p.z()}, i);
  }
}

bool finite(const std::array<double, 3>& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

class VoxelGrid {
 public:
  VoxelGrid(int level, std::uint64_t maxVoxels, Attributes attributes)
      : level_(level), maxVoxels_(maxVoxels), attributes_(attributes) {
    voxels_.reserve(static_cast<std::size_t>(maxVoxels + 1));
  }

  void add(const Scan& run) {
    const PointSet& points = run.points;
    forEachPoint(run, [&](const std::array<double, 3>& p, std::size_t i) {
      if (!finite(p)) {
        ++nonFinite_;
        return;
      }
      VoxelSums sums;
      sums.position = p;
      sums.count = 1;
      if (attributes_.normals)
        for (int axis = 0; axis < 3; ++axis) sums.normal[axis] = points.normals[i][axis];
      if (attributes_.colors) sums.color = {points.colors[i].r, points.colors[i].g, points.colors[i].b};
      if (attributes_.intensities) sums.intensity = points.intensities[i];
      voxels_[keyOf(p)].add(sums);
      while (voxels_.size() > maxVoxels_) coarsen();
    });
  }

  double voxelSize() const { return std::ldexp(1.0, level_); }
  std::uint64_t nonFinite() const { return nonFinite_; }
  std::uint64_t coarsenings() const { return coarsenings_; }

  // The centroids, in key order, as a scan in its local frame.
  Scan centroids() const {
    std::vector<const Voxels::value_type*> order;
    order.reserve(voxels_.size());
    for (const auto& voxel : voxels_) order.push_back(&voxel);
    std::sort(order.begin(), order.end(), [](const auto* a, const auto* b) { return a->first < b->first; });
    Scan scan;
    PointSet& points = scan.points;
    readers::PositionCollector positions;
    positions.reserve(order.size());
    for (const auto* voxel : order) {
      const VoxelSums& s = voxel->second;
      const double n = static_cast<double>(s.count);
      positions.push(s.position[0] / n, s.position[1] / n, s.position[2] / n);
      if (attributes_.normals)
        points.normals.emplace_back(static_cast<float>(s.normal[0]), static_cast<float>(s.normal[1]),
                                    static_cast<float>(s.normal[2]));
      if (attributes_.colors) {
        auto mean = [&](int c) { return static_cast<std::uint8_t>(std::lround(static_cast<double>(s.color[c]) / n)); };
        points.colors.push_back({mean(0), mean(1), mean(2)});
      }
      if (attributes_.intensities) points.intensities.push_back(static_cast<float>(s.intensity / n));
    }
    positions.finishInto(scan);
    return scan;
  }

 private:
  VoxelKey keyOf(const std::array<double, 3>& p) const {
    const double size = voxelSize();
    return {static_cast<std::int64_t>(std::floor(p[0] / size)), static_cast<std::int64_t>(std::floor(p[1] / size)),
            static_cast<std::int64_t>(std::floor(p[2] / size))};
  }

  // Voxels twice as large: floor(k / 2) is the key of floor(x / 2s) for a
  // power-of-two s, so the merged sums are those of the points themselves.
  void coarsen() {
    Voxels coarser;
    coarser.reserve(static_cast<std::size_t>(maxVoxels_ + 1));
    for (const auto& [key, sums] : voxels_) coarser[{key[0] >> 1, key[1] >> 1, key[2] >> 1}].add(sums);
    voxels_ = std::move(coarser);
    ++level_;
    ++coarsenings_;
  }

  int level_;
  std::uint64_t maxVoxels_;
  Attributes attributes_;
  Voxels voxels_;
  std::uint64_t nonFinite_ = 0, coarsenings_ = 0;
};

// Records [first, first + count) of the file as a scan; BadInput when the
// file ends early or the reader refuses them.
Result<Scan> readRecords(const fs::path& path, const std::string& head, const readers::RecordLayout& layout,
                         ScanFormat format, std::uint64_t first, std::uint64_t count) {
  const std::uint64_t at = layout.recordsAt + first * layout.recordBytes;
  auto bytes = readFileRange(path, at, static_cast<std::size_t>(count * layout.recordBytes));
  if (!bytes) return bytes.error();
  if (bytes->size() != count * layout.recordBytes)
    return badInput("{}: byte {}: the file ends inside point record {} of the {} its header declares", path.string(),
                    at + bytes->size(), first + bytes->size() / layout.recordBytes + 1, layout.count);
  try {
    return format == ScanFormat::Ply ? readers::readPlyRecords(head, *bytes, layout)
                                     : readers::readLasRecords(head, *bytes, layout);
  } catch (const parse::ParseFailure& failure) {
    return badInput("{}: records {} to {}: {}", path.string(), first + 1, first + count, failure.what());
  }
}

// Runs of records read from disk, each as a file of its own.
PointRuns recordRuns(const fs::path& path, std::string head, const readers::RecordLayout& layout, ScanFormat format) {
  auto read = [path, head = std::move(head), layout, format](
                  std::uint64_t runPoints, const std::function<void(Scan&)>& take) -> Result<std::vector<std::string>> {
    std::vector<std::string> notes;
    for (std::uint64_t first = 0; first < layout.count; first += runPoints) {
      auto run = readRecords(path, head, layout, format, first, std::min(runPoints, layout.count - first));
      if (!run) return run.error();
      if (first == 0) notes = run->readNotes;
      take(*run);
    }
    return notes;
  };
  return {path, layout.count, std::move(read)};
}

// A LAZ file held whole (compressed), its chunks decompressed a run at a time.
PointRuns lazRuns(const fs::path& path, std::uint64_t count) {
  auto read = [path](std::uint64_t runPoints,
                     const std::function<void(Scan&)>& take) -> Result<std::vector<std::string>> {
    auto bytes = readFileBytes(path);
    if (!bytes) return bytes.error();
    std::vector<std::string> notes;
    try {
      const std::string summary = readers::readLazRuns(*bytes, runPoints, [&](Scan& run) {
        if (notes.empty()) notes = run.readNotes;
        take(run);
      });
      notes.insert(notes.begin(), summary);
    } catch (const parse::ParseFailure& failure) {
      return badInput("{}: {}", path.string(), failure.what());
    }
    return notes;
  };
  return {path, count, std::move(read)};
}

// The starting voxel level: a power of two at or below D / (4 sqrt(maxPoints)),
// D the diagonal of the file's first kStartPoints points. A surface of area
// up to 16 D^2 (any scan whose first points span a fair part of it) occupies
// more than maxPoints voxels at that level, so the voxels only coarsen, and
// few times.
int startLevel(const Scan& firstRun, std::uint64_t maxPoints) {
  std::array<double, 3> lo{}, hi{};
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  forEachPoint(firstRun, [&](const std::array<double, 3>& p, std::size_t i) {
    if (i >= kStartPoints || !finite(p)) return;
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
    }
  });
  const double diagonal = std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  // No extent (one point, or none finite): any level; coarsening finds the rest.
  if (!(diagonal > 0.0) || !std::isfinite(diagonal)) return -20;
  return static_cast<int>(std::floor(std::log2(diagonal / (4.0 * std::sqrt(static_cast<double>(maxPoints))))));
}

}  // namespace

Result<std::optional<PointRuns>> openPointRuns(const fs::path& path, ScanFormat format) {
  if (format != ScanFormat::Ply && format != ScanFormat::Las) return std::optional<PointRuns>();
  auto head = readFileRange(path, 0, kHeadBytes);
  if (!head) return head.error();
  if (format == ScanFormat::Las)
    if (const auto count = readers::lazPointCount(*head)) return std::optional<PointRuns>(lazRuns(path, *count));
  const auto layout = format == ScanFormat::Ply ? readers::plyRecordLayout(*head) : readers::lasRecordLayout(*head);
  if (!layout || layout->recordBytes == 0) return std::optional<PointRuns>();
  head->resize(static_cast<std::size_t>(layout->recordsAt));
  return std::optional<PointRuns>(recordRuns(path, std::move(*head), *layout, format));
}

Result<VoxelSubsample> voxelSubsample(const PointRuns& file, std::uint64_t maxPoints, std::uint64_t runPoints,
                                      const Progress& progress) {
  VoxelSubsample result;
  std::optional<VoxelGrid> grid;
  auto notes = file.read(std::max(runPoints, kStartPoints), [&](Scan& run) {
    if (!grid) {
      const PointSet& points = run.points;
      grid.emplace(startLevel(run, maxPoints), maxPoints,
                   Attributes{!points.normals.empty(), !points.colors.empty(), !points.intensities.empty()});
    }
    grid->add(run);
    result.pointsRead += run.points.size();
    ++result.runs;
    if (progress) progress(result.pointsRead, file.count);
  });
  if (!notes) return notes.error();
  if (!grid) return badInput("{}: no points", file.path.string());
  result.scan = grid->centroids();
  result.scan.readNotes = std::move(*notes);
  result.voxelSize = grid->voxelSize();
  result.nonFinite = grid->nonFinite();
  result.coarsenings = grid->coarsenings();
  return result;
}

}  // namespace apo::large_scan
