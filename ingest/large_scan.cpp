#include "ingest/large_scan.h"

#include "core/file_io.h"
#include "ingest/lzf_blocks.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace apo::large_scan {
namespace {

namespace fs = std::filesystem;


using VoxelKey = std::array<std::int64_t, 3>;

std::uint64_t hashOf(const VoxelKey& key) {
  std::uint64_t h = 0x9E3779B97F4A7C15ULL;
  for (const std::int64_t k : key) h = (h ^ static_cast<std::uint64_t>(k)) * 0xBF58476D1CE4E5B9ULL;
  return h ^ (h >> 31);
}

// The sums a voxel's centroid and averages come from: they add exactly when
// voxels merge.
struct VoxelSums {
  std::array<double, 3> position{};
  std::array<float, 3> normal{};  // directions: float sums are ample
  std::array<std::uint64_t, 3> color{};
  double intensity = 0.0;
  std::uint64_t count = 0;
  // The scan position (multi-scan files) of the voxel's first point; where
  // voxels merge, that of the one with more points (the earlier on a tie):
  // a centroid's line of sight to one scanner that saw its surface.
  std::uint16_t station = 0;

  void add(const VoxelSums& other) {
    if (other.count > count) station = other.station;
    for (int axis = 0; axis < 3; ++axis) {
      position[axis] += other.position[axis];
      normal[axis] += other.normal[axis];
      color[axis] += other.color[axis];
    }
    intensity += other.intensity;
    count += other.count;
  }
};

// The voxels as two flat arrays (keys, sums) in order of first occupation,
// found by an open-addressing index of their positions: about 110 bytes a
// voxel, a third of a node-based map's, and coarsened in place.
class Voxels {
 public:
  explicit Voxels(std::uint64_t capacity) : slots_(std::bit_ceil(2 * capacity + 2), kEmpty) {
    keys_.reserve(static_cast<std::size_t>(capacity + 1));
    sums_.reserve(static_cast<std::size_t>(capacity + 1));
  }

  std::size_t size() const { return keys_.size(); }
  const VoxelKey& key(std::size_t i) const { return keys_[i]; }
  const VoxelSums& sums(std::size_t i) const { return sums_[i]; }

  void add(const VoxelKey& key, const VoxelSums& sums) {
    std::uint32_t& slot = slotOf(key);
    if (slot != kEmpty) {
      sums_[slot].add(sums);
      return;
    }
    slot = static_cast<std::uint32_t>(keys_.size());
    keys_.push_back(key);
    sums_.push_back(sums);
  }

  // Every key halved (floor), voxels meeting on a key merged into the first.
  void halveKeys() {
    std::fill(slots_.begin(), slots_.end(), kEmpty);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < keys_.size(); ++i) {
      const VoxelKey key{keys_[i][0] >> 1, keys_[i][1] >> 1, keys_[i][2] >> 1};
      std::uint32_t& slot = slotOf(key);
      if (slot != kEmpty) {
        sums_[slot].add(sums_[i]);
        continue;
      }
      slot = static_cast<std::uint32_t>(kept);
      keys_[kept] = key;
      sums_[kept] = sums_[i];
      ++kept;
    }
    keys_.resize(kept);
    sums_.resize(kept);
  }

 private:
  static constexpr std::uint32_t kEmpty = 0xFFFFFFFFU;

  // The key's slot: its voxel's index, or an empty slot to hold it.
  std::uint32_t& slotOf(const VoxelKey& key) {
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t at = hashOf(key) & mask;; at = (at + 1) & mask)
      if (slots_[at] == kEmpty || keys_[slots_[at]] == key) return slots_[at];
  }

  std::vector<VoxelKey> keys_;
  std::vector<VoxelSums> sums_;
  std::vector<std::uint32_t> slots_;  // at most half full
};

// Which attributes the file's points carry (every run has the same).
struct Attributes {
  bool normals = false, colors = false, intensities = false, stations = false;
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
      : level_(level), maxVoxels_(maxVoxels), attributes_(attributes), voxels_(maxVoxels) {}

