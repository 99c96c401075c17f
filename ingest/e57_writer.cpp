// E57 (ASTM E2807) 1.0 files of a Scan, readable by e57_reader.cpp and by
// other E57 software. The layout (e57_format.h, e57_pages.h):
//
//   logical:  | file header (48) | section of station 0 | ... | XML | zeros to the page's end |
//
// then cut into 1020-byte pages, each followed by its CRC-32C. One data3D per
// station, holding the station's points in its own frame (the inverse of its
// pose applied, in double), so that a reader must apply the pose to get the
// common frame back; a scan without stations is one data3D posed at its
// origin. Fields, in this order:
//
//   cartesianX/Y/Z        ScaledInteger, scale a power of ten at most half a
//                         float's spacing at the station's largest coordinate
//                         (no coarser than the float positions written)
//   cartesianInvalidState Integer 0..2, only when some position is not finite
//                         (written as 2, coordinates 0)
//   nor:normalX/Y/Z       Float single (the libe57.org normals extension)
//   intensity             Float single; intensityLimits [0, 1] when every value
//                         lies there (readers map by them), else the values' range
//   colorRed/Green/Blue   Integer 0..255, colorLimits 0..255
//   rowIndex/columnIndex  Integer 0..max, and the station's indexBounds
//
// Each data packet holds the same number of records, a multiple of 8, of
// every field, so that every bytestream ends on a byte boundary in every
// packet.
#include "core/error.h"
#include "ingest/e57_format.h"
#include "ingest/e57_pages.h"
#include "ingest/readers.h"

#include <fmt/format.h>
#include <pugixml.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace apo::readers {
namespace {

// ---------------------------------------------------------------- bit streams

// Appends values least significant bit first, as E57's bit-pack codec reads them.
class BitWriter {
 public:
  void reserve(std::size_t bytes) { bytes_.reserve(bytes); }
  void put(std::uint64_t value, int bits) {
    if (bits == 0) return;
    if (bits == 64) {
      put(value & 0xFFFFFFFF, 32);
      put(value >> 32, 32);
      return;
    }
    value &= (std::uint64_t{1} << bits) - 1;
    register_ |= value << used_;
    if (used_ + bits >= 64) {
      flushWord();
      register_ = used_ == 0 ? 0 : value >> (64 - used_);
      used_ = used_ + bits - 64;
    } else {
      used_ += bits;
    }
  }
  void putFloat(float value) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, 4);
    put(bits, 32);
  }
  // The stream's bytes, the last one zero-padded.
  std::string finish() {
    for (int byte = 0; byte * 8 < used_; ++byte) bytes_.push_back(static_cast<char>(register_ >> (8 * byte)));
    register_ = 0;
    used_ = 0;
    return std::move(bytes_);
  }

 private:
  void flushWord() {
    char word[8];
    std::memcpy(word, &register_, 8);  // little-endian machines
    bytes_.append(word, 8);
  }

  std::string bytes_;
  std::uint64_t register_ = 0;
  int used_ = 0;
};

// ---------------------------------------------------------------- stations

using Matrix3 = std::array<std::array<double, 3>, 3>;

