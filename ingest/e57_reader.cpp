// E57 (ASTM E2807) 1.0: every scan of /data3D, cartesian or spherical, with
// the bit-pack codec (the one codec writers use), read into one Scan: each
// scan's points moved by its pose (rotation, then translation, in double)
// into the file's common frame and then into the local frame (positions.h);
// each scan a ScanStation; intensity, colour, row and column indices, return
// numbers and surface normals (the libe57.org `nor:` extension) kept.
// Points a scanner marked invalid are skipped and counted. Images, other
// fields and metadata are named in the scan's notes, not read.
//
// The layers, outside in: pages and their CRCs (e57_pages.h), the file
// header and the XML section (parsed with pugixml), then each scan's
// compressed vector section, its packets and bit streams (e57_format.h).
// The records are decoded twice, a packet at a time: once for the local
// frame (LocalFrame), the counts and the grids' sizes, once into the Scan's
// floats; holding every position in double instead would cost more than
// decoding them again. The second pass hands its points on in runs
// (readE57Runs), so that a file larger than memory is read through; the
// whole read is one run.
// Every offset and count the file claims is checked against its size before
// anything is allocated for it; errors name the byte offset or the XML
// element's path (/data3D/0/points/prototype/cartesianX).
#include "ingest/e57_format.h"
#include "ingest/e57_pages.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <pugixml.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace apo::readers {
namespace {

using e57::PagedFile;
using parse::fail;

// ---------------------------------------------------------------- header

struct FileHeader {
  std::uint32_t major = 0, minor = 0;
  std::uint64_t physicalLength = 0, xmlPhysicalOffset = 0, xmlLength = 0, pageSize = 0;
};

template <class T>
T readLittle(std::string_view bytes, std::size_t at) {
  return parse::BinaryCursor(bytes, at).read<T>(false, "E57 field");
}

FileHeader parseFileHeader(std::string_view file) {
  if (file.size() < 8 || file.substr(0, 8) != e57::kSignature)
    fail("byte 0: not an E57 file (no 'ASTM-E57' signature)");
  if (file.size() < e57::kPageSize)
    fail("byte {}: the file ends inside its first {}-byte page (truncated?)", file.size(), e57::kPageSize);
  FileHeader header;
  header.major = readLittle<std::uint32_t>(file, 8);
  header.minor = readLittle<std::uint32_t>(file, 12);
  header.physicalLength = readLittle<std::uint64_t>(file, 16);
  header.xmlPhysicalOffset = readLittle<std::uint64_t>(file, 24);
  header.xmlLength = readLittle<std::uint64_t>(file, 32);
  header.pageSize = readLittle<std::uint64_t>(file, 40);
  if (header.major != 1) fail("byte 8: E57 version {}.{}: apo reads version 1", header.major, header.minor);
  if (header.pageSize != e57::kPageSize)
    fail("byte 40: page size {}: E57 files have {}-byte pages", header.pageSize, e57::kPageSize);
  if (header.physicalLength != file.size())
    fail("byte 16: the header gives the file's length as {} bytes, but it has {} (truncated or padded?)",
         header.physicalLength, file.size());
  return header;
}

// ---------------------------------------------------------------- XML helpers

// An XML element and its path from the root, for messages.
struct Node {
  pugi::xml_node xml;
  std::string path;

