// LAS 1.2 and LAZ writing (readers.h, encodeLas). A LAS point stores int32
// coordinates, steps of the header's scale from its offset; here one scale
// for the three axes, the power of ten at or below half a float's spacing
// at the scan's largest coordinate (as the E57 writer chooses it: finer
// than any two floats the scan holds, 0.01 µm for a 20 cm object), and the
// offset at the scan's box minimum plus its origin, so that the file is in
// the scan's file coordinates. The integers then run from 0 to at most
// 2 × 10 × 2^24, well inside int32.
//
// The LAS 1.2 header (ASPRS LAS 1.2, table 4), byte offsets:
//     0 "LASF"                    4 uint16 file source id   6 uint16 global encoding
//     8 GUID (16 bytes)          24 uint8 version 1, 2     26 system identifier (32)
//    58 generating software (32) 90 uint16 creation day, year
//    94 uint16 header size 227   96 uint32 offset to point data
//   100 uint32 number of VLRs   104 uint8 point format (bit 7: LASzip-compressed)
//   105 uint16 record length    107 uint32 point count  111 uint32[5] points by return
//   131 double scale x, y, z    155 double offset x, y, z
//   179 double max x, min x, max y, min y, max z, min z
// Point formats 0 and 2 (20 and 26 bytes): int32 x, y, z; uint16 intensity;
// return number (bits 0-2) and number of returns (3-5); classification;
// int8 scan angle; user data; uint16 point source id; format 2: uint16 red,
// green, blue.
#include "core/error.h"
#include "ingest/laz_encoder.h"
#include "ingest/readers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

