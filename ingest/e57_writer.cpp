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

// A data3D to write: the points of one station in its frame.
struct StationData {
  std::string name;
  bool writePose = false;
  std::array<double, 4> rotationWxyz = {1, 0, 0, 0};
  std::array<double, 3> translation = {0, 0, 0};  // in the file's frame (origin included)
  std::vector<std::uint32_t> indices;             // into the scan's points
  std::vector<std::array<double, 3>> positions;   // in the station's frame
  std::vector<std::array<float, 3>> normals;      // in the station's frame
  std::uint32_t rowCount = 0, columnCount = 0;
};

using Matrix3 = std::array<std::array<double, 3>, 3>;

Matrix3 rotationMatrix(const std::array<double, 4>& q) {
  const auto [w, x, y, z] = q;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

// R^T v: into the station's frame.
std::array<double, 3> inverseRotate(const Matrix3& r, double x, double y, double z) {
  return {r[0][0] * x + r[1][0] * y + r[2][0] * z, r[0][1] * x + r[1][1] * y + r[2][1] * z,
          r[0][2] * x + r[1][2] * y + r[2][2] * z};
}

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
  } else {
    for (std::size_t s = 0; s < scan.stations.size(); ++s) {
      const ScanStation& station = scan.stations[s];
      StationData data;
      data.name = station.name.empty() ? fmt::format("scan {}", s) : station.name;
      data.rotationWxyz = station.rotationWxyz;
      for (int axis = 0; axis < 3; ++axis) data.translation[axis] = scan.origin[axis] + station.position[axis];
      data.writePose = station.hasPose || data.translation != std::array<double, 3>{} ||
                       data.rotationWxyz != std::array<double, 4>{1, 0, 0, 0};
      data.rowCount = station.rowCount;
      data.columnCount = station.columnCount;
      stations.push_back(std::move(data));
    }
    APO_CHECK_OP(points.stations.size(), ==, points.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      APO_CHECK_OP(points.stations[i], <, stations.size());
      stations[points.stations[i]].indices.push_back(i);
    }
  }
  // Positions (and normals) into each station's frame, in double.
  for (std::size_t s = 0; s < stations.size(); ++s) {
    StationData& data = stations[s];
    const Matrix3 r = rotationMatrix(data.rotationWxyz);
    const Vec3f position = scan.stations.empty() ? Vec3f::Zero() : scan.stations[s].position;
    data.positions.reserve(data.indices.size());
    for (const std::uint32_t i : data.indices) {
      const Vec3f& p = points.positions[i];
      data.positions.push_back(inverseRotate(r, double(p.x()) - position.x(), double(p.y()) - position.y(),
                                             double(p.z()) - position.z()));
    }
    if (points.hasNormals()) {
      data.normals.reserve(data.indices.size());
      for (const std::uint32_t i : data.indices) {
        const Vec3f& n = points.normals[i];
        const auto q = inverseRotate(r, n.x(), n.y(), n.z());
        data.normals.push_back({float(q[0]), float(q[1]), float(q[2])});
      }
    }
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

OutField integerField(std::string name, const std::vector<std::int64_t>& values, std::int64_t minimum,
                      std::int64_t maximum, std::optional<double> scale = std::nullopt) {
  OutField field;
  field.name = std::move(name);
  field.type = scale ? "ScaledInteger" : "Integer";
  field.attributes = {{"minimum", fmt::format("{}", minimum)}, {"maximum", fmt::format("{}", maximum)}};
  if (scale) field.attributes.emplace_back("scale", number(*scale));
  field.bits = e57::bitsForRange(minimum, maximum);
  BitWriter writer;
  writer.reserve(values.size() / 8 * field.bits + 16);
  for (const std::int64_t value : values)
    writer.put(static_cast<std::uint64_t>(value) - static_cast<std::uint64_t>(minimum), field.bits);
  field.stream = writer.finish();
  return field;
}

OutField floatField(std::string name, const std::vector<float>& values, double minimum, double maximum) {
  OutField field;
  field.name = std::move(name);
  field.type = "Float";
  field.attributes = {{"precision", "single"}, {"minimum", number(minimum)}, {"maximum", number(maximum)}};
  field.bits = 32;
  field.stream.resize(values.size() * sizeof(float));
  std::memcpy(field.stream.data(), values.data(), field.stream.size());  // little-endian machines
  return field;
}

// The finite values' range ([0, 0] when there are none).
std::array<double, 2> finiteRange(const std::vector<float>& values) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const float v : values)
    if (std::isfinite(v)) low = std::min<double>(low, v), high = std::max<double>(high, v);
  return low <= high ? std::array<double, 2>{low, high} : std::array<double, 2>{0.0, 0.0};
}

// What a station's data3D says besides its fields.
struct StationSummary {
  std::array<std::array<double, 2>, 3> bounds{};  // of the written (quantised) coordinates
  std::optional<std::array<double, 2>> intensityLimits;
  std::optional<std::array<std::int64_t, 2>> rowRange, columnRange;
};

// A power of ten at most half a float's spacing at the largest coordinate.
double coordinateScale(const std::vector<std::array<double, 3>>& positions) {
  double largest = 0.0;
  for (const auto& p : positions)
    for (const double v : p)
      if (std::isfinite(v)) largest = std::max(largest, std::abs(v));
  if (largest == 0.0) return 1e-3;
  return std::pow(10.0, std::floor(std::log10(largest * 0x1p-24)));
}