  explicit operator bool() const { return bool(xml); }
  Node child(const char* name) const { return {xml.child(name), path + "/" + name}; }
  std::string_view type() const { return xml.attribute("type").value(); }
  std::string_view text() const {
    std::string_view text = xml.text().get();
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
    return text;
  }
};

std::int64_t integerOrFail(std::string_view token, std::int64_t fallback, const std::string& where) {
  if (token.empty()) return fallback;
  std::int64_t value = 0;
  if (!parse::parseInteger(token, value))
    fail("XML element {}: expected an integer, got {}", where, parse::quoted(token));
  return value;
}

double doubleOrFail(std::string_view token, double fallback, const std::string& where) {
  if (token.empty()) return fallback;
  double value = 0;
  if (!parse::parseNumber(token, value)) fail("XML element {}: expected a number, got {}", where, parse::quoted(token));
  return value;
}

std::int64_t integerAttribute(const Node& node, const char* name, std::int64_t fallback) {
  return integerOrFail(node.xml.attribute(name).value(), fallback, fmt::format("{} (attribute {})", node.path, name));
}

double doubleAttribute(const Node& node, const char* name, double fallback) {
  return doubleOrFail(node.xml.attribute(name).value(), fallback, fmt::format("{} (attribute {})", node.path, name));
}

// The value of an Integer, ScaledInteger or Float element (an empty one is
// 0, as the standard has it).
double numberOf(const Node& node) {
  const std::string_view type = node.type();
  if (type == "Integer") return static_cast<double>(integerOrFail(node.text(), 0, node.path));
  if (type == "Float") return doubleOrFail(node.text(), 0.0, node.path);
  if (type == "ScaledInteger")
    return static_cast<double>(integerOrFail(node.text(), 0, node.path)) * doubleAttribute(node, "scale", 1.0) +
           doubleAttribute(node, "offset", 0.0);
  fail("XML element {}: expected an Integer, ScaledInteger or Float element, found type {}", node.path,
       parse::quoted(type));
}

std::optional<double> optionalNumber(const Node& parent, const char* name) {
  const Node node = parent.child(name);
  if (!node) return std::nullopt;
  return numberOf(node);
}

std::string stringOf(const Node& node) { return node ? std::string(node.text()) : std::string(); }

std::vector<Node> childElements(const Node& node) {
  std::vector<Node> children;
  std::size_t index = 0;
  for (pugi::xml_node child : node.xml.children()) {
    if (child.type() != pugi::node_element) continue;
    // Vector children are numbered, Structure children named.
    const bool numbered = node.type() == "Vector";
    children.push_back({child, node.path + "/" + (numbered ? std::to_string(index) : std::string(child.name()))});
    ++index;
  }
  return children;
}

// ---------------------------------------------------------------- prototype

enum class Codec { Integer, ScaledInteger, Float32, Float64 };

// What a prototype leaf means to apo; Other fields are checked and skipped.
enum class Role {
  X, Y, Z, Range, Azimuth, Elevation, CartesianInvalid, SphericalInvalid, Intensity, Red, Green, Blue, Row, Column,
  ReturnIndex, ReturnCount, NormalX, NormalY, NormalZ, Other, Count
};

struct RoleName {
  const char* name;
  Role role;
};
constexpr RoleName kRoleNames[] = {
    {"cartesianX", Role::X},
    {"cartesianY", Role::Y},
    {"cartesianZ", Role::Z},
    {"sphericalRange", Role::Range},
    {"sphericalAzimuth", Role::Azimuth},
    {"sphericalElevation", Role::Elevation},
    {"cartesianInvalidState", Role::CartesianInvalid},
    {"sphericalInvalidState", Role::SphericalInvalid},
    {"intensity", Role::Intensity},
    {"colorRed", Role::Red},
    {"colorGreen", Role::Green},
    {"colorBlue", Role::Blue},
    {"rowIndex", Role::Row},
    {"columnIndex", Role::Column},
    {"returnIndex", Role::ReturnIndex},
    {"returnCount", Role::ReturnCount},
    {"nor:normalX", Role::NormalX},
    {"nor:normalY", Role::NormalY},
    {"nor:normalZ", Role::NormalZ},
};

// One leaf of the prototype: one value per record, in its own bit stream.
struct Field {
  std::string name;  // relative to the prototype: "cartesianX", "las:pointSourceId"
  std::string path;  // for messages
  Role role = Role::Other;
  Codec codec = Codec::Integer;
  int bits = 0;  // per value in the stream
  std::int64_t minimum = 0, maximum = 0;
  double scale = 1.0, offset = 0.0;
  // The declared range of the values, for limits the file does not give
  // elsewhere (Float fields: their minimum and maximum attributes, if any).
  std::optional<std::array<double, 2>> declared;
};

Role roleOf(const std::string& name) {
  for (const RoleName& entry : kRoleNames)
    if (name == entry.name) return entry.role;
  return Role::Other;
}

Field fieldOf(const Node& node, const std::string& name) {
  Field field;
  field.name = name;
  field.path = node.path;
  field.role = roleOf(name);
  const std::string_view type = node.type();
  if (type == "Integer" || type == "ScaledInteger") {
    field.codec = type == "Integer" ? Codec::Integer : Codec::ScaledInteger;
    field.minimum = integerAttribute(node, "minimum", std::numeric_limits<std::int64_t>::min());
    field.maximum = integerAttribute(node, "maximum", std::numeric_limits<std::int64_t>::max());
    if (field.minimum > field.maximum)
      fail("XML element {}: minimum {} is above maximum {}", node.path, field.minimum, field.maximum);
    if (field.codec == Codec::ScaledInteger) {
      field.scale = doubleAttribute(node, "scale", 1.0);
      field.offset = doubleAttribute(node, "offset", 0.0);
      if (!std::isfinite(field.scale) || field.scale == 0.0 || !std::isfinite(field.offset))
        fail("XML element {}: scale {} and offset {} must be finite, the scale non-zero", node.path, field.scale,
             field.offset);
    }
    field.bits = e57::bitsForRange(field.minimum, field.maximum);
    field.declared = std::array<double, 2>{static_cast<double>(field.minimum) * field.scale + field.offset,
                                           static_cast<double>(field.maximum) * field.scale + field.offset};
    return field;
  }
  if (type == "Float") {
    const std::string_view precision = node.xml.attribute("precision").value();
    if (precision != "" && precision != "single" && precision != "double")
      fail("XML element {}: precision {}: E57 floats are 'single' or 'double'", node.path, parse::quoted(precision));
    field.codec = precision == "single" ? Codec::Float32 : Codec::Float64;
    field.bits = precision == "single" ? 32 : 64;
    if (node.xml.attribute("minimum") && node.xml.attribute("maximum"))
      field.declared =
          std::array<double, 2>{doubleAttribute(node, "minimum", 0.0), doubleAttribute(node, "maximum", 0.0)};
    return field;
  }
  fail("XML element {}: a {} field in a prototype: apo reads Integer, ScaledInteger and Float fields", node.path,
       parse::quoted(type));
}

// The prototype's leaves depth first: the order of the bit streams.
void collectFields(const Node& node, const std::string& prefix, int depth, std::vector<Field>& fields) {
  constexpr int kMaxDepth = 16;  // real prototypes nest one or two levels; this bounds the recursion
  if (depth > kMaxDepth) fail("XML element {}: prototype nested deeper than {} levels", node.path, kMaxDepth);
  for (const Node& child : childElements(node)) {
    const std::string name = prefix + child.xml.name();
    if (child.type() == "Structure" || child.type() == "Vector")
      collectFields(child, name + "/", depth + 1, fields);
    else
      fields.push_back(fieldOf(child, name));
  }
}

void checkCodecs(const Node& points) {
  const Node codecs = points.child("codecs");
  if (!codecs) return;
  for (const Node& codec : childElements(codecs)) {
    bool bitPack = false;
    for (const Node& part : childElements(codec)) bitPack |= std::string_view(part.xml.name()) == "bitPackCodec";
    if (!bitPack)
      fail("XML element {}: a codec other than bitPackCodec: apo reads bit-packed E57 points only", codec.path);
  }
}

// ---------------------------------------------------------------- scans

struct Pose {
  std::array<double, 4> rotationWxyz = {1, 0, 0, 0};
  std::array<double, 3> translation = {0, 0, 0};
  std::array<std::array<double, 3>, 3> matrix = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  bool identity = true;
};

// A scan as /data3D describes it.
struct ScanHeader {
  std::string path;  // "/data3D/0"
  std::string name;  // its name, else its guid, else its path
  std::uint64_t fileOffset = 0, recordCount = 0;
  std::vector<Field> fields;
  bool hasPose = false;
  Pose pose;
  std::optional<std::array<double, 2>> intensityLimits;
  std::array<std::optional<std::array<double, 2>>, 3> colorLimits;
  std::optional<std::array<double, 2>> rowBounds, columnBounds;
  // In the scan's own frame: x, y, z minimum and maximum; the spherical
  // range's and elevation's (the azimuth's wraps around: not checked).
  std::optional<std::array<std::array<double, 2>, 3>> cartesianBounds;
  std::optional<std::array<double, 2>> rangeBounds, elevationBounds;
  std::vector<std::string> unread;  // its children apo does not read
};

std::optional<std::array<double, 2>> rangeOf(const Node& parent, const char* minimum, const char* maximum) {
  const auto low = optionalNumber(parent, minimum), high = optionalNumber(parent, maximum);
  if (!low || !high) return std::nullopt;
  return std::array<double, 2>{*low, *high};
}

std::array<std::array<double, 3>, 3> rotationMatrix(const std::array<double, 4>& q) {
  const auto [w, x, y, z] = q;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

Pose parsePose(const Node& node, std::vector<std::string>& notes) {
  Pose pose;
  if (const Node rotation = node.child("rotation")) {
    std::array<double, 4> q{};
    const char* names[] = {"w", "x", "y", "z"};
    for (int i = 0; i < 4; ++i) q[i] = optionalNumber(rotation, names[i]).value_or(0.0);
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!std::isfinite(norm) || norm < 1e-9)
      fail("XML element {}: the rotation quaternion ({}, {}, {}, {}) has no direction", rotation.path, q[0], q[1], q[2],
           q[3]);
    // Writers round the quaternion's digits; only a clearly off one is named.
    if (std::abs(norm - 1.0) > 1e-6)
      notes.push_back(fmt::format("{}: rotation quaternion of length {} normalised", rotation.path, norm));
    for (double& component : q) component /= norm;
    pose.rotationWxyz = q;
    pose.matrix = rotationMatrix(q);
  }
  if (const Node translation = node.child("translation")) {
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
      pose.translation[i] = optionalNumber(translation, names[i]).value_or(0.0);
      if (!std::isfinite(pose.translation[i]))
        fail("XML element {}/{}: translation {} is not finite", translation.path, names[i], pose.translation[i]);
    }
  }
  pose.identity = pose.rotationWxyz == std::array<double, 4>{1, 0, 0, 0} && pose.translation == std::array<double, 3>{};
  return pose;
}