  void add(const Scan& run) {
    const PointSet& points = run.points;
    forEachPoint(run, [&](const std::array<double, 3>& p, std::size_t i) {
      if (!finite(p) || !keyable(p)) {
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
      if (attributes_.stations) sums.station = points.stations[i];
      voxels_.add(keyOf(p), sums);
      while (voxels_.size() > maxVoxels_) coarsen();
    });
  }

  double voxelSize() const { return std::ldexp(1.0, level_); }
  std::uint64_t nonFinite() const { return nonFinite_; }
  std::uint64_t coarsenings() const { return coarsenings_; }

  // The centroids, in key order, as a scan in its local frame.
  Scan centroids() const {
    std::vector<std::uint32_t> order(voxels_.size());
    std::iota(order.begin(), order.end(), 0U);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return voxels_.key(a) < voxels_.key(b); });
    Scan scan;
    PointSet& points = scan.points;
    readers::PositionCollector positions;
    positions.reserve(order.size());
    for (const std::uint32_t voxel : order) {
      const VoxelSums& s = voxels_.sums(voxel);
      const double n = static_cast<double>(s.count);
      positions.push(s.position[0] / n, s.position[1] / n, s.position[2] / n);
      if (attributes_.normals)
        points.normals.emplace_back(s.normal[0], s.normal[1], s.normal[2]);
      if (attributes_.colors) {
        auto mean = [&](int c) { return static_cast<std::uint8_t>(std::lround(static_cast<double>(s.color[c]) / n)); };
        points.colors.push_back({mean(0), mean(1), mean(2)});
      }
      if (attributes_.intensities) points.intensities.push_back(static_cast<float>(s.intensity / n));
      if (attributes_.stations) points.stations.push_back(s.station);
    }
    positions.finishInto(scan);
    return scan;
  }

 private:
  // Whether the point's voxel key fits in 62 bits: a coordinate that far
  // (10^38 in a corrupt file) counts with the non-finite ones.
  bool keyable(const std::array<double, 3>& p) const {
    const double limit = std::ldexp(voxelSize(), 62);
    return std::abs(p[0]) < limit && std::abs(p[1]) < limit && std::abs(p[2]) < limit;
  }

  VoxelKey keyOf(const std::array<double, 3>& p) const {
    const double size = voxelSize();
    return {static_cast<std::int64_t>(std::floor(p[0] / size)), static_cast<std::int64_t>(std::floor(p[1] / size)),
            static_cast<std::int64_t>(std::floor(p[2] / size))};
  }

  // Voxels twice as large: floor(k / 2) is the key of floor(x / 2s) for a
  // power-of-two s, so the merged sums are those of the points themselves.
  void coarsen() {
    voxels_.halveKeys();
    ++level_;
    ++coarsenings_;
  }

  int level_;
  std::uint64_t maxVoxels_;
  Attributes attributes_;
  Voxels voxels_;
  std::uint64_t nonFinite_ = 0, coarsenings_ = 0;
};

// A format whose points are fixed-size records: its layout from the file's
// first bytes, and its reader of a run of records behind the header.
struct RecordFormat {
  std::optional<readers::RecordLayout> (*layout)(std::string_view head);
  Scan (*read)(std::string_view head, std::string_view records, const readers::RecordLayout& layout);
};

std::optional<RecordFormat> recordFormatOf(ScanFormat format) {
  if (format == ScanFormat::Ply) return RecordFormat{readers::plyRecordLayout, readers::readPlyRecords};
  if (format == ScanFormat::Las) return RecordFormat{readers::lasRecordLayout, readers::readLasRecords};
  if (format == ScanFormat::Pcd) return RecordFormat{readers::pcdRecordLayout, readers::readPcdRecords};
  return std::nullopt;
}

