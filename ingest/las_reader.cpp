// LAS (ASPRS lidar exchange format) 1.0 to 1.4, point formats 0 to 10,
// uncompressed. Positions are the stored integers times the header's scale
// plus its offset, in double, then moved into the local frame (positions.h);
// intensity, RGB, classification and return numbers are kept; GPS time,
// scan angle, user data, point source id, waveform packets and extra bytes
// are skipped by the record length the header declares (and said so in the
// scan's notes). LAZ (LASzip-compressed points) is decompressed first into
// the same raw records (laz_decoder.h), which then take the same path. Every
// count and offset the header claims is checked against the file's size
// before anything is allocated for it.
#include "ingest/laz_decoder.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

namespace apo::readers {
namespace {

using parse::fail;

// The public header block's fields (LAS 1.4 specification, table 3).
constexpr std::size_t kHeaderSize12 = 227;  // LAS 1.0 to 1.2
constexpr std::size_t kHeaderSize13 = 235;  // plus the waveform data start
constexpr std::size_t kHeaderSize14 = 375;  // plus EVLRs and 64-bit counts
constexpr std::size_t kVlrHeaderSize = 54;

// Bytes of each point format's own fields; a record may be longer (extra
// bytes, declared by the record length).
constexpr std::array<std::uint16_t, 11> kFormatSize = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
// Where RGB starts, for the formats that have it (0: none).
constexpr std::array<std::uint16_t, 11> kRgbOffset = {0, 0, 20, 28, 0, 28, 0, 30, 30, 0, 30};

struct Header {
  int versionMinor = 0;
  std::uint16_t headerSize = 0;
  std::uint32_t pointOffset = 0;
  std::uint32_t vlrCount = 0;
  int format = 0;
  bool compressed = false;  // LAZ: the format byte's bit 7 (or LASzip's old bit 6)
  std::uint16_t recordLength = 0;
  std::uint64_t pointCount = 0;
  std::size_t pointCountAt = 107;  // the legacy count's place, or the 64-bit one's
  std::array<double, 3> scale{}, offset{};
};

std::uint8_t byteAt(std::string_view bytes, std::size_t at) { return static_cast<std::uint8_t>(bytes[at]); }

template <class T>
T read(std::string_view bytes, std::size_t at, std::string_view what) {
  return parse::BinaryCursor(bytes, at).read<T>(false, what);
}

void checkSignatureAndVersion(std::string_view bytes) {
  if (bytes.size() < 4 || bytes.substr(0, 4) != "LASF") fail("byte 0: not a LAS file (no 'LASF' signature)");
  if (bytes.size() < kHeaderSize12)
    fail("byte {}: the file ends inside the {}-byte LAS header", bytes.size(), kHeaderSize12);
  const int major = byteAt(bytes, 24), minor = byteAt(bytes, 25);
  if (major != 1 || minor > 4) fail("byte 24: LAS version {}.{}: apo reads LAS 1.0 to 1.4", major, minor);
}

Header parseHeader(std::string_view bytes) {
  checkSignatureAndVersion(bytes);
  Header header;
  header.versionMinor = byteAt(bytes, 25);
  header.headerSize = read<std::uint16_t>(bytes, 94, "header size");
  header.pointOffset = read<std::uint32_t>(bytes, 96, "offset to point data");
  header.vlrCount = read<std::uint32_t>(bytes, 100, "number of VLRs");
  const std::uint8_t formatByte = byteAt(bytes, 104);
  header.recordLength = read<std::uint16_t>(bytes, 105, "point record length");
  header.compressed = (formatByte & 0xC0) != 0;
  header.format = formatByte & 0x3F;
  if (header.format > 10) fail("byte 104: point data format {}: LAS defines formats 0 to 10", header.format);
  const std::size_t minimumHeader =
      header.versionMinor >= 4 ? kHeaderSize14 : header.versionMinor == 3 ? kHeaderSize13 : kHeaderSize12;
  if (header.headerSize < minimumHeader)
    fail("byte 94: header size {} is below the {} bytes of a LAS 1.{} header", header.headerSize, minimumHeader,
         header.versionMinor);
  if (bytes.size() < header.headerSize)
    fail("byte {}: the file ends inside its {}-byte header", bytes.size(), header.headerSize);
  if (header.pointOffset < header.headerSize || header.pointOffset > bytes.size())
    fail("byte 96: offset to point data {} is outside [{}, {}] (the header's end, the file's size)", header.pointOffset,
         header.headerSize, bytes.size());
  if (header.recordLength < kFormatSize[header.format])
    fail("byte 105: point record length {} is shorter than the {} bytes of point format {}", header.recordLength,
         kFormatSize[header.format], header.format);
  header.pointCount = read<std::uint32_t>(bytes, 107, "number of point records");
  if (header.versionMinor >= 4) {
    const auto count64 = read<std::uint64_t>(bytes, 247, "number of point records (64-bit)");
    if (count64 != 0) {
      header.pointCount = count64;
      header.pointCountAt = 247;
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    header.scale[axis] = read<double>(bytes, 131 + 8 * axis, "scale factor");
    header.offset[axis] = read<double>(bytes, 155 + 8 * axis, "offset");
    if (!std::isfinite(header.scale[axis]) || header.scale[axis] == 0.0)
      fail("byte {}: scale factor {} is not a finite non-zero number", 131 + 8 * axis, header.scale[axis]);
    if (!std::isfinite(header.offset[axis]))
      fail("byte {}: offset {} is not a finite number", 155 + 8 * axis, header.offset[axis]);
  }
  return header;
}

// Walks the variable-length records between the header and the points, only
// to report what does not add up (the points' place is the header's offset,
// whatever the records say).
void noteVlrProblems(std::string_view bytes, const Header& header, std::vector<std::string>& notes) {
  std::size_t at = header.headerSize;
  std::uint32_t walked = 0;
  while (walked < header.vlrCount && at + kVlrHeaderSize <= header.pointOffset) {
    at += kVlrHeaderSize + read<std::uint16_t>(bytes, at + 52, "VLR record length");
    ++walked;
  }
  if (walked < header.vlrCount || at > header.pointOffset)
    notes.push_back(fmt::format("the header declares {} variable-length records, but {} fit before the point data at "
                                "byte {}; the points were read from there",
                                header.vlrCount, at > header.pointOffset ? walked - 1 : walked, header.pointOffset));
}

// 16-bit colour channels (the spec's) to bytes; files that store 8-bit values
// in them (some writers do) are taken as they are.
std::vector<Rgb8> colorsToBytes(const std::vector<std::array<std::uint16_t, 3>>& colors) {
  std::uint16_t largest = 0;
  for (const auto& c : colors) largest = std::max({largest, c[0], c[1], c[2]});
  const int shift = largest > 255 ? 8 : 0;
  std::vector<Rgb8> bytes;
  bytes.reserve(colors.size());
  for (const auto& c : colors)
    bytes.push_back({static_cast<std::uint8_t>(c[0] >> shift), static_cast<std::uint8_t>(c[1] >> shift),
                     static_cast<std::uint8_t>(c[2] >> shift)});
  return bytes;
}

void checkHasPoints(const Header& header) {
  if (header.pointCount == 0) fail("byte {}: no points: the header's point count is 0", header.pointCountAt);
}

// The points from their raw records, which start at `records`' byte 0 (the
// file's point data, or the LAZ points decompressed); `recordsAt` is that
// byte's offset in the file, for messages.
Scan readPoints(std::string_view records, std::size_t recordsAt, const Header& header) {
  parse::checkCountFits(header.pointCount, header.recordLength, records.size(),
                        fmt::format("LAS points in format {}", header.format), recordsAt);
  checkHasPoints(header);
  const auto count = static_cast<std::size_t>(header.pointCount);
  const bool extended = header.format >= 6;
  const std::uint16_t rgbAt = kRgbOffset[header.format];
  Scan scan;
  PointSet& points = scan.points;
  PositionCollector positions;
  positions.reserve(count);
  points.intensities.reserve(count);
  points.classifications.reserve(count);
  points.returnNumbers.reserve(count);
  points.returnCounts.reserve(count);
  std::vector<std::array<std::uint16_t, 3>> colors;
  if (rgbAt != 0) colors.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t at = i * header.recordLength;
    std::array<double, 3> world{};
    for (int axis = 0; axis < 3; ++axis)
      world[axis] = read<std::int32_t>(records, at + 4 * axis, "coordinate") * header.scale[axis] + header.offset[axis];
    positions.push(world[0], world[1], world[2]);
    points.intensities.push_back(read<std::uint16_t>(records, at + 12, "intensity"));
    const std::uint8_t returns = byteAt(records, at + 14);
    points.returnNumbers.push_back(extended ? returns & 0x0F : returns & 0x07);
    points.returnCounts.push_back(extended ? returns >> 4 : (returns >> 3) & 0x07);
    points.classifications.push_back(extended ? byteAt(records, at + 16) : byteAt(records, at + 15) & 0x1F);
    if (rgbAt != 0)
      colors.push_back({read<std::uint16_t>(records, at + rgbAt, "red"),
                        read<std::uint16_t>(records, at + rgbAt + 2, "green"),
                        read<std::uint16_t>(records, at + rgbAt + 4, "blue")});
  }
  if (rgbAt != 0) points.colors = colorsToBytes(colors);
  positions.finishInto(scan);
  return scan;
}

// What the LAZ decoder needs of the header.
laz::PointRecords lazLayout(const Header& header) {
  return {header.headerSize, header.vlrCount,   header.pointOffset, header.format,
          header.recordLength, header.pointCount, header.pointCountAt};
}

// The points' raw records, decompressed when the file is LAZ (with a read
// note saying how it was compressed).
std::string decompressedRecords(std::string_view bytes, const Header& header, std::vector<std::string>& notes) {
  checkHasPoints(header);
  laz::Decompressed laz = laz::decompressPoints(bytes, lazLayout(header));
  notes.push_back(std::move(laz.summary));
  return std::move(laz.records);
}

}  // namespace

Scan readLas(std::string_view bytes) {
  const Header header = parseHeader(bytes);
  std::vector<std::string> notes;
  noteVlrProblems(bytes, header, notes);
  const std::string decompressed = header.compressed ? decompressedRecords(bytes, header, notes) : std::string();
  Scan scan = readPoints(header.compressed ? std::string_view(decompressed) : bytes.substr(header.pointOffset),
                         header.pointOffset, header);
  notes.push_back(fmt::format("LAS 1.{}, point format {}: GPS time, scan angle, user data and point source id not kept",
                              header.versionMinor, header.format));
  if (header.recordLength > kFormatSize[header.format])
    notes.push_back(fmt::format("{} extra bytes per point (beyond format {}'s {}) skipped",
                                header.recordLength - kFormatSize[header.format], header.format,
                                kFormatSize[header.format]));
  scan.readNotes.insert(scan.readNotes.begin(), notes.begin(), notes.end());
  return scan;
}

std::optional<RecordLayout> lasRecordLayout(std::string_view head) {
  try {
    if (head.size() < kHeaderSize12 || head.size() < read<std::uint32_t>(head, 96, "offset to point data"))
      return std::nullopt;
    const Header header = parseHeader(head);
    if (header.compressed || header.pointCount == 0) return std::nullopt;
    return RecordLayout{header.pointCount, header.pointOffset, header.recordLength};
  } catch (const parse::ParseFailure&) {
    return std::nullopt;  // the whole file's read says what is wrong, with the file's size known
  }
}

Scan readLasRecords(std::string_view head, std::string_view records, const RecordLayout& layout) {
  std::string file(head.substr(0, layout.recordsAt));
  const std::uint64_t count = records.size() / layout.recordBytes;
  // Both counts: the legacy one (0 beyond 32 bits, as LAS 1.4 writes it) and,
  // from LAS 1.4, the 64-bit one.
  const auto legacy = static_cast<std::uint32_t>(count > 0xFFFFFFFFU ? 0 : count);
  std::memcpy(file.data() + 107, &legacy, sizeof legacy);
  if (byteAt(file, 25) >= 4) std::memcpy(file.data() + 247, &count, sizeof count);
  file += records;
  return readLas(file);
}

std::optional<std::uint64_t> lazPointCount(std::string_view head) {
  try {
    const Header header = parseHeader(head);
    if (!header.compressed) return std::nullopt;
    return header.pointCount;
  } catch (const parse::ParseFailure&) {
    return std::nullopt;
  }
}

std::string readLazRuns(std::string_view file, std::uint64_t runPoints,
                        const std::function<void(Scan& run, std::size_t end)>& take) {
  const Header header = parseHeader(file);
  if (!header.compressed) fail("byte 104: point data format byte {}: not LAZ", byteAt(file, 104));
  checkHasPoints(header);
  // Each run's records behind the header, marked uncompressed, are a LAS file.
  std::string head(file.substr(0, header.pointOffset));
  head[104] = static_cast<char>(header.format);
  const RecordLayout layout{header.pointCount, header.pointOffset, header.recordLength};
  return laz::decompressPointsInRuns(file, lazLayout(header), runPoints, [&](std::string& records, std::size_t end) {
    Scan run = readLasRecords(head, records, layout);
    take(run, end);
  });
}

std::string lasPointRecords(std::string_view bytes) {
  const Header header = parseHeader(bytes);
  std::vector<std::string> notes;
  if (header.compressed) return decompressedRecords(bytes, header, notes);
  parse::checkCountFits(header.pointCount, header.recordLength, bytes.size() - header.pointOffset,
                        fmt::format("LAS points in format {}", header.format), header.pointOffset);
  checkHasPoints(header);
  return std::string(bytes.substr(header.pointOffset, header.pointCount * header.recordLength));
}

}  // namespace apo::readers