std::uint64_t countAttribute(const Node& node, const char* name) {
  const pugi::xml_attribute attribute = node.xml.attribute(name);
  if (!attribute) fail("XML element {}: no {} attribute", node.path, name);
  const std::int64_t value = integerAttribute(node, name, 0);
  if (value < 0) fail("XML element {}: {} {} is negative", node.path, name, value);
  return static_cast<std::uint64_t>(value);
}

constexpr const char* kReadScanChildren[] = {
    "guid", "name", "description", "points", "pose", "cartesianBounds", "sphericalBounds", "intensityLimits",
    "colorLimits", "indexBounds"};

ScanHeader parseScanHeader(const Node& node, std::vector<std::string>& notes) {
  ScanHeader scan;
  scan.path = node.path;
  scan.name = stringOf(node.child("name"));
  if (scan.name.empty()) scan.name = stringOf(node.child("guid"));
  if (scan.name.empty()) scan.name = node.path;
  const Node points = node.child("points");
  if (!points) fail("XML element {}: no points", node.path);
  if (points.type() != "CompressedVector")
    fail("XML element {}: type {}, not CompressedVector", points.path, parse::quoted(points.type()));
  scan.fileOffset = countAttribute(points, "fileOffset");
  scan.recordCount = countAttribute(points, "recordCount");
  const Node prototype = points.child("prototype");
  if (!prototype) fail("XML element {}: no prototype", points.path);
  collectFields(prototype, "", 0, scan.fields);
  checkCodecs(points);
  if (const Node pose = node.child("pose")) {
    scan.hasPose = true;
    scan.pose = parsePose(pose, notes);
  }
  if (const Node limits = node.child("intensityLimits"))
    scan.intensityLimits = rangeOf(limits, "intensityMinimum", "intensityMaximum");
  if (const Node limits = node.child("colorLimits")) {
    scan.colorLimits[0] = rangeOf(limits, "colorRedMinimum", "colorRedMaximum");
    scan.colorLimits[1] = rangeOf(limits, "colorGreenMinimum", "colorGreenMaximum");
    scan.colorLimits[2] = rangeOf(limits, "colorBlueMinimum", "colorBlueMaximum");
  }
  if (const Node bounds = node.child("indexBounds")) {
    scan.rowBounds = rangeOf(bounds, "rowMinimum", "rowMaximum");
    scan.columnBounds = rangeOf(bounds, "columnMinimum", "columnMaximum");
  }
  if (const Node bounds = node.child("cartesianBounds")) {
    const auto x = rangeOf(bounds, "xMinimum", "xMaximum"), y = rangeOf(bounds, "yMinimum", "yMaximum"),
               z = rangeOf(bounds, "zMinimum", "zMaximum");
    if (x && y && z) scan.cartesianBounds = std::array<std::array<double, 2>, 3>{*x, *y, *z};
  }
  if (const Node bounds = node.child("sphericalBounds")) {
    scan.rangeBounds = rangeOf(bounds, "rangeMinimum", "rangeMaximum");
    scan.elevationBounds = rangeOf(bounds, "elevationMinimum", "elevationMaximum");
  }
  for (const Node& child : childElements(node)) {
    const std::string_view name = child.xml.name();
    if (std::find(std::begin(kReadScanChildren), std::end(kReadScanChildren), name) == std::end(kReadScanChildren))
      scan.unread.emplace_back(name);
  }
  return scan;
}

// ---------------------------------------------------------------- binary section

// A scan's compressed vector section, checked: where its packets run.
struct Section {
  std::uint64_t firstPacket = 0, end = 0;  // logical
};

// The record count against what the section can hold, before anything is
// allocated: a claim of 10^11 records in a small file stops here.
void checkRecordCount(const ScanHeader& scan, std::uint64_t sectionLength) {
  std::uint64_t bitsPerRecord = 0;
  for (const Field& field : scan.fields) bitsPerRecord += field.bits;
  // Records of constant fields take no bits; they still become points, so
  // they are held to one per bit of the section.
  const std::uint64_t limit = sectionLength * 8 / std::max<std::uint64_t>(bitsPerRecord, 1);
  if (scan.recordCount > limit)
    fail("byte {}: {}/points claims {} records of {} bits, but its section of {} bytes holds at most {}",
         scan.fileOffset, scan.path, scan.recordCount, bitsPerRecord, sectionLength, limit);
}

std::string sectionName(const ScanHeader& scan) { return scan.path + "/points' compressed vector section"; }

Section locateSection(const PagedFile& file, const ScanHeader& scan) {
  // Writers give a scan without records no section (fileOffset 0).
  if (scan.recordCount == 0 && scan.fileOffset == 0) return {};
  const std::string what = sectionName(scan);
  const std::uint64_t start = file.logicalFromPhysical(scan.fileOffset, what);
  std::string header;
  file.append(start, e57::kSectionHeaderSize, header, what + " header");
  const auto id = static_cast<std::uint8_t>(header[0]);
  if (id != e57::kCompressedVectorSectionId)
    fail("byte {}: {} has section id {}, not {} (a compressed vector section)", scan.fileOffset, what, id,
         e57::kCompressedVectorSectionId);
  const auto length = readLittle<std::uint64_t>(header, 8);
  const auto dataPhysical = readLittle<std::uint64_t>(header, 16);
  if (length < e57::kSectionHeaderSize || length > file.logicalSize() - start)
    fail("byte {}: {}: section length {} is outside [{}, {}] (the file's end)", scan.fileOffset + 8, what, length,
         e57::kSectionHeaderSize, file.logicalSize() - start);
  checkRecordCount(scan, length);
  Section section{start + length, start + length};
  if (scan.recordCount == 0) return section;
  section.firstPacket = file.logicalFromPhysical(dataPhysical, what + "'s first data packet");
  if (section.firstPacket < start + e57::kSectionHeaderSize || section.firstPacket > section.end)
    fail("byte {}: {}: its first data packet at byte {} lies outside the section", scan.fileOffset + 16, what,
         dataPhysical);
  return section;
}

// ---------------------------------------------------------------- decoding

// Bytes kept after a stream's data, so that the decoder may load whole words
// at its end.
constexpr std::size_t kStreamPadding = 16;
constexpr std::size_t kBatch = 4096;

// One field's bit stream as far as the packets read so far carry it: the
// bytes not yet consumed, then kStreamPadding zero bytes.
struct StreamBuffer {
  std::string bytes = std::string(kStreamPadding, '\0');
  std::uint64_t bit = 0;  // the first bit not consumed

  std::uint64_t bitsLeft() const { return (bytes.size() - kStreamPadding) * 8 - bit; }
  // Appends a packet's bytestream, first dropping the bytes consumed.
  void refill(const PagedFile& file, std::uint64_t at, std::uint64_t count) {
    bytes.resize(bytes.size() - kStreamPadding);
    bytes.erase(0, bit / 8);
    bit %= 8;
    file.append(at, count, bytes, "bytestream");
    bytes.append(kStreamPadding, '\0');
  }
};