// Records [first, first + count) of the file as a scan; BadInput when the
// file ends early or the reader refuses them.
Result<Scan> readRecords(const fs::path& path, const std::string& head, const readers::RecordLayout& layout,
                         const RecordFormat& format, std::uint64_t first, std::uint64_t count) {
  const std::uint64_t at = layout.recordsAt + first * layout.recordBytes;
  auto bytes = readFileRange(path, at, static_cast<std::size_t>(count * layout.recordBytes));
  if (!bytes) return bytes.error();
  if (bytes->size() != count * layout.recordBytes)
    return badInput("{}: byte {}: the file ends inside point record {} of the {} its header declares", path.string(),
                    at + bytes->size(), first + bytes->size() / layout.recordBytes + 1, layout.count);
  try {
    return format.read(head, *bytes, layout);
  } catch (const parse::ParseFailure& failure) {
    return badInput("{}: records {} to {}: {}", path.string(), first + 1, first + count, failure.what());
  }
}

// Runs of records read from disk, each as a file of its own.
PointRuns recordRuns(const fs::path& path, std::string head, const readers::RecordLayout& layout,
                     const RecordFormat& format) {
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

// A file mapped, its runs read by `readMapped(file, runPoints, take)`,
// which returns the read notes; its parse failures are the file's BadInput.
template <class ReadMapped>
PointRuns mappedRuns(const fs::path& path, std::uint64_t count, ReadMapped readMapped) {
  auto read = [path, readMapped](std::uint64_t runPoints,
                                 const std::function<void(Scan&)>& take) -> Result<std::vector<std::string>> {
    auto file = MappedFile::open(path);
    if (!file) return file.error();
    try {
      return readMapped(*file, runPoints, take);
    } catch (const parse::ParseFailure& failure) {
      return badInput("{}: {}", path.string(), failure.what());
    }
  };
  return {path, count, std::move(read)};
}

// A LAZ file's chunks decompressed a run at a time, each run's compressed
// bytes given back once decoded.
PointRuns lazRuns(const fs::path& path, std::uint64_t count) {
  return mappedRuns(path, count,
                    [](const MappedFile& file, std::uint64_t runPoints, const std::function<void(Scan&)>& take) {
                      std::vector<std::string> notes;
                      const std::string summary =
                          readers::readLazRuns(file.bytes(), runPoints, [&](Scan& run, std::size_t end) {
                            if (notes.empty()) notes = run.readNotes;
                            take(run);
                            file.release(end);
                          });
                      notes.insert(notes.begin(), summary);
                      return notes;
                    });
}

// An E57 file read twice through (readers::readE57Runs), its pages given
// back as they are read.
PointRuns e57Runs(const fs::path& path, std::uint64_t count) {
  return mappedRuns(path, count,
                    [](const MappedFile& file, std::uint64_t runPoints, const std::function<void(Scan&)>& take) {
                      std::vector<std::string> notes;
                      readers::readE57Runs(
                          file.bytes(), runPoints,
                          [&](Scan& run) {
                            if (notes.empty()) notes = run.readNotes;
                            take(run);
                          },
                          [&] { file.release(file.bytes().size()); });
                      return notes;
                    });
}

// Bytes of a text file read at a time, and of a compressed PCD's body
// decoded at a time.
constexpr std::size_t kTextBlock = std::size_t{16} << 20;

// Each field's start in a compressed PCD's decoded body (every point's values
// of one field, then of the next; padding left out).
std::vector<std::uint64_t> fieldStarts(const readers::PcdCompressedLayout& layout) {
  std::vector<std::uint64_t> starts;
  std::uint64_t at = 0;
  for (const readers::PcdCompressedLayout::Block& field : layout.fields) {
    starts.push_back(at);
    if (!field.padding) at += layout.count * field.pointBytes;
  }
  return starts;
}

// Points [first, first + count) of a decoded body as the binary twin's
// records, padding zero.
Status gatherRecords(const RawFile& decoded, const readers::PcdCompressedLayout& layout,
                     const std::vector<std::uint64_t>& starts, std::uint64_t first, std::uint64_t count,
                     std::string& records, std::string& values) {
  const std::uint64_t recordBytes = layout.binary.recordBytes;
  records.assign(static_cast<std::size_t>(count * recordBytes), '\0');
  for (std::size_t f = 0; f < layout.fields.size(); ++f) {
    const readers::PcdCompressedLayout::Block& field = layout.fields[f];
    if (field.padding) continue;
    values.resize(static_cast<std::size_t>(count * field.pointBytes));
    APO_RETURN_IF_ERROR(decoded.read(starts[f] + first * field.pointBytes, values.data(), values.size()));
    for (std::uint64_t i = 0; i < count; ++i)
      std::memcpy(records.data() + i * recordBytes + field.recordOffset, values.data() + i * field.pointBytes,
                  field.pointBytes);
  }
  return okStatus();
}

// A binary_compressed PCD of one row: its LZF body decoded through, 16 MiB
// at a time, into a scratch file of no name in TMPDIR (its decoded size: at
// most 4 GiB, the format's sizes being 32-bit), then runs of points gathered
// from its fields into the binary twin's records, each read as a binary
// PCD's records are.
PointRuns compressedPcdRuns(const fs::path& path, readers::PcdCompressedLayout layout) {
  const std::uint64_t count = layout.count;
  auto read = [path, layout = std::move(layout)](
                  std::uint64_t runPoints, const std::function<void(Scan&)>& take) -> Result<std::vector<std::string>> {
    auto file = MappedFile::open(path);
    if (!file) return file.error();
    std::error_code noTemp;
    const fs::path temp = fs::temp_directory_path(noTemp);
    if (noTemp) return internalError("no folder for the decoded body of {}: {}", path.string(), noTemp.message());
    auto decoded = RawFile::scratch(fmt::format("the decoded body of {}", path.string()), temp);
    if (!decoded) return decoded.error();
    const std::string_view bytes = file->bytes();
    std::vector<std::string> notes;
    try {
      const readers::PcdCompressedStream stream =
          readers::pcdCompressedStream(bytes.substr(layout.sizesAt), layout, bytes.size());
      Status written = okStatus();
      std::uint64_t at = 0;
      lzf::decodeBlocks(bytes.substr(layout.sizesAt + 8, stream.compressedBytes), stream.decodedBytes,
                        layout.sizesAt + 8, kTextBlock, [&](std::string_view block) {
                          if (written.ok()) written = decoded->write(at, block.data(), block.size());
                          at += block.size();
                          file->release(bytes.size());
                        });
      APO_RETURN_IF_ERROR(written);
      const std::vector<std::uint64_t> starts = fieldStarts(layout);
      std::string records, values;
      for (std::uint64_t first = 0; first < layout.count; first += runPoints) {
        const std::uint64_t points = std::min(runPoints, layout.count - first);
        APO_RETURN_IF_ERROR(gatherRecords(*decoded, layout, starts, first, points, records, values));
        Scan run;
        try {
          run = readers::readPcdRecords(layout.binaryHead, records, layout.binary);
        } catch (const parse::ParseFailure& failure) {
          return badInput("{}: points {} to {}: {}", path.string(), first + 1, first + points, failure.what());
        }
        if (first == 0) notes = run.readNotes;
        take(run);
      }
    } catch (const parse::ParseFailure& failure) {
      return badInput("{}: {}", path.string(), failure.what());
    }
    notes.insert(notes.begin(), "binary_compressed: its LZF body decoded through a scratch file, a run at a time");
    return notes;
  };
  return {path, count, std::move(read)};
}

// The file's lines from byte `from` on, each with its terminator (\n, \r\n
// or \r, as parse::TextCursor ends lines; the last may have none), handed to
// `visit` in order, a block of the file held at a time.
Status forEachLine(const fs::path& path, std::uint64_t from, const std::function<void(std::string_view line)>& visit) {
  std::string pending;  // the start of a line that the block cut
  for (std::uint64_t at = from;;) {
    auto block = readFileRange(path, at, kTextBlock);
    if (!block) return block.error();
    at += block->size();
    const bool last = block->size() < kTextBlock;
    std::string text = std::move(pending) + *block;
    std::size_t start = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] != '\n' && text[i] != '\r') continue;
      // A \r at the block's end may be half of \r\n: the next block decides.
      if (text[i] == '\r' && i + 1 == text.size() && !last) break;
      if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      visit(std::string_view(text).substr(start, i + 1 - start));
      start = i + 1;
    }
    pending = text.substr(start);
    if (last) {
      if (!pending.empty()) visit(pending);
      return okStatus();
    }
  }
}