namespace apo::readers {
namespace {

constexpr std::uint16_t kHeaderSize = 227;
constexpr std::uint8_t kLaszipFormatBit = 0x80;
constexpr std::uint8_t kHighestLegacyClass = 31;  // format 0-5 classes have 5 bits
constexpr std::uint8_t kUnclassified = 1;

template <class T>
void put(std::uint8_t* at, T value) {
  std::memcpy(at, &value, sizeof value);
}

template <class T>
void append(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

// The grid the coordinates are stored on.
struct Quantization {
  double scale = 1e-3;
  Vec3f boxMin = Vec3f::Zero();           // local frame, integer 0 on each axis
  std::array<double, 3> offset{};        // file coordinates of integer 0
  std::array<std::int32_t, 3> largest{};  // the largest integer on each axis

  std::int32_t step(const Vec3f& p, int axis) const {
    return static_cast<std::int32_t>(std::llround((double{p[axis]} - double{boxMin[axis]}) / scale));
  }
};

Quantization quantizationOf(const Scan& scan) {
  Quantization q;
  const Aabb box = boundingBox(scan.points.positions);
  const double largest = std::max(box.min.cwiseAbs().maxCoeff(), box.max.cwiseAbs().maxCoeff());
  if (largest > 0.0) q.scale = std::pow(10.0, std::floor(std::log10(largest * 0x1p-24)));
  q.boxMin = box.min;
  for (int axis = 0; axis < 3; ++axis) {
    q.offset[axis] = scan.origin[axis] + double{box.min[axis]};
    q.largest[axis] = q.step(box.max, axis);
  }
  return q;
}

// Intensities as LAS's uint16: as they are when all are whole numbers in
// [0, 65535] (read from a LAS or E57 file), else scaled so that the largest
// is 65535; negative and non-finite ones become 0.
class IntensityToUint16 {
 public:
  explicit IntensityToUint16(const std::vector<float>& intensities) {
    float largest = 0.0f;
    bool whole = true;
    for (const float v : intensities) {
      if (!std::isfinite(v)) continue;
      largest = std::max(largest, v);
      whole = whole && v >= 0.0f && v <= 65535.0f && v == std::floor(v);
    }
    factor_ = whole || largest <= 0.0f ? 1.0 : 65535.0 / largest;
  }
  std::uint16_t operator()(float v) const {
    if (!std::isfinite(v) || v <= 0.0f) return 0;
    return static_cast<std::uint16_t>(std::min<double>(std::round(v * factor_), 65535.0));
  }

 private:
  double factor_ = 1.0;
};

// Point i's record of format 0 or 2.
class RecordMaker {
 public:
  explicit RecordMaker(const Scan& scan)
      : points_(scan.points), quantization_(quantizationOf(scan)), intensity_(scan.points.intensities) {}

  int format() const { return points_.hasColors() ? 2 : 0; }
  std::uint16_t recordLength() const { return points_.hasColors() ? 26 : 20; }
  const Quantization& quantization() const { return quantization_; }

  void fill(std::size_t i, std::uint8_t* record) const {
    const Vec3f& p = points_.positions[i];
    for (int axis = 0; axis < 3; ++axis) put<std::int32_t>(record + 4 * axis, quantization_.step(p, axis));
    put<std::uint16_t>(record + 12, points_.hasIntensities() ? intensity_(points_.intensities[i]) : 0);
    // A scan without returns is single returns (one of one).
    const std::uint8_t r = points_.hasReturns() ? std::min<std::uint8_t>(points_.returnNumbers[i], 7) : 1;
    const std::uint8_t n = points_.hasReturns() ? std::min<std::uint8_t>(points_.returnCounts[i], 7) : 1;
    record[14] = static_cast<std::uint8_t>(r | (n << 3));
    const std::uint8_t c = points_.hasClassifications() ? points_.classifications[i] : 0;
    record[15] = c <= kHighestLegacyClass ? c : kUnclassified;
    record[16] = 0;  // scan angle
    record[17] = 0;  // user data
    // The point source id says which scan position (station) saw the point.
    put<std::uint16_t>(record + 18, points_.hasStations() ? points_.stations[i] : 0);
    if (!points_.hasColors()) return;
    // 8-bit channels to LAS's 16 (255 to 65535).
    const Rgb8 color = points_.colors[i];
    put<std::uint16_t>(record + 20, static_cast<std::uint16_t>(color.r * 257));
    put<std::uint16_t>(record + 22, static_cast<std::uint16_t>(color.g * 257));
    put<std::uint16_t>(record + 24, static_cast<std::uint16_t>(color.b * 257));
  }

 private:
  const PointSet& points_;
  Quantization quantization_;
  IntensityToUint16 intensity_;
};

// How many points are first, second, ... fifth returns (the header's counts).
std::array<std::uint32_t, 5> pointsByReturn(const PointSet& points) {
  std::array<std::uint32_t, 5> counts{};
  if (!points.hasReturns()) {
    counts[0] = static_cast<std::uint32_t>(points.size());
    return counts;
  }
  for (const std::uint8_t r : points.returnNumbers)
    if (r >= 1 && r <= 5) ++counts[r - 1];
  return counts;
}

std::string fixedText(std::string_view text, std::size_t size) {
  std::string field(text.substr(0, size));
  field.resize(size, '\0');
  return field;
}

std::string lasHeader(const Scan& scan, const RecordMaker& records, bool compressed, std::size_t vlrBytes) {
  const Quantization& q = records.quantization();
  std::string header = "LASF";
  append<std::uint16_t>(header, 0);  // file source id
  append<std::uint16_t>(header, 0);  // global encoding
  header += std::string(16, '\0');   // GUID
  append<std::uint8_t>(header, 1);
  append<std::uint8_t>(header, 2);
  header += fixedText("OTHER", 32);
  header += fixedText("apo", 32);
  append<std::uint16_t>(header, 0);  // creation day and year unknown: the bytes stay the same run to run
  append<std::uint16_t>(header, 0);
  append<std::uint16_t>(header, kHeaderSize);
  append<std::uint32_t>(header, static_cast<std::uint32_t>(kHeaderSize + vlrBytes));
  append<std::uint32_t>(header, compressed ? 1 : 0);
  append<std::uint8_t>(header, static_cast<std::uint8_t>(records.format() | (compressed ? kLaszipFormatBit : 0)));
  append<std::uint16_t>(header, records.recordLength());
  append<std::uint32_t>(header, static_cast<std::uint32_t>(scan.points.size()));
  for (const std::uint32_t count : pointsByReturn(scan.points)) append<std::uint32_t>(header, count);
  for (int axis = 0; axis < 3; ++axis) append<double>(header, q.scale);
  for (int axis = 0; axis < 3; ++axis) append<double>(header, q.offset[axis]);
  // The bounds of the stored coordinates (what a reader computes from them).
  for (int axis = 0; axis < 3; ++axis) {
    append<double>(header, q.offset[axis] + q.largest[axis] * q.scale);
    append<double>(header, q.offset[axis]);
  }
  APO_CHECK_OP(header.size(), ==, kHeaderSize);
  return header;
}

}  // namespace

std::string encodeLas(const Scan& scan, LasEncoding encoding) {
  const PointSet& points = scan.points;
  APO_CHECK(points.size() > 0 && points.size() <= std::numeric_limits<std::uint32_t>::max());
  for (const Vec3f& p : points.positions) APO_CHECK(p.allFinite());
  const RecordMaker records(scan);
  const bool compressed = encoding == LasEncoding::Laz;
  const std::string vlr = compressed ? laz::laszipVlr(records.format()) : std::string();
  std::string file = lasHeader(scan, records, compressed, vlr.size()) + vlr;
  std::array<std::uint8_t, 26> record{};
  if (!compressed) {
    file.reserve(file.size() + points.size() * records.recordLength());
    for (std::size_t i = 0; i < points.size(); ++i) {
      records.fill(i, record.data());
      file.append(reinterpret_cast<const char*>(record.data()), records.recordLength());
    }
    return file;
  }
  laz::PointCompressor compressor(records.format(), file);
  for (std::size_t i = 0; i < points.size(); ++i) {
    records.fill(i, record.data());
    compressor.add(record.data());
  }
  compressor.finish();
  return file;
}

}  // namespace apo::readers