// Decodes `count` values of `field` from `stream` as doubles (integers of up
// to 53 bits exactly: row, column, colour, state). The codec is chosen per
// batch, not per value, and the loops load whole words.
void decodeValues(const Field& field, StreamBuffer& stream, std::size_t count, double* out) {
  const char* data = stream.bytes.data();
  std::uint64_t bit = stream.bit;
  stream.bit += count * field.bits;
  if (field.codec == Codec::Float32 || field.codec == Codec::Float64) {
    // Float streams hold only whole floats: byte-aligned.
    const char* at = data + bit / 8;
    if (field.codec == Codec::Float32) {
      for (std::size_t i = 0; i < count; ++i) {
        float value;
        std::memcpy(&value, at + 4 * i, 4);
        out[i] = value;
      }
    } else {
      std::memcpy(out, at, 8 * count);
    }
    return;
  }
  const int bits = field.bits;
  const auto minimum = static_cast<std::uint64_t>(field.minimum);
  const double scale = field.scale, offset = field.offset;
  const auto value = [&](std::uint64_t raw) {
    return static_cast<double>(static_cast<std::int64_t>(minimum + raw)) * scale + offset;
  };
  const std::uint64_t mask = bits == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
  if (bits == 0) {
    std::fill(out, out + count, value(0));
  } else if (bits <= 56) {
    // One unaligned load holds the value: it starts within the word's first byte.
    for (std::size_t i = 0; i < count; ++i, bit += bits) {
      std::uint64_t word;
      std::memcpy(&word, data + bit / 8, 8);
      out[i] = value((word >> (bit % 8)) & mask);
    }
  } else {
    for (std::size_t i = 0; i < count; ++i, bit += bits) {
      std::uint64_t low, high;
      std::memcpy(&low, data + bit / 8, 8);
      std::memcpy(&high, data + bit / 8 + 8, 8);
      const int shift = static_cast<int>(bit % 8);
      out[i] = value((shift == 0 ? low : (low >> shift) | (high << (64 - shift))) & mask);
    }
  }
}

// A scan's records, decoded a batch at a time as its packets come: memory
// for one packet per field, not for the whole scan. Fields not asked for are
// stepped over.
class RecordReader {
 public:
  RecordReader(const PagedFile& file, const ScanHeader& scan, const Section& section, const std::vector<bool>& decoded)
      : file_(file),
        scan_(scan),
        at_(section.firstPacket),
        end_(section.end),
        decoded_(decoded),
        streams_(scan.fields.size()),
        values_(scan.fields.size()),
        lengths_(scan.fields.size()) {
    for (std::size_t i = 0; i < decoded_.size(); ++i)
      if (decoded_[i]) values_[i].resize(kBatch);
  }

  // Decodes the next records, kBatch at most; 0 once every record was.
  std::size_t next() {
    if (done_ == scan_.recordCount) return 0;
    while (available() == 0) readPacket();
    const auto count =
        static_cast<std::size_t>(std::min({std::uint64_t{kBatch}, available(), scan_.recordCount - done_}));
    for (std::size_t i = 0; i < streams_.size(); ++i) {
      if (decoded_[i])
        decodeValues(scan_.fields[i], streams_[i], count, values_[i].data());
      else
        streams_[i].bit += count * scan_.fields[i].bits;
    }
    done_ += count;
    return count;
  }

  const double* values(std::size_t field) const { return values_[field].data(); }

 private:
  // Records every stream holds whole (all of them when no field takes bits).
  std::uint64_t available() const {
    std::uint64_t records = scan_.recordCount - done_;
    for (std::size_t i = 0; i < streams_.size(); ++i)
      if (scan_.fields[i].bits > 0) records = std::min(records, streams_[i].bitsLeft() / scan_.fields[i].bits);
    return records;
  }

  // Reads packets up to and including the next data packet into the streams.
  void readPacket() {
    const std::string what = sectionName(scan_);
    for (;;) {
      const std::uint64_t physical = e57::physicalFromLogical(at_);
      if (end_ - at_ < e57::kPacketHeaderSize)
        fail("byte {}: {} ends after {} of its {} records: its bytestreams hold no more", physical, what, done_,
             scan_.recordCount);
      char head[e57::kDataPacketHeaderSize] = {};
      file_.read(at_, e57::kPacketHeaderSize, head, "packet header");
      const auto type = static_cast<std::uint8_t>(head[0]);
      const std::uint64_t length = readLittle<std::uint16_t>(std::string_view(head, 4), 2) + std::uint64_t{1};
      if (length < e57::kPacketHeaderSize || length > end_ - at_)
        fail("byte {}: packet of {} bytes is shorter than its header or runs past the end of {}", physical, length,
             what);
      if (type == e57::kDataPacket) {
        readDataPacket(physical, length);
        at_ += length;
        return;
      }
      if (type != e57::kIndexPacket && type != e57::kEmptyPacket)
        fail("byte {}: packet type {} in {}: E57 packets are index (0), data (1) or empty (2)", physical, type, what);
      at_ += length;
    }
  }

  void readDataPacket(std::uint64_t physical, std::uint64_t length) {
    const std::uint64_t table = e57::kDataPacketHeaderSize + 2 * streams_.size();
    if (length < table) fail("byte {}: data packet of {} bytes is shorter than its own header", physical, length);
    char head[e57::kDataPacketHeaderSize];
    file_.read(at_, e57::kDataPacketHeaderSize, head, "data packet header");
    const auto count = readLittle<std::uint16_t>(std::string_view(head, e57::kDataPacketHeaderSize), 4);
    if (count != streams_.size())
      fail("byte {}: data packet has {} bytestreams, but {}'s prototype has {} fields", physical, count, scan_.path,
           streams_.size());
    lengthBytes_.clear();
    file_.append(at_ + e57::kDataPacketHeaderSize, 2 * streams_.size(), lengthBytes_, "bytestream lengths");
    std::uint64_t total = 0;
    for (std::size_t i = 0; i < lengths_.size(); ++i)
      total += lengths_[i] = readLittle<std::uint16_t>(lengthBytes_, 2 * i);
    if (table + total > length)
      fail("byte {}: data packet's bytestreams ({} bytes) overflow its length {}", physical, total, length);
    std::uint64_t streamAt = at_ + table;
    for (std::size_t i = 0; i < streams_.size(); ++i) {
      streams_[i].refill(file_, streamAt, lengths_[i]);
      streamAt += lengths_[i];
    }
  }

  const PagedFile& file_;
  const ScanHeader& scan_;
  std::uint64_t at_, end_;
  std::vector<bool> decoded_;
  std::vector<StreamBuffer> streams_;
  std::vector<std::vector<double>> values_;
  std::vector<std::uint16_t> lengths_;
  std::string lengthBytes_;
  std::uint64_t done_ = 0;
};

// ---------------------------------------------------------------- assembly

// Where each role's field is in the prototype (-1: absent).
struct FieldIndex {
  std::array<int, static_cast<std::size_t>(Role::Count)> of{};
  FieldIndex() { of.fill(-1); }
  int operator[](Role role) const { return of[static_cast<std::size_t>(role)]; }
  bool has(Role role) const { return (*this)[role] >= 0; }
};