// A format whose points are one to a line: its layout from the file's first
// bytes, which lines hold points, and its reader of a run of lines.
struct TextFormat {
  std::optional<readers::TextLayout> (*layout)(std::string_view head);
  bool (*isDataLine)(std::string_view line);
  Scan (*read)(std::string_view head, std::string_view lines, const readers::TextRun& run);
};

std::optional<TextFormat> textFormatOf(ScanFormat format) {
  if (format == ScanFormat::Xyz) return TextFormat{readers::xyzTextLayout, readers::isXyzDataLine, readers::readXyzLines};
  if (format == ScanFormat::Ply) return TextFormat{readers::plyTextLayout, readers::isNonBlankLine, readers::readPlyLines};
  if (format == ScanFormat::Pcd) return TextFormat{readers::pcdTextLayout, readers::isNonBlankLine, readers::readPcdLines};
  return std::nullopt;
}

// Runs of whole lines after the file's head, each holding `runPoints` data
// lines; the last run holds every line after the one before it, and the
// rest of `count` as its points: a PLY's lines beyond its header's count are
// refused by its reader, lines short of it here.
PointRuns textRuns(const fs::path& path, std::string head, const readers::TextLayout& layout, std::uint64_t count,
                   const TextFormat& format) {
  auto read = [path, head = std::move(head), layout, count, format](
                  std::uint64_t runPoints, const std::function<void(Scan&)>& take) -> Result<std::vector<std::string>> {
    std::vector<std::string> notes;
    std::string lines;
    readers::TextRun run{layout.linesBefore, 0, 0};
    std::uint64_t linesInRun = 0;
    std::optional<Error> failed;
    auto flush = [&] {
      try {
        Scan points = format.read(head, lines, run);
        if (run.pointsBefore == 0) notes = points.readNotes;
        take(points);
      } catch (const parse::ParseFailure& failure) {
        failed = badInput("{}: {}", path.string(), failure.what());
      }
      run = {run.linesBefore + linesInRun, run.pointsBefore + run.points, 0};
      lines.clear();
      linesInRun = 0;
    };
    const Status walked = forEachLine(path, layout.dataBytes, [&](std::string_view line) {
      if (failed) return;
      lines += line;
      ++linesInRun;
      if (!format.isDataLine(line)) return;
      ++run.points;
      const bool last = run.pointsBefore + runPoints >= count;
      if (!last && run.points == runPoints) flush();
    });
    if (!walked) return walked.error();
    if (!failed && run.pointsBefore + run.points < count)
      return badInput("{}: line {}: the file ends after {} of the {} points its header declares", path.string(),
                      run.linesBefore + linesInRun, run.pointsBefore + run.points, count);
    if (!failed && (run.points > 0 || linesInRun > 0)) {
      run.points = count - run.pointsBefore;
      flush();
    }
    if (failed) return *failed;
    return notes;
  };
  return {path, count, std::move(read)};
}