std::vector<OutField> stationFields(const Scan& scan, const StationData& station, StationSummary& summary) {
  const PointSet& points = scan.points;
  const std::size_t n = station.indices.size();
  std::vector<OutField> fields;

  // Coordinates: rounded to the scale; non-finite ones marked invalid.
  const double scale = coordinateScale(station.positions);
  std::array<std::vector<std::int64_t>, 3> raw;
  std::vector<std::int64_t> invalid(n, 0);
  bool anyInvalid = false;
  std::array<std::int64_t, 3> low, high;
  low.fill(std::numeric_limits<std::int64_t>::max());
  high.fill(std::numeric_limits<std::int64_t>::min());
  for (auto& axis : raw) axis.resize(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = station.positions[i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      invalid[i] = 2;
      anyInvalid = true;
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      raw[axis][i] = std::llround(p[axis] / scale);
      low[axis] = std::min(low[axis], raw[axis][i]);
      high[axis] = std::max(high[axis], raw[axis][i]);
    }
  }
  for (int axis = 0; axis < 3; ++axis) {
    if (low[axis] > high[axis]) low[axis] = high[axis] = 0;  // no finite point
    for (std::size_t i = 0; i < n; ++i)
      if (invalid[i] != 0) raw[axis][i] = low[axis];
    summary.bounds[axis] = {double(low[axis]) * scale, double(high[axis]) * scale};
  }
  const char* axisNames[] = {"cartesianX", "cartesianY", "cartesianZ"};
  for (int axis = 0; axis < 3; ++axis) fields.push_back(integerField(axisNames[axis], raw[axis], low[axis], high[axis], scale));
  if (anyInvalid) fields.push_back(integerField("cartesianInvalidState", invalid, 0, 2));

  if (points.hasNormals()) {
    const char* names[] = {"nor:normalX", "nor:normalY", "nor:normalZ"};
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<float> values(n);
      for (std::size_t i = 0; i < n; ++i) values[i] = station.normals[i][axis];
      fields.push_back(floatField(names[axis], values, -1.0, 1.0));
    }
  }
  if (points.hasIntensities()) {
    std::vector<float> values(n);
    for (std::size_t i = 0; i < n; ++i) values[i] = points.intensities[station.indices[i]];
    const auto range = finiteRange(values);
    // Readers map intensities by their limits: [0, 1] keeps values already there.
    summary.intensityLimits = range[0] >= 0.0 && range[1] <= 1.0 ? std::array<double, 2>{0.0, 1.0} : range;
    fields.push_back(floatField("intensity", values, (*summary.intensityLimits)[0], (*summary.intensityLimits)[1]));
  }
  if (points.hasColors()) {
    const char* names[] = {"colorRed", "colorGreen", "colorBlue"};
    for (int channel = 0; channel < 3; ++channel) {
      std::vector<std::int64_t> values(n);
      for (std::size_t i = 0; i < n; ++i) {
        const Rgb8& c = points.colors[station.indices[i]];
        values[i] = channel == 0 ? c.r : channel == 1 ? c.g : c.b;
      }
      fields.push_back(integerField(names[channel], values, 0, 255));
    }
  }
  if (points.hasGridIndices()) {
    std::vector<std::int64_t> rows(n), columns(n);
    std::int64_t rowMaximum = std::int64_t{station.rowCount} - 1, columnMaximum = std::int64_t{station.columnCount} - 1;
    for (std::size_t i = 0; i < n; ++i) {
      rows[i] = points.rows[station.indices[i]];
      columns[i] = points.columns[station.indices[i]];
      rowMaximum = std::max(rowMaximum, rows[i]);
      columnMaximum = std::max(columnMaximum, columns[i]);
    }
    rowMaximum = std::max<std::int64_t>(rowMaximum, 0);
    columnMaximum = std::max<std::int64_t>(columnMaximum, 0);
    summary.rowRange = std::array<std::int64_t, 2>{0, rowMaximum};
    summary.columnRange = std::array<std::int64_t, 2>{0, columnMaximum};
    fields.push_back(integerField("rowIndex", rows, 0, rowMaximum));
    fields.push_back(integerField("columnIndex", columns, 0, columnMaximum));
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

// The compressed vector section of `records` records of `fields`, to start
// at logical offset `start`.
std::string encodeSection(const std::vector<OutField>& fields, std::uint64_t records, std::uint64_t start) {
  const std::uint64_t packetHeader = e57::kDataPacketHeaderSize + 2 * fields.size();
  int bitsPerRecord = 0;
  for (const OutField& field : fields) bitsPerRecord += field.bits;
  // Records per packet: a multiple of 8 (whole bytes of every stream) that
  // fits the packet with room for its padding to 4 bytes.
  const std::uint64_t room = e57::kMaxPacketSize - packetHeader - 3;
  const std::uint64_t perPacket = std::max<std::uint64_t>(8, room * 8 / std::max(bitsPerRecord, 1) / 8 * 8);

  std::string packets;
  for (std::uint64_t first = 0; first < records; first += perPacket) {
    const std::uint64_t last = std::min(records, first + perPacket);
    std::string packet;
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
    packets += packet;
  }

  std::string section;
  section.push_back(static_cast<char>(e57::kCompressedVectorSectionId));
  section.append(7, '\0');
  putLittle<std::uint64_t>(section, e57::kSectionHeaderSize + packets.size());
  putLittle<std::uint64_t>(section, e57::physicalFromLogical(start + e57::kSectionHeaderSize));
  putLittle<std::uint64_t>(section, 0);  // no index packets
  return section + packets;
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
  const bool hasColor = std::any_of(written.fields.begin(), written.fields.end(),
                                    [](const OutField& field) { return field.name == "colorRed"; });
  if (hasColor) {
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
  addString(root, "guid", guidOf({"apo file", std::to_string(stations.size()),
                                  stations.empty() ? "" : stations.front().station->name}));
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
    logical += encodeSection(entry.fields, entry.records, logical.size());
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