// What a scan's records hold, and so what becomes of them.
struct ScanPlan {
  FieldIndex index;
  bool cartesian = false;
  Role invalidRole = Role::CartesianInvalid;
  bool hasIntensity = false, hasColor = false, hasGrid = false, hasReturns = false, hasNormals = false;
  std::array<Role, 3> coordinates{};
  std::vector<Role> used;  // the fields read into the Scan
};

ScanPlan planScan(const ScanHeader& scan) {
  ScanPlan plan;
  FieldIndex& index = plan.index;
  for (std::size_t i = 0; i < scan.fields.size(); ++i) {
    const Role role = scan.fields[i].role;
    if (role == Role::Other) continue;
    if (index.has(role)) fail("XML element {}: a second {} field", scan.fields[i].path, scan.fields[i].name);
    index.of[static_cast<std::size_t>(role)] = static_cast<int>(i);
  }
  plan.cartesian = index.has(Role::X) && index.has(Role::Y) && index.has(Role::Z);
  const bool spherical = index.has(Role::Range) && index.has(Role::Azimuth) && index.has(Role::Elevation);
  if (!plan.cartesian && !spherical)
    fail("XML element {}/points/prototype: neither cartesianX, Y and Z nor sphericalRange, Azimuth and Elevation",
         scan.path);
  plan.coordinates = plan.cartesian ? std::array<Role, 3>{Role::X, Role::Y, Role::Z}
                                    : std::array<Role, 3>{Role::Range, Role::Azimuth, Role::Elevation};
  plan.invalidRole = plan.cartesian ? Role::CartesianInvalid : Role::SphericalInvalid;
  plan.hasIntensity = index.has(Role::Intensity);
  plan.hasColor = index.has(Role::Red) && index.has(Role::Green) && index.has(Role::Blue);
  plan.hasGrid = index.has(Role::Row) && index.has(Role::Column);
  plan.hasReturns = index.has(Role::ReturnIndex) && index.has(Role::ReturnCount);
  plan.hasNormals = index.has(Role::NormalX) && index.has(Role::NormalY) && index.has(Role::NormalZ);
  for (const Role role : {Role::Row, Role::Column})
    if (index.has(role)) {
      const Field& field = scan.fields[index[role]];
      if (field.codec != Codec::Integer || field.minimum < 0 ||
          field.maximum > std::numeric_limits<std::uint32_t>::max())
        fail("XML element {}: row and column indices are Integers in [0, 2^32)", field.path);
    }
  plan.used.assign(plan.coordinates.begin(), plan.coordinates.end());
  if (index.has(plan.invalidRole)) plan.used.push_back(plan.invalidRole);
  if (plan.hasIntensity) plan.used.push_back(Role::Intensity);
  if (plan.hasColor) plan.used.insert(plan.used.end(), {Role::Red, Role::Green, Role::Blue});
  if (plan.hasGrid) plan.used.insert(plan.used.end(), {Role::Row, Role::Column});
  if (plan.hasReturns) plan.used.insert(plan.used.end(), {Role::ReturnIndex, Role::ReturnCount});
  if (plan.hasNormals) plan.used.insert(plan.used.end(), {Role::NormalX, Role::NormalY, Role::NormalZ});
  return plan;
}

// Which fields a pass decodes: `roles` (absent ones ignored).
std::vector<bool> decodedFields(const ScanHeader& scan, const ScanPlan& plan, const std::vector<Role>& roles) {
  std::vector<bool> decoded(scan.fields.size(), false);
  for (const Role role : roles)
    if (plan.index.has(role)) decoded[plan.index[role]] = true;
  return decoded;
}

// A record's position in its scan's own frame (spherical coordinates
// converted), then moved by the scan's pose into the file's frame.
std::array<double, 3> inScanFrame(bool cartesian, double a, double b, double c) {
  if (cartesian) return {a, b, c};
  const double range = a, azimuth = b, elevation = c;
  return {range * std::cos(elevation) * std::cos(azimuth), range * std::cos(elevation) * std::sin(azimuth),
          range * std::sin(elevation)};
}

std::array<double, 3> posed(const Pose& pose, const std::array<double, 3>& p) {
  if (pose.identity) return p;
  const auto& r = pose.matrix;
  return {r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2] + pose.translation[0],
          r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2] + pose.translation[1],
          r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2] + pose.translation[2]};
}

// Outside [minimum, maximum] by more than the rounding of their digits.
bool outside(const std::array<double, 2>& range, double value) {
  return !(value >= range[0] - 1e-6 * (1 + std::abs(range[0])) && value <= range[1] + 1e-6 * (1 + std::abs(range[1])));
}

// A record outside the bounds its scan declares, in the scan's own frame.
bool outsideDeclaredBounds(const ScanHeader& scan, bool cartesian, double a, double c,
                           const std::array<double, 3>& local) {
  bool out = false;
  if (scan.cartesianBounds)
    for (int axis = 0; axis < 3; ++axis) out |= outside((*scan.cartesianBounds)[axis], local[axis]);
  if (!cartesian && scan.rangeBounds) out |= outside(*scan.rangeBounds, a);
  if (!cartesian && scan.elevationBounds) out |= outside(*scan.elevationBounds, c);
  return out;
}

// A linear map of a scan's raw values onto apo's range ([0, 1] intensities,
// 0-255 colours), from the limits the file declares.
struct LinearMap {
  double minimum = 0.0, factor = 1.0;
  double operator()(double value) const { return (value - minimum) * factor; }
};

// The limits a scan declares for a field: its own element (intensityLimits,
// colorLimits) first, else the field's declared range.
std::optional<std::array<double, 2>> limitsOf(const std::optional<std::array<double, 2>>& declared,
                                              const Field& field) {
  if (declared) return declared;
  return field.declared;
}

LinearMap mapOnto(const std::optional<std::array<double, 2>>& limits, double top) {
  if (!limits || !std::isfinite((*limits)[0]) || !std::isfinite((*limits)[1])) return {0.0, 1.0};
  const double span = (*limits)[1] - (*limits)[0];
  return {(*limits)[0], span > 0.0 ? top / span : 0.0};
}

std::string describeLimits(const std::optional<std::array<double, 2>>& limits) {
  if (!limits) return "none declared: raw values kept";
  return fmt::format("[{}, {}]", (*limits)[0], (*limits)[1]);
}

// A scan as the first pass found it.
struct ScanTally {
  std::uint64_t valid = 0, directionOnly = 0, invalid = 0, outsideBounds = 0;
  std::uint32_t rows = 0, columns = 0;  // the valid points' grid: largest index + 1
};

// Records decoded between the times the first pass lets the file's pages go.
constexpr std::size_t kGiveBackRecords = std::size_t{1} << 20;