// The data lines after the file's head: the points it holds.
Result<std::uint64_t> countDataLines(const fs::path& path, const readers::TextLayout& layout, const TextFormat& format) {
  std::uint64_t points = 0;
  const Status walked = forEachLine(path, layout.dataBytes, [&](std::string_view line) {
    if (format.isDataLine(line)) ++points;
  });
  if (!walked) return walked.error();
  return points;
}

// The file as text runs when its head decides its layout and it may hold
// more than `maxPoints` points: a PLY's header says; XYZ text is counted
// when its size allows (a point takes at least 6 bytes, "0 0 0\n": smaller
// files are read whole without counting). Else nullopt.
Result<std::optional<PointRuns>> openTextRuns(const fs::path& path, std::string head, const TextFormat& format,
                                              std::uint64_t maxPoints) {
  const std::optional<readers::TextLayout> layout = format.layout(head);
  if (!layout) return std::optional<PointRuns>();
  std::uint64_t count = layout->count;
  if (count == 0) {
    std::error_code error;
    const std::uint64_t size = fs::file_size(path, error);
    if (error || size / 6 <= maxPoints) return std::optional<PointRuns>();
    auto counted = countDataLines(path, *layout, format);
    if (!counted) return counted.error();
    count = *counted;
  }
  head.resize(layout->headBytes);
  return std::optional<PointRuns>(textRuns(path, std::move(head), *layout, count, format));
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

Result<std::optional<PointRuns>> openPointRuns(const fs::path& path, ScanFormat format, std::uint64_t maxPoints) {
  if (format == ScanFormat::E57) {
    auto file = MappedFile::open(path);
    if (!file) return file.error();
    const std::optional<std::uint64_t> count = readers::e57RecordCount(file->bytes());
    if (!count) return std::optional<PointRuns>();
    return std::optional<PointRuns>(e57Runs(path, *count));
  }
  const std::optional<RecordFormat> records = recordFormatOf(format);
  const std::optional<TextFormat> text = textFormatOf(format);
  if (!records && !text) return std::optional<PointRuns>();
  auto head = readFileRange(path, 0, kHeadBytes);
  if (!head) return head.error();
  if (!records) return openTextRuns(path, std::move(*head), *text, maxPoints);
  if (format == ScanFormat::Las)
    if (const auto count = readers::lazPointCount(*head)) return std::optional<PointRuns>(lazRuns(path, *count));
  if (format == ScanFormat::Pcd)
    if (auto compressed = readers::pcdCompressedLayout(*head))
      return std::optional<PointRuns>(compressedPcdRuns(path, std::move(*compressed)));
  const auto layout = records->layout(*head);
  if (text && !layout) return openTextRuns(path, std::move(*head), *text, maxPoints);
  if (!layout || layout->recordBytes == 0) return std::optional<PointRuns>();
  head->resize(static_cast<std::size_t>(layout->recordsAt));
  return std::optional<PointRuns>(recordRuns(path, std::move(*head), *layout, *records));
}

Result<VoxelSubsample> voxelSubsample(const PointRuns& file, std::uint64_t maxPoints, std::uint64_t runPoints,
                                      const Progress& progress) {
  VoxelSubsample result;
  std::optional<VoxelGrid> grid;
  // A PCD's VIEWPOINT or an E57's scan positions, in the frame of the first
  // run, whose reader read them.
  std::optional<Viewpoint> viewpoint;
  std::vector<ScanStation> stations;
  std::array<double, 3> firstFrame{};
  auto notes = file.read(std::max(runPoints, kStartPoints), [&](Scan& run) {
    if (!grid) {
      const PointSet& points = run.points;
      grid.emplace(startLevel(run, maxPoints), maxPoints,
                   Attributes{points.hasNormals(), points.hasColors(), points.hasIntensities(),
                              points.hasStations() && !run.stations.empty()});
      viewpoint = run.viewpoint;
      stations = run.stations;
      firstFrame = run.origin;
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
  const auto intoResultFrame = [&](Vec3f& position) {
    for (int axis = 0; axis < 3; ++axis)
      position[axis] = static_cast<float>(firstFrame[axis] + position[axis] - result.scan.origin[axis]);
  };
  if (viewpoint) {
    intoResultFrame(viewpoint->origin);
    result.scan.viewpoint = viewpoint;
  }
  if (result.scan.points.hasStations()) {
    for (ScanStation& station : stations) intoResultFrame(station.position);
    result.scan.stations = std::move(stations);
  }
  result.voxelSize = grid->voxelSize();
  result.nonFinite = grid->nonFinite();
  result.coarsenings = grid->coarsenings();
  return result;
}

}  // namespace apo::large_scan