Matrix3 rotationMatrix(const std::array<double, 4>& q) {
  const auto [w, x, y, z] = q;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

// A data3D to write: one station's pose and which points are its.
struct StationData {
  std::string name;
  bool writePose = false;
  std::array<double, 4> rotationWxyz = {1, 0, 0, 0};
  std::array<double, 3> translation = {0, 0, 0};  // in the file's frame (origin included)
  Vec3f position = Vec3f::Zero();                 // in the scan's local frame
  Matrix3 rotation = rotationMatrix({1, 0, 0, 0});
  std::vector<std::uint32_t> indices;  // into the scan's points
  std::uint32_t rowCount = 0, columnCount = 0;

  // R^T v: a direction into the station's frame.
  std::array<double, 3> unrotated(double x, double y, double z) const {
    const Matrix3& r = rotation;
    return {r[0][0] * x + r[1][0] * y + r[2][0] * z, r[0][1] * x + r[1][1] * y + r[2][1] * z,
            r[0][2] * x + r[1][2] * y + r[2][2] * z};
  }
  // A point of the scan's local frame in the station's frame, in double.
  std::array<double, 3> local(const Vec3f& p) const {
    return unrotated(double(p.x()) - position.x(), double(p.y()) - position.y(), double(p.z()) - position.z());
  }
};

std::vector<StationData> splitByStation(const Scan& scan) {
  const PointSet& points = scan.points;
  std::vector<StationData> stations;
  if (scan.stations.empty()) {
    StationData all;
    all.name = "scan";
    all.translation = scan.origin;
    all.writePose = scan.isGeoreferenced();
    all.indices.resize(points.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) all.indices[i] = i;
    stations.push_back(std::move(all));
    return stations;
  }
  for (std::size_t s = 0; s < scan.stations.size(); ++s) {
    const ScanStation& station = scan.stations[s];
    StationData data;
    data.name = station.name.empty() ? fmt::format("scan {}", s) : station.name;
    data.rotationWxyz = station.rotationWxyz;
    data.rotation = rotationMatrix(station.rotationWxyz);
    data.position = station.position;
    for (int axis = 0; axis < 3; ++axis) data.translation[axis] = scan.origin[axis] + station.position[axis];
    data.writePose = station.hasPose || data.translation != std::array<double, 3>{} ||
                     data.rotationWxyz != std::array<double, 4>{1, 0, 0, 0};
    data.rowCount = station.rowCount;
    data.columnCount = station.columnCount;
    data.indices.reserve(station.pointCount);
    stations.push_back(std::move(data));
  }
  APO_CHECK_OP(points.stations.size(), ==, points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    APO_CHECK_OP(points.stations[i], <, stations.size());
    stations[points.stations[i]].indices.push_back(i);
  }
  return stations;
}

// ---------------------------------------------------------------- fields

// One prototype leaf: its XML attributes and its encoded stream.
struct OutField {
  std::string name;
  std::string type;  // "Integer", "ScaledInteger", "Float"
  std::vector<std::pair<std::string, std::string>> attributes;
  int bits = 0;  // per record
  std::string stream;
};

std::string number(double value) { return fmt::format("{}", value); }

// An Integer (or, with a scale, ScaledInteger) field of `count` values,
// value(i) each, declared in [minimum, maximum].
template <class Value>
OutField integerField(std::string name, std::size_t count, std::int64_t minimum, std::int64_t maximum, Value value,
                      std::optional<double> scale = std::nullopt) {
  OutField field;
  field.name = std::move(name);
  field.type = scale ? "ScaledInteger" : "Integer";
  field.attributes = {{"minimum", fmt::format("{}", minimum)}, {"maximum", fmt::format("{}", maximum)}};
  if (scale) field.attributes.emplace_back("scale", number(*scale));
  field.bits = e57::bitsForRange(minimum, maximum);
  BitWriter writer;
  writer.reserve(count / 8 * field.bits + 16);
  for (std::size_t i = 0; i < count; ++i)
    writer.put(static_cast<std::uint64_t>(value(i)) - static_cast<std::uint64_t>(minimum), field.bits);
  field.stream = writer.finish();
  return field;
}

// A single-precision Float field of `count` values, value(i) each.
template <class Value>
OutField floatField(std::string name, std::size_t count, double minimum, double maximum, Value value) {
  OutField field;
  field.name = std::move(name);
  field.type = "Float";
  field.attributes = {{"precision", "single"}, {"minimum", number(minimum)}, {"maximum", number(maximum)}};
  field.bits = 32;
  field.stream.resize(count * sizeof(float));
  for (std::size_t i = 0; i < count; ++i) {
    const float v = value(i);
    std::memcpy(field.stream.data() + 4 * i, &v, 4);  // little-endian machines
  }
  return field;
}

// What a station's data3D says besides its fields.
struct StationSummary {
  std::array<std::array<double, 2>, 3> bounds{};  // of the written (quantised) coordinates
  std::optional<std::array<double, 2>> intensityLimits;
  std::optional<std::array<std::int64_t, 2>> rowRange, columnRange;
  bool hasColor = false;
};

bool isFinite(const std::array<double, 3>& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// A power of ten at most half a float's spacing at the largest coordinate.
double coordinateScale(const Scan& scan, const StationData& station) {
  double largest = 0.0;
  for (const std::uint32_t i : station.indices) {
    const auto p = station.local(scan.points.positions[i]);
    if (isFinite(p)) largest = std::max({largest, std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
  }
  if (largest == 0.0) return 1e-3;
  return std::pow(10.0, std::floor(std::log10(largest * 0x1p-24)));
}

// The coordinate fields (and the invalid state of non-finite positions).
void addCoordinateFields(const Scan& scan, const StationData& station, StationSummary& summary,
                         std::vector<OutField>& fields) {
  const std::size_t n = station.indices.size();
  const double scale = coordinateScale(scan, station);
  // Non-finite positions are written at the lowest corner, marked invalid.
  const auto rawAt = [&](std::size_t i) {
    const auto p = station.local(scan.points.positions[station.indices[i]]);
    if (!isFinite(p)) return std::optional<std::array<std::int64_t, 3>>();
    return std::optional<std::array<std::int64_t, 3>>(std::array<std::int64_t, 3>{
        std::llround(p[0] / scale), std::llround(p[1] / scale), std::llround(p[2] / scale)});
  };
  std::array<std::int64_t, 3> low, high;
  low.fill(std::numeric_limits<std::int64_t>::max());
  high.fill(std::numeric_limits<std::int64_t>::min());
  bool anyInvalid = false;
  for (std::size_t i = 0; i < n; ++i) {
    const auto raw = rawAt(i);
    anyInvalid |= !raw;
    if (!raw) continue;
    for (int axis = 0; axis < 3; ++axis) {
      low[axis] = std::min(low[axis], (*raw)[axis]);
      high[axis] = std::max(high[axis], (*raw)[axis]);
    }
  }
  const char* names[] = {"cartesianX", "cartesianY", "cartesianZ"};
  for (int axis = 0; axis < 3; ++axis) {
    if (low[axis] > high[axis]) low[axis] = high[axis] = 0;  // no finite point
    summary.bounds[axis] = {double(low[axis]) * scale, double(high[axis]) * scale};
    fields.push_back(integerField(
        names[axis], n, low[axis], high[axis],
        [&](std::size_t i) {
          const auto raw = rawAt(i);
          return raw ? (*raw)[axis] : low[axis];
        },
        scale));
  }
  if (anyInvalid)
    fields.push_back(integerField("cartesianInvalidState", n, 0, 2, [&](std::size_t i) { return rawAt(i) ? 0 : 2; }));
}

std::vector<OutField> stationFields(const Scan& scan, const StationData& station, StationSummary& summary) {
  const PointSet& points = scan.points;
  const std::vector<std::uint32_t>& indices = station.indices;
  const std::size_t n = indices.size();
  std::vector<OutField> fields;
  addCoordinateFields(scan, station, summary, fields);
  if (points.hasNormals()) {
    const char* names[] = {"nor:normalX", "nor:normalY", "nor:normalZ"};
    for (int axis = 0; axis < 3; ++axis)
      fields.push_back(floatField(names[axis], n, -1.0, 1.0, [&](std::size_t i) {
        const Vec3f& normal = points.normals[indices[i]];
        return static_cast<float>(station.unrotated(normal.x(), normal.y(), normal.z())[axis]);
      }));
  }
  if (points.hasIntensities()) {
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const std::uint32_t i : indices) {
      if (!std::isfinite(points.intensities[i])) continue;
      low = std::min<double>(low, points.intensities[i]);
      high = std::max<double>(high, points.intensities[i]);
    }
    if (low > high) low = high = 0.0;
    // Readers map intensities by their limits: [0, 1] keeps values already there.
    summary.intensityLimits =
        low >= 0.0 && high <= 1.0 ? std::array<double, 2>{0.0, 1.0} : std::array<double, 2>{low, high};
    fields.push_back(floatField("intensity", n, (*summary.intensityLimits)[0], (*summary.intensityLimits)[1],
                                [&](std::size_t i) { return points.intensities[indices[i]]; }));
  }
  if (points.hasColors()) {
    summary.hasColor = true;
    fields.push_back(integerField("colorRed", n, 0, 255, [&](std::size_t i) { return points.colors[indices[i]].r; }));
    fields.push_back(integerField("colorGreen", n, 0, 255, [&](std::size_t i) { return points.colors[indices[i]].g; }));
    fields.push_back(integerField("colorBlue", n, 0, 255, [&](std::size_t i) { return points.colors[indices[i]].b; }));
  }
  if (points.hasGridIndices()) {
    std::int64_t rowMaximum = std::int64_t{station.rowCount} - 1, columnMaximum = std::int64_t{station.columnCount} - 1;
    for (const std::uint32_t i : indices) {
      rowMaximum = std::max<std::int64_t>(rowMaximum, points.rows[i]);
      columnMaximum = std::max<std::int64_t>(columnMaximum, points.columns[i]);
    }
    rowMaximum = std::max<std::int64_t>(rowMaximum, 0);
    columnMaximum = std::max<std::int64_t>(columnMaximum, 0);
    summary.rowRange = std::array<std::int64_t, 2>{0, rowMaximum};
    summary.columnRange = std::array<std::int64_t, 2>{0, columnMaximum};
    fields.push_back(
        integerField("rowIndex", n, 0, rowMaximum, [&](std::size_t i) { return points.rows[indices[i]]; }));
    fields.push_back(
        integerField("columnIndex", n, 0, columnMaximum, [&](std::size_t i) { return points.columns[indices[i]]; }));
  }
  return fields;
}

// ---------------------------------------------------------------- binary

template <class T>
void putLittle(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian machines
  out.append(bytes, sizeof(T));
}

// Appends to `logical` the compressed vector section of `records` records
// of `fields`.
void appendSection(const std::vector<OutField>& fields, std::uint64_t records, std::string& logical) {
  const std::uint64_t start = logical.size();
  const std::uint64_t packetHeader = e57::kDataPacketHeaderSize + 2 * fields.size();
  int bitsPerRecord = 0;
  for (const OutField& field : fields) bitsPerRecord += field.bits;
  // Records per packet: a multiple of 8 (whole bytes of every stream) that
  // fits the packet with room for its padding to 4 bytes.
  const std::uint64_t room = e57::kMaxPacketSize - packetHeader - 3;
  const std::uint64_t perPacket = std::max<std::uint64_t>(8, room * 8 / std::max(bitsPerRecord, 1) / 8 * 8);

  // The section header, its length set once the packets are written.
  logical.push_back(static_cast<char>(e57::kCompressedVectorSectionId));
  logical.append(7, '\0');
  putLittle<std::uint64_t>(logical, 0);
  putLittle<std::uint64_t>(logical, e57::physicalFromLogical(start + e57::kSectionHeaderSize));
  putLittle<std::uint64_t>(logical, 0);  // no index packets
  std::string packet;
  for (std::uint64_t first = 0; first < records; first += perPacket) {
    const std::uint64_t last = std::min(records, first + perPacket);
    packet.clear();
    packet.push_back(static_cast<char>(e57::kDataPacket));
    packet.push_back(0);  // flags
    putLittle<std::uint16_t>(packet, 0);  // length - 1, set below
    putLittle<std::uint16_t>(packet, static_cast<std::uint16_t>(fields.size()));
    std::vector<std::string_view> slices;
    for (const OutField& field : fields) {
      const std::uint64_t from = first * field.bits / 8, to = (last * field.bits + 7) / 8;
      slices.push_back(std::string_view(field.stream).substr(from, to - from));
      putLittle<std::uint16_t>(packet, static_cast<std::uint16_t>(slices.back().size()));
    }
    for (const std::string_view slice : slices) packet.append(slice);
    packet.resize((packet.size() + 3) / 4 * 4, '\0');
    const auto lengthMinusOne = static_cast<std::uint16_t>(packet.size() - 1);
    std::memcpy(packet.data() + 2, &lengthMinusOne, 2);
    logical += packet;
  }
  const std::uint64_t length = logical.size() - start;
  std::memcpy(logical.data() + start + 8, &length, 8);
}

// ---------------------------------------------------------------- XML

pugi::xml_node addElement(pugi::xml_node parent, const char* name, const char* type) {
  pugi::xml_node node = parent.append_child(name);
  node.append_attribute("type") = type;
  return node;
}

void addFloat(pugi::xml_node parent, const char* name, double value) {
  addElement(parent, name, "Float").text().set(number(value).c_str());
}

void addInteger(pugi::xml_node parent, const char* name, std::int64_t value) {
  addElement(parent, name, "Integer").text().set(fmt::format("{}", value).c_str());
}

void addString(pugi::xml_node parent, const char* name, const std::string& value) {
  addElement(parent, name, "String").append_child(pugi::node_cdata).set_value(value.c_str());
}

// A GUID-shaped name, the same for the same input (files written twice are
// byte-identical): FNV-1a of the words given.
std::string guidOf(std::initializer_list<std::string_view> words) {
  std::uint64_t a = 0xcbf29ce484222325, b = 0x84222325cbf29ce4;
  for (const std::string_view word : words)
    for (const char c : word) {
      a = (a ^ static_cast<unsigned char>(c)) * 0x100000001b3;
      b = (b ^ static_cast<unsigned char>(c)) * 0x100000001b3 + 1;
    }
  return fmt::format("{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}", a >> 32, (a >> 16) & 0xFFFF, a & 0xFFFF, b >> 48,
                     b & 0xFFFFFFFFFFFF);
}

struct WrittenStation {
  const StationData* station;
  StationSummary summary;
  std::vector<OutField> fields;  // streams already written: only their XML
  std::uint64_t fileOffset = 0, records = 0;
};

void addStation(pugi::xml_node data3D, const WrittenStation& written, std::size_t index) {
  const StationData& station = *written.station;
  const StationSummary& summary = written.summary;
  pugi::xml_node scan = addElement(data3D, "vectorChild", "Structure");
  addString(scan, "guid", guidOf({"apo data3D", std::to_string(index), station.name, std::to_string(written.records)}));
  addString(scan, "name", station.name);
  addString(scan, "description", "written by apo");
  if (station.writePose) {
    pugi::xml_node pose = addElement(scan, "pose", "Structure");
    pugi::xml_node rotation = addElement(pose, "rotation", "Structure");
    const char* quaternionNames[] = {"w", "x", "y", "z"};
    for (int i = 0; i < 4; ++i) addFloat(rotation, quaternionNames[i], station.rotationWxyz[i]);
    pugi::xml_node translation = addElement(pose, "translation", "Structure");
    const char* axisNames[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) addFloat(translation, axisNames[i], station.translation[i]);
  }
  pugi::xml_node bounds = addElement(scan, "cartesianBounds", "Structure");
  const char* boundNames[3][2] = {{"xMinimum", "xMaximum"}, {"yMinimum", "yMaximum"}, {"zMinimum", "zMaximum"}};
  for (int axis = 0; axis < 3; ++axis)
    for (int end = 0; end < 2; ++end) addFloat(bounds, boundNames[axis][end], summary.bounds[axis][end]);
  if (summary.intensityLimits) {
    pugi::xml_node limits = addElement(scan, "intensityLimits", "Structure");
    addFloat(limits, "intensityMinimum", (*summary.intensityLimits)[0]);
    addFloat(limits, "intensityMaximum", (*summary.intensityLimits)[1]);
  }
  if (summary.hasColor) {
    pugi::xml_node limits = addElement(scan, "colorLimits", "Structure");
    for (const char* channel : {"Red", "Green", "Blue"}) {
      addInteger(limits, fmt::format("color{}Minimum", channel).c_str(), 0);
      addInteger(limits, fmt::format("color{}Maximum", channel).c_str(), 255);
    }
  }
  if (summary.rowRange) {
    pugi::xml_node index = addElement(scan, "indexBounds", "Structure");
    addInteger(index, "rowMinimum", (*summary.rowRange)[0]);
    addInteger(index, "rowMaximum", (*summary.rowRange)[1]);
    addInteger(index, "columnMinimum", (*summary.columnRange)[0]);
    addInteger(index, "columnMaximum", (*summary.columnRange)[1]);
    addInteger(index, "returnMinimum", 0);
    addInteger(index, "returnMaximum", 0);
  }
  pugi::xml_node points = addElement(scan, "points", "CompressedVector");
  points.append_attribute("fileOffset") = fmt::format("{}", written.fileOffset).c_str();
  points.append_attribute("recordCount") = fmt::format("{}", written.records).c_str();
  pugi::xml_node prototype = addElement(points, "prototype", "Structure");
  for (const OutField& field : written.fields) {
    pugi::xml_node leaf = addElement(prototype, field.name.c_str(), field.type.c_str());
    for (const auto& [name, value] : field.attributes) leaf.append_attribute(name.c_str()) = value.c_str();
  }
  addElement(points, "codecs", "Vector").append_attribute("allowHeterogeneousChildren") = "1";
}

std::string encodeXml(const std::vector<WrittenStation>& stations, bool hasNormals) {
  pugi::xml_document document;
  pugi::xml_node root = addElement(document, "e57Root", "Structure");
  root.append_attribute("xmlns") = e57::kNamespace;
  if (hasNormals) root.append_attribute("xmlns:nor") = "http://www.libe57.org/E57_NOR_surface_normals.txt";
  addString(root, "formatName", "ASTM E57 3D Imaging Data File");
  addString(
      root, "guid",
      guidOf({"apo file", std::to_string(stations.size()), stations.empty() ? "" : stations.front().station->name}));
  addInteger(root, "versionMajor", 1);
  addInteger(root, "versionMinor", 0);
  addString(root, "e57LibraryVersion", "apo");
  addString(root, "coordinateMetadata", "");
  pugi::xml_node data3D = addElement(root, "data3D", "Vector");
  data3D.append_attribute("allowHeterogeneousChildren") = "1";
  for (std::size_t s = 0; s < stations.size(); ++s) addStation(data3D, stations[s], s);
  addElement(root, "images2D", "Vector").append_attribute("allowHeterogeneousChildren") = "1";

  struct StringWriter : pugi::xml_writer {
    std::string text;
    void write(const void* data, std::size_t size) override { text.append(static_cast<const char*>(data), size); }
  } writer;
  document.save(writer, "  ", pugi::format_default, pugi::encoding_utf8);
  return std::move(writer.text);
}

// ---------------------------------------------------------------- pages

std::string fileHeader(std::uint64_t physicalLength, std::uint64_t xmlPhysicalOffset, std::uint64_t xmlLength) {
  std::string header(e57::kSignature, 8);
  putLittle<std::uint32_t>(header, 1);
  putLittle<std::uint32_t>(header, 0);
  putLittle<std::uint64_t>(header, physicalLength);
  putLittle<std::uint64_t>(header, xmlPhysicalOffset);
  putLittle<std::uint64_t>(header, xmlLength);
  putLittle<std::uint64_t>(header, e57::kPageSize);
  return header;
}

// The logical content cut into pages, each sealed with its CRC.
std::string paged(std::string logical) {
  logical.resize((logical.size() + e57::kPageDataSize - 1) / e57::kPageDataSize * e57::kPageDataSize, '\0');
  std::string file;
  file.reserve(logical.size() / e57::kPageDataSize * e57::kPageSize);
  for (std::size_t at = 0; at < logical.size(); at += e57::kPageDataSize) {
    file.append(logical, at, e57::kPageDataSize);
    file.append(e57::kCrcSize, '\0');
  }
  e57::sealPages(file);
  return file;
}

}  // namespace

std::string encodeE57(const Scan& scan) {
  const std::vector<StationData> stations = splitByStation(scan);
  std::string logical(e57::kFileHeaderSize, '\0');
  std::vector<WrittenStation> written;
  for (const StationData& station : stations) {
    WrittenStation entry;
    entry.station = &station;
    entry.records = station.indices.size();
    entry.fields = stationFields(scan, station, entry.summary);
    entry.fileOffset = e57::physicalFromLogical(logical.size());
    std::size_t streamBytes = 0;
    for (const OutField& field : entry.fields) streamBytes += field.stream.size();
    logical.reserve(logical.size() + streamBytes + streamBytes / 64 + e57::kMaxPacketSize);  // with packet headers
    appendSection(entry.fields, entry.records, logical);
    for (OutField& field : entry.fields) std::string().swap(field.stream);  // written: free it
    written.push_back(std::move(entry));
  }
  const std::uint64_t xmlStart = logical.size();
  const std::string xml = encodeXml(written, scan.points.hasNormals());
  logical += xml;
  const std::uint64_t pages = (logical.size() + e57::kPageDataSize - 1) / e57::kPageDataSize;
  const std::string header = fileHeader(pages * e57::kPageSize, e57::physicalFromLogical(xmlStart), xml.size());
  logical.replace(0, header.size(), header);
  return paged(std::move(logical));
}

}  // namespace apo::readers