// First pass: the valid records' positions into the frame, the others
// counted, the grid's size found.
ScanTally measureScan(const PagedFile& file, const ScanHeader& scan, const Section& section, const ScanPlan& plan,
                      LocalFrame& frame, const std::function<void()>& giveBack) {
  std::vector<Role> roles(plan.coordinates.begin(), plan.coordinates.end());
  roles.push_back(plan.invalidRole);
  if (plan.hasGrid) roles.insert(roles.end(), {Role::Row, Role::Column});
  RecordReader reader(file, scan, section, decodedFields(scan, plan, roles));
  const int invalidField = plan.index[plan.invalidRole];
  ScanTally tally;
  std::size_t sinceGiveBack = 0;
  while (const std::size_t count = reader.next()) {
    if ((sinceGiveBack += count) >= kGiveBackRecords) {
      giveBack();
      sinceGiveBack = 0;
    }
    const double* a = reader.values(plan.index[plan.coordinates[0]]);
    const double* b = reader.values(plan.index[plan.coordinates[1]]);
    const double* c = reader.values(plan.index[plan.coordinates[2]]);
    const double* state = invalidField >= 0 ? reader.values(invalidField) : nullptr;
    for (std::size_t i = 0; i < count; ++i) {
      if (state && state[i] != 0.0) {
        ++(state[i] == 1.0 ? tally.directionOnly : tally.invalid);
        continue;
      }
      const auto local = inScanFrame(plan.cartesian, a[i], b[i], c[i]);
      // Declared bounds are in the scan's own frame: checked before the pose.
      tally.outsideBounds += outsideDeclaredBounds(scan, plan.cartesian, a[i], c[i], local);
      const auto world = posed(scan.pose, local);
      frame.include(world[0], world[1], world[2]);
      ++tally.valid;
      if (plan.hasGrid) {
        // planScan held row and column to [0, 2^32).
        tally.rows = std::max(tally.rows, static_cast<std::uint32_t>(reader.values(plan.index[Role::Row])[i]) + 1);
        tally.columns =
            std::max(tally.columns, static_cast<std::uint32_t>(reader.values(plan.index[Role::Column])[i]) + 1);
      }
    }
  }
  return tally;
}

// Per-point attributes that some scans have and others may not: the points
// of scans without one get zeros (with a note) once any scan has it.
template <class T>
void catchUp(std::vector<T>& values, std::size_t size) {
  if (values.size() < size) values.resize(size, T{});
}

// Second pass: the valid records into `run`, in the frame; `emit` is called
// whenever the run holds `runPoints` points (it hands the run on and empties
// it), so that a run may end inside a scan and hold the end of one and the
// start of the next.
void decodeScan(const PagedFile& file, const ScanHeader& scan, const Section& section, const ScanPlan& plan,
                const LocalFrame& frame, std::uint16_t station, std::uint64_t runPoints,
                const std::function<void()>& emit, Scan& run) {
  const FieldIndex& index = plan.index;
  const Field& intensityField = scan.fields[std::max(index[Role::Intensity], 0)];
  const LinearMap intensityMap =
      plan.hasIntensity ? mapOnto(limitsOf(scan.intensityLimits, intensityField), 1.0) : LinearMap{};
  const std::array<Role, 3> colorRoles = {Role::Red, Role::Green, Role::Blue};
  std::array<LinearMap, 3> colorMaps;
  if (plan.hasColor)
    for (int c = 0; c < 3; ++c)
      colorMaps[c] = mapOnto(limitsOf(scan.colorLimits[c], scan.fields[index[colorRoles[c]]]), 255.0);

  PointSet& points = run.points;
  // Attributes this scan has and the run's earlier points (another scan's)
  // may not: zeros for those, as completeRun gives the rest.
  const auto catchUpPresent = [&] {
    const std::size_t before = points.size();
    if (plan.hasIntensity) catchUp(points.intensities, before);
    if (plan.hasColor) catchUp(points.colors, before);
    if (plan.hasGrid) {
      catchUp(points.rows, before);
      catchUp(points.columns, before);
    }
    if (plan.hasReturns) {
      catchUp(points.returnNumbers, before);
      catchUp(points.returnCounts, before);
    }
  };
  catchUpPresent();

  RecordReader reader(file, scan, section, decodedFields(scan, plan, plan.used));
  const auto values = [&](Role role) { return reader.values(index[role]); };
  const auto& r = scan.pose.matrix;
  const int invalidField = index[plan.invalidRole];
  while (const std::size_t count = reader.next()) {
    const double* a = values(plan.coordinates[0]);
    const double* b = values(plan.coordinates[1]);
    const double* c = values(plan.coordinates[2]);
    const double* state = invalidField >= 0 ? reader.values(invalidField) : nullptr;
    for (std::size_t i = 0; i < count; ++i) {
      if (state && state[i] != 0.0) continue;
      const auto world = posed(scan.pose, inScanFrame(plan.cartesian, a[i], b[i], c[i]));
      points.positions.push_back(frame.local(world[0], world[1], world[2]));
      points.stations.push_back(station);
      if (plan.hasIntensity) points.intensities.push_back(static_cast<float>(intensityMap(values(Role::Intensity)[i])));
      if (plan.hasColor) {
        std::array<std::uint8_t, 3> rgb;
        for (int k = 0; k < 3; ++k)
          rgb[k] =
              static_cast<std::uint8_t>(std::clamp(std::round(colorMaps[k](values(colorRoles[k])[i])), 0.0, 255.0));
        points.colors.push_back({rgb[0], rgb[1], rgb[2]});
      }
      if (plan.hasGrid) {
        points.rows.push_back(static_cast<std::uint32_t>(values(Role::Row)[i]));
        points.columns.push_back(static_cast<std::uint32_t>(values(Role::Column)[i]));
      }
      if (plan.hasReturns) {
        // E57 counts returns from 0, LAS (and PointSet) from 1.
        points.returnNumbers.push_back(
            static_cast<std::uint8_t>(std::clamp(values(Role::ReturnIndex)[i] + 1.0, 0.0, 255.0)));
        points.returnCounts.push_back(static_cast<std::uint8_t>(std::clamp(values(Role::ReturnCount)[i], 0.0, 255.0)));
      }
      if (plan.hasNormals) {
        const double nx = values(Role::NormalX)[i], ny = values(Role::NormalY)[i], nz = values(Role::NormalZ)[i];
        points.normals.emplace_back(static_cast<float>(r[0][0] * nx + r[0][1] * ny + r[0][2] * nz),
                                    static_cast<float>(r[1][0] * nx + r[1][1] * ny + r[1][2] * nz),
                                    static_cast<float>(r[2][0] * nx + r[2][1] * ny + r[2][2] * nz));
      }
      if (points.size() >= runPoints) emit();
    }
  }
}

// The scan's station: its pose, its grid's size (from its points' indices,
// else from its indexBounds) and its count of points.
ScanStation stationOf(const ScanHeader& scan, const ScanPlan& plan, const ScanTally& tally) {
  ScanStation station;
  station.name = scan.name;
  station.rotationWxyz = scan.pose.rotationWxyz;
  station.hasPose = scan.hasPose;
  station.pointCount = tally.valid;
  if (plan.hasGrid && tally.valid > 0) {
    station.rowCount = tally.rows;
    station.columnCount = tally.columns;
  } else if (scan.rowBounds && scan.columnBounds) {
    const auto size = [](double maximum) {
      return maximum >= 0.0 && maximum < 4294967295.0 ? static_cast<std::uint32_t>(maximum) + 1 : 0u;
    };
    station.rowCount = size((*scan.rowBounds)[1]);
    station.columnCount = size((*scan.columnBounds)[1]);
  }
  return station;
}

void noteScan(const ScanHeader& scan, const ScanPlan& plan, const ScanTally& tally, std::vector<std::string>& notes) {
  const std::string label = fmt::format("{} ({})", scan.path, scan.name);
  const FieldIndex& index = plan.index;
  if (plan.hasIntensity)
    notes.push_back(fmt::format("{}: intensities mapped to [0, 1] from their limits {}", label,
                                describeLimits(limitsOf(scan.intensityLimits, scan.fields[index[Role::Intensity]]))));
  if (plan.hasColor)
    notes.push_back(fmt::format("{}: colours mapped to 0-255 from their limits {}", label,
                                describeLimits(limitsOf(scan.colorLimits[0], scan.fields[index[Role::Red]]))));
  if (tally.directionOnly + tally.invalid > 0)
    notes.push_back(fmt::format("{}: {} of {} records skipped as invalid ({} with a direction only, {} invalid)", label,
                                tally.directionOnly + tally.invalid, scan.recordCount, tally.directionOnly,
                                tally.invalid));
  if (tally.outsideBounds > 0)
    notes.push_back(
        fmt::format("{}: {} points lie outside its declared cartesianBounds or sphericalBounds (in its own frame)",
                    label, tally.outsideBounds));
  std::vector<std::string> skipped;
  for (const Field& field : scan.fields)
    if (std::find(plan.used.begin(), plan.used.end(), field.role) == plan.used.end()) skipped.push_back(field.name);
  if (!skipped.empty()) notes.push_back(fmt::format("{}: fields not kept: {}", label, fmt::join(skipped, ", ")));
  if (!scan.unread.empty())
    notes.push_back(fmt::format("{}: elements not read: {}", label, fmt::join(scan.unread, ", ")));
}

// The per-point attributes every run carries: those any scan with points
// has (zeros for the other scans' points), and normals only when every scan
// has them (they have no neutral value).
struct FileAttributes {
  bool intensity = false, color = false, grid = false, returns = false, normals = false;
};

// The attributes, and a note for each that some scans lack.
FileAttributes attributesOf(const std::vector<ScanHeader>& scans, const std::vector<ScanPlan>& plans,
                            const std::vector<ScanTally>& tallies, std::vector<std::string>& notes) {
  const auto decide = [&](bool ScanPlan::*has, const char* what) {
    std::vector<std::string> lacking;
    bool any = false;
    for (std::size_t s = 0; s < scans.size(); ++s) {
      if (plans[s].*has)
        any |= tallies[s].valid > 0;
      else
        lacking.push_back(fmt::format("{} ({})", scans[s].path, scans[s].name));
    }
    if (any && !lacking.empty())
      notes.push_back(has == &ScanPlan::hasNormals
                          ? fmt::format("normals dropped: {} have none", fmt::join(lacking, ", "))
                          : fmt::format("{} missing in {}: 0 for their points", what, fmt::join(lacking, ", ")));
    return std::pair{any, lacking.empty()};
  };
  FileAttributes attributes;
  attributes.intensity = decide(&ScanPlan::hasIntensity, "intensity").first;
  attributes.color = decide(&ScanPlan::hasColor, "colour").first;
  attributes.grid = decide(&ScanPlan::hasGrid, "row and column indices").first;
  attributes.returns = decide(&ScanPlan::hasReturns, "return numbers").first;
  const auto [normals, everyScan] = decide(&ScanPlan::hasNormals, "normals");
  attributes.normals = normals && everyScan;
  return attributes;
}

// Room for `count` points with the file's attributes: the whole read holds
// each array once, not grown by doubling.
void reserveRun(const FileAttributes& attributes, std::size_t count, PointSet& points) {
  points.positions.reserve(count);
  points.stations.reserve(count);
  if (attributes.intensity) points.intensities.reserve(count);
  if (attributes.color) points.colors.reserve(count);
  if (attributes.grid) {
    points.rows.reserve(count);
    points.columns.reserve(count);
  }
  if (attributes.returns) {
    points.returnNumbers.reserve(count);
    points.returnCounts.reserve(count);
  }
  if (attributes.normals) points.normals.reserve(count);
}

// Every one of the file's attributes for each of the run's points.
void completeRun(const FileAttributes& attributes, PointSet& points) {
  const std::size_t size = points.size();
  const auto complete = [&](auto& values, bool present) {
    if (present)
      catchUp(values, size);
    else
      values.clear();
  };
  complete(points.intensities, attributes.intensity);
  complete(points.colors, attributes.color);
  complete(points.rows, attributes.grid);
  complete(points.columns, attributes.grid);
  complete(points.returnNumbers, attributes.returns);
  complete(points.returnCounts, attributes.returns);
  if (!attributes.normals) points.normals.clear();
}

// ---------------------------------------------------------------- root

constexpr const char* kReadRootChildren[] = {
    "formatName", "guid", "versionMajor", "versionMinor", "e57LibraryVersion", "creationDateTime",
    "coordinateMetadata", "data3D", "images2D"};

void noteUnreadRoot(const Node& root, std::vector<std::string>& notes) {
  const std::string metadata = stringOf(root.child("coordinateMetadata"));
  if (!metadata.empty())
    notes.push_back(fmt::format("coordinateMetadata (the coordinate reference system) not interpreted: {}",
                                parse::quoted(metadata)));
  if (const Node images = root.child("images2D")) {
    const std::vector<Node> children = childElements(images);
    std::set<std::string> kinds;
    for (const Node& image : children)
      for (const Node& part : childElements(image)) {
        const std::string name = part.xml.name();
        if (name.size() > 14 && name.ends_with("Representation")) kinds.insert(name.substr(0, name.size() - 14));
      }
    if (!children.empty())
      notes.push_back(fmt::format("{} images2D ({}) not read", children.size(), fmt::join(kinds, ", ")));
  }
  std::vector<std::string> unread;
  for (const Node& child : childElements(root)) {
    const std::string_view name = child.xml.name();
    if (std::find(std::begin(kReadRootChildren), std::end(kReadRootChildren), name) == std::end(kReadRootChildren))
      unread.emplace_back(name);
  }
  if (!unread.empty()) notes.push_back(fmt::format("elements not read: {}", fmt::join(unread, ", ")));
}

void parseXml(const PagedFile& file, const FileHeader& header, std::string& text, pugi::xml_document& document) {
  const std::uint64_t start = file.logicalFromPhysical(header.xmlPhysicalOffset, "the XML section (header byte 24)");
  file.append(start, header.xmlLength, text, "the XML section");
  const pugi::xml_parse_result result =
      document.load_buffer_inplace(text.data(), text.size(), pugi::parse_default, pugi::encoding_utf8);
  if (!result)
    fail("byte {}: the XML section is not well-formed: {} (its byte {})",
         e57::physicalFromLogical(start + static_cast<std::uint64_t>(std::max<std::ptrdiff_t>(result.offset, 0))),
         result.description(), result.offset);
}

std::string scansWord(std::size_t count) { return fmt::format("{} scan{}", count, count == 1 ? "" : "s"); }

// Each scan's count was checked against its own section; scans that share
// one (or claim overlapping ones) could still add up to far more points
// than the file holds, so their sum is held to the file too: at least one
// bit a record.
void checkTotalRecords(const PagedFile& file, const std::vector<ScanHeader>& scans) {
  std::uint64_t claimedBytes = 0;
  for (const ScanHeader& scan : scans) {
    std::uint64_t bitsPerRecord = 0;
    for (const Field& field : scan.fields) bitsPerRecord += field.bits;
    // Within one section's bits each (checkRecordCount): no overflow.
    claimedBytes += (scan.recordCount / 8) * std::max<std::uint64_t>(bitsPerRecord, 1);
    if (claimedBytes > file.logicalSize())
      fail("XML element /data3D: the scans' records up to {} claim more bytes than the file's {}", scan.path,
           file.logicalSize());
  }
}

// The file's scans as /data3D describes them, each with its plan and its
// section; the XML document lives in `xmlText` and `document`.
struct Description {
  std::vector<ScanHeader> scans;
  std::vector<ScanPlan> plans;
  std::vector<Section> sections;
  std::vector<std::string> notes;      // the scans' (their poses')
  std::vector<std::string> rootNotes;  // what the root holds that apo does not read
};

Description describe(const PagedFile& file, const FileHeader& header, std::string& xmlText,
                     pugi::xml_document& document) {
  parseXml(file, header, xmlText, document);
  const Node root{document.child("e57Root"), ""};
  if (!root) fail("XML element /e57Root: missing: the XML section is not an E57 description");
  const Node data3D = root.child("data3D");
  if (!data3D) fail("XML element /data3D: missing: the file holds no scans");
  const std::vector<Node> nodes = childElements(data3D);
  if (nodes.size() > std::numeric_limits<std::uint16_t>::max())
    fail("XML element /data3D: {} scans: apo reads at most {}", nodes.size(),
         std::numeric_limits<std::uint16_t>::max());
  Description description;
  for (const Node& node : nodes) {
    description.scans.push_back(parseScanHeader(node, description.notes));
    description.plans.push_back(planScan(description.scans.back()));
    description.sections.push_back(locateSection(file, description.scans.back()));
  }
  checkTotalRecords(file, description.scans);
  noteUnreadRoot(root, description.rootNotes);
  return description;
}

// The whole read, a run of `runPoints` points at a time: the pages' CRCs,
// the XML, a first pass over every record for the frame, the counts and the
// grids' sizes, then a second pass handing each run to `take` with the
// file's frame, its stations and every read note. `giveBack` is called every
// so often: the pages read so far are not needed again soon.
void readScanRuns(std::string_view bytes, std::uint64_t runPoints, const std::function<void(Scan& run)>& take,
                  const std::function<void()>& giveBack) {
  const FileHeader header = parseFileHeader(bytes);
  e57::checkPages(bytes, [&](std::uint64_t) { giveBack(); });
  const PagedFile file(bytes);
  std::string xmlText;
  pugi::xml_document document;
  const Description description = describe(file, header, xmlText, document);
  const std::vector<ScanHeader>& scans = description.scans;
  const std::vector<ScanPlan>& plans = description.plans;

  // First pass: the frame, how many points there are, the grids' sizes.
  Scan run;  // every run's frame, stations and notes; then its points
  run.readNotes = description.notes;
  LocalFrame frame;
  std::vector<ScanTally> tallies;
  std::uint64_t valid = 0, records = 0;
  for (std::size_t s = 0; s < scans.size(); ++s) {
    tallies.push_back(measureScan(file, scans[s], description.sections[s], plans[s], frame, giveBack));
    valid += tallies.back().valid;
    records += scans[s].recordCount;
  }
  if (valid == 0) fail("no points: {} records in {}, none valid", records, scansWord(scans.size()));
  frame.fixInto(run);
  for (std::size_t s = 0; s < scans.size(); ++s) {
    ScanStation station = stationOf(scans[s], plans[s], tallies[s]);
    // Stations in the same local frame as the points.
    for (int axis = 0; axis < 3; ++axis)
      station.position[axis] = static_cast<float>(scans[s].pose.translation[axis] - run.origin[axis]);
    run.stations.push_back(station);
    noteScan(scans[s], plans[s], tallies[s], run.readNotes);
  }
  const FileAttributes attributes = attributesOf(scans, plans, tallies, run.readNotes);
  run.readNotes.insert(run.readNotes.end(), description.rootNotes.begin(), description.rootNotes.end());
  std::vector<std::uint64_t> counts;
  for (const ScanHeader& scan : scans) counts.push_back(scan.recordCount);
  run.readNotes.insert(run.readNotes.begin(), fmt::format("E57 {}.{}: {} ({} records)", header.major, header.minor,
                                                          scansWord(scans.size()), fmt::join(counts, ", ")));

  // Second pass: the points, a run at a time.
  std::uint64_t handed = 0;
  const auto reserveNext = [&] {
    reserveRun(attributes, static_cast<std::size_t>(std::min(runPoints, valid - handed)), run.points);
  };
  reserveNext();
  const auto emit = [&] {
    completeRun(attributes, run.points);
    handed += run.points.size();
    take(run);
    run.points = PointSet();
    if (handed < valid) reserveNext();
    giveBack();
  };
  for (std::size_t s = 0; s < scans.size(); ++s)
    decodeScan(file, scans[s], description.sections[s], plans[s], frame, static_cast<std::uint16_t>(s), runPoints,
               emit, run);
  if (run.points.size() > 0) emit();
}

// Exceptions other than the reader's own failures (a library's) as a
// refusal of the file.
template <class Read>
void refusingOtherErrors(const Read& read) {
  try {
    read();
  } catch (const parse::ParseFailure&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& error) {
    // pugixml reports by return value; anything else a library throws is
    // still a refusal of this file, not a crash.
    fail("the E57 file could not be read: {}", error.what());
  }
}

}  // namespace

Scan readE57(std::string_view bytes) {
  Scan whole;
  refusingOtherErrors([&] {
    readScanRuns(bytes, std::numeric_limits<std::uint64_t>::max(), [&](Scan& run) { whole = std::move(run); }, [] {});
  });
  return whole;
}

std::optional<std::uint64_t> e57RecordCount(std::string_view file) {
  std::optional<std::uint64_t> records;
  try {
    const PagedFile paged(file);
    std::string xmlText;
    pugi::xml_document document;
    const Description description = describe(paged, parseFileHeader(file), xmlText, document);
    records = 0;
    for (const ScanHeader& scan : description.scans) *records += scan.recordCount;
  } catch (const std::exception&) {
    return std::nullopt;  // the whole read says why
  }
  return records;
}

void readE57Runs(std::string_view file, std::uint64_t runPoints, const std::function<void(Scan& run)>& take,
                 const std::function<void()>& giveBack) {
  refusingOtherErrors([&] { readScanRuns(file, runPoints, take, giveBack); });
}

}  // namespace apo::readers
