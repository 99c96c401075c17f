// PLY reader (ascii, binary_little_endian, binary_big_endian; version 1.0).
// Our own parser rather than PCL's: PCL's loader silently returns zeros for
// double-precision coordinates (../shared/STACK.md, pitfall 2).
//
// The header is parsed into elements and properties, then the body is read
// element by element in header order by one generic routine per element kind
// (vertex, face, anything else skipped), over either an ascii or a binary body
// source. Every count the header or a list claims is checked against the bytes
// that remain before anything is allocated for it.
#include "core/error.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace apo::readers {
namespace {

using parse::fail;

enum class Encoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

enum class ScalarType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<ScalarType> scalarTypeNamed(std::string_view name) {
  struct Named {
    std::string_view name;
    ScalarType type;
  };
  static constexpr Named kTypes[] = {
      {"char", ScalarType::Int8},     {"int8", ScalarType::Int8},       {"uchar", ScalarType::UInt8},
      {"uint8", ScalarType::UInt8},   {"short", ScalarType::Int16},     {"int16", ScalarType::Int16},
      {"ushort", ScalarType::UInt16}, {"uint16", ScalarType::UInt16},   {"int", ScalarType::Int32},
      {"int32", ScalarType::Int32},   {"uint", ScalarType::UInt32},     {"uint32", ScalarType::UInt32},
      {"float", ScalarType::Float32}, {"float32", ScalarType::Float32}, {"double", ScalarType::Float64},
      {"float64", ScalarType::Float64},
  };
  for (const Named& named : kTypes)
    if (named.name == name) return named.type;
  return std::nullopt;
}

std::size_t byteSize(ScalarType type) {
  switch (type) {
    case ScalarType::Int8:
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32: return 4;
    case ScalarType::Float64: return 8;
  }
  APO_CHECK(!"unhandled ScalarType");
  return 0;
}

bool isFloating(ScalarType type) { return type == ScalarType::Float32 || type == ScalarType::Float64; }

struct Property {
  std::string name;
  ScalarType type = ScalarType::Float32;  // of the value, or of each item of a list
  std::optional<ScalarType> listCountType;  // set for list properties only
  bool isList() const { return listCountType.has_value(); }
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  std::size_t line = 0;  // header line declaring it, for messages
};

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::vector<Element> elements;
  std::size_t endLine = 0;  // line of end_header
  // "comment apo_origin X Y Z": apo's own PLY files in a local frame (the
  // writer's), whose origin comes back into Scan::origin.
  std::optional<std::array<double, 3>> origin;
  // Positioned just after end_header: the ascii body continues from it, the
  // binary body starts at its offset.
  parse::TextCursor afterHeader{std::string_view{}};
};

// "vertices", "faces", "edges": element counts in messages.
std::string plural(const std::string& elementName) {
  return elementName == "vertex" ? "vertices" : elementName + "s";
}

// --- Header -----------------------------------------------------------------

void checkMagic(parse::TextCursor& cursor) {
  std::string_view line;
  cursor.next(line);
  std::vector<std::string_view> tokens;
  parse::splitWhitespace(line, tokens);
  if (tokens.size() != 1 || tokens[0] != "ply")
    fail("byte 0: wrong magic: expected 'ply', got {}", parse::quoted(line));
}

Encoding parseFormatLine(const std::vector<std::string_view>& tokens, std::size_t line) {
  if (tokens.size() != 3) fail("line {}: malformed format line, expected 'format ENCODING 1.0'", line);
  double version = 0;
  if (!parse::parseNumber(tokens[2], version) || version != 1.0)
    fail("line {}: unsupported PLY version {} (only 1.0 is defined)", line, parse::quoted(tokens[2]));
  if (tokens[1] == "ascii") return Encoding::Ascii;
  if (tokens[1] == "binary_little_endian") return Encoding::BinaryLittleEndian;
  if (tokens[1] == "binary_big_endian") return Encoding::BinaryBigEndian;
  fail("line {}: unknown format {} (expected ascii, binary_little_endian or binary_big_endian)", line,
       parse::quoted(tokens[1]));
}

Element parseElementLine(const std::vector<std::string_view>& tokens, std::size_t line) {
  if (tokens.size() != 3) fail("line {}: malformed element line, expected 'element NAME COUNT'", line);
  std::int64_t count = 0;
  if (!parse::parseInteger(tokens[2], count))
    fail("line {}: count {} of element '{}' is not an integer", line, parse::quoted(tokens[2]), tokens[1]);
  if (count < 0) fail("line {}: negative count {} for element '{}'", line, count, tokens[1]);
  return {std::string(tokens[1]), static_cast<std::uint64_t>(count), {}, line};
}

ScalarType parseScalarType(std::string_view token, std::size_t line) {
  const std::optional<ScalarType> type = scalarTypeNamed(token);
  if (!type) fail("line {}: unknown property type {}", line, parse::quoted(token));
  return *type;
}

Property parsePropertyLine(const std::vector<std::string_view>& tokens, std::size_t line) {
  if (tokens.size() == 5 && tokens[1] == "list") {
    const ScalarType countType = parseScalarType(tokens[2], line);
    if (isFloating(countType))
      fail("line {}: list count type {} is not an integer type", line, parse::quoted(tokens[2]));
    return {std::string(tokens[4]), parseScalarType(tokens[3], line), countType};
  }
  if (tokens.size() != 3 || tokens[1] == "list")
    fail("line {}: malformed property line, expected 'property TYPE NAME' or "
         "'property list COUNTTYPE ITEMTYPE NAME'",
         line);
  return {std::string(tokens[2]), parseScalarType(tokens[1], line), std::nullopt};
}

std::array<double, 3> parseOriginComment(const std::vector<std::string_view>& tokens, std::size_t line) {
  std::array<double, 3> origin{};
  for (int axis = 0; axis < 3; ++axis)
    if (!parse::parseNumber(tokens[2 + axis], origin[axis]) || !std::isfinite(origin[axis]))
      fail("line {}: apo_origin coordinate {} is not a finite number", line, parse::quoted(tokens[2 + axis]));
  return origin;
}

Header parseHeader(std::string_view bytes) {
  if (bytes.empty()) fail("empty file");
  Header header;
  parse::TextCursor cursor(bytes);
  checkMagic(cursor);
  bool sawFormat = false;
  std::string_view line;
  std::vector<std::string_view> tokens;
  while (cursor.next(line)) {
    parse::splitWhitespace(line, tokens);
    if (tokens.empty()) continue;
    const std::string_view keyword = tokens[0];
    const std::size_t lineNumber = cursor.lineNumber();
    if (keyword == "end_header") {
      if (!sawFormat) fail("line {}: header has no format line", lineNumber);
      header.endLine = lineNumber;
      header.afterHeader = cursor;
      return header;
    }
    if (keyword == "format") {
      header.encoding = parseFormatLine(tokens, lineNumber);
      sawFormat = true;
    } else if (keyword == "element") {
      header.elements.push_back(parseElementLine(tokens, lineNumber));
    } else if (keyword == "property") {
      if (header.elements.empty()) fail("line {}: property declared before any element", lineNumber);
      header.elements.back().properties.push_back(parsePropertyLine(tokens, lineNumber));
    } else if (keyword == "comment" && tokens.size() == 5 && tokens[1] == "apo_origin") {
      header.origin = parseOriginComment(tokens, lineNumber);
    }
    // Other comments, obj_info and unknown lines carry nothing we use.
  }
  fail("line {}: header has no end_header line", cursor.lineNumber());
}

// --- What to keep from the vertex and face elements --------------------------

const Element* findUniqueElement(const Header& header, std::string_view name) {
  const Element* found = nullptr;
  for (const Element& element : header.elements) {
    if (element.name != name) continue;
    if (found) fail("line {}: second '{}' element (first on line {})", element.line, name, found->line);
    found = &element;
  }
  return found;
}

// Index of the first scalar property with one of `names`, in declaration order.
std::optional<std::size_t> findScalar(const Element& element, std::initializer_list<std::string_view> names) {
  for (std::size_t i = 0; i < element.properties.size(); ++i) {
    const Property& property = element.properties[i];
    if (property.isList()) continue;
    for (std::string_view name : names)
      if (property.name == name) return i;
  }
  return std::nullopt;
}

// Where each vertex property's value goes.
enum VertexSlot : std::uint8_t {
  kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kIntensity, kClassification, kReturnNumber, kReturnCount, kSlotCount
};
constexpr std::uint8_t kSkip = kSlotCount;

struct VertexPlan {
  const Element* element = nullptr;
  std::vector<std::uint8_t> slotOfProperty;  // a VertexSlot, or kSkip
  bool normals = false, colors = false, intensities = false, classifications = false, returns = false;
  std::array<ScalarType, 3> colorTypes{};  // red, green, blue: decide scaling
};

VertexPlan planVertices(const Header& header) {
  VertexPlan plan;
  plan.element = findUniqueElement(header, "vertex");
  if (!plan.element) fail("line {}: header declares no vertex element", header.endLine);
  const Element& element = *plan.element;
  if (element.count > std::numeric_limits<std::uint32_t>::max())
    fail("line {}: {} vertices are more than 32-bit face indices can address", element.line, element.count);
  plan.slotOfProperty.assign(element.properties.size(), kSkip);

  for (auto [slot, name] : {std::pair{kX, "x"}, std::pair{kY, "y"}, std::pair{kZ, "z"}}) {
    const auto index = findScalar(element, {name});
    if (!index) fail("line {}: element vertex has no scalar property '{}'", element.line, name);
    plan.slotOfProperty[*index] = slot;
  }

  // Normals and colors are kept only when all three components are present.
  const auto nx = findScalar(element, {"nx"}), ny = findScalar(element, {"ny"}), nz = findScalar(element, {"nz"});
  if (nx && ny && nz) {
    plan.normals = true;
    plan.slotOfProperty[*nx] = kNx;
    plan.slotOfProperty[*ny] = kNy;
    plan.slotOfProperty[*nz] = kNz;
  }
  const auto red = findScalar(element, {"red", "diffuse_red"});
  const auto green = findScalar(element, {"green", "diffuse_green"});
  const auto blue = findScalar(element, {"blue", "diffuse_blue"});
  if (red && green && blue) {
    plan.colors = true;
    plan.slotOfProperty[*red] = kRed;
    plan.slotOfProperty[*green] = kGreen;
    plan.slotOfProperty[*blue] = kBlue;
    plan.colorTypes = {element.properties[*red].type, element.properties[*green].type,
                       element.properties[*blue].type};
  }
  if (const auto intensity = findScalar(element, {"confidence", "intensity", "scalar_intensity"})) {
    plan.intensities = true;
    plan.slotOfProperty[*intensity] = kIntensity;
  }
  if (const auto classification = findScalar(element, {"classification", "scalar_classification"})) {
    plan.classifications = true;
    plan.slotOfProperty[*classification] = kClassification;
  }
  const auto returnNumber = findScalar(element, {"return_number", "scalar_return_number"});
  const auto returnCount = findScalar(element, {"number_of_returns", "scalar_number_of_returns"});
  if (returnNumber && returnCount) {
    plan.returns = true;
    plan.slotOfProperty[*returnNumber] = kReturnNumber;
    plan.slotOfProperty[*returnCount] = kReturnCount;
  }
  return plan;
}

struct FacePlan {
  const Element* element = nullptr;  // null when the scan is a point cloud
  std::size_t indexProperty = 0;
};

// The vertex index list of element `name` ("face" or "tristrips").
FacePlan planFaces(const Header& header, std::string_view name = "face") {
  FacePlan plan;
  plan.element = findUniqueElement(header, name);
  if (!plan.element) return plan;
  const std::vector<Property>& properties = plan.element->properties;
  for (std::size_t i = 0; i < properties.size(); ++i) {
    if (properties[i].name != "vertex_indices" && properties[i].name != "vertex_index") continue;
    if (!properties[i].isList())
      fail("line {}: {} property '{}' is not a list", plan.element->line, name, properties[i].name);
    plan.indexProperty = i;
    return plan;
  }
  fail("line {}: element {} has no 'vertex_indices' list", plan.element->line, name);
}

// --- Body sources ------------------------------------------------------------
// Both offer the same operations, so that the element readers below are
// written once: beginElement (checks the count against what remains),
// beginRecord, number, listCount, skipListItems, endRecord, finish, and
// position() ("line N" / "byte N") for messages.

class AsciiBody {
 public:
  // `firstIndex`: elements of the file before the body's (a run of its
  // lines), so that messages name the file's element.
  AsciiBody(parse::TextCursor cursor, std::size_t totalBytes, std::uint64_t firstIndex = 0)
      : cursor_(cursor), totalBytes_(totalBytes), firstIndex_(firstIndex) {}

  void beginElement(const Element& element) {
    element_ = &element;
    // Each element needs at least one digit and a separator (the last value
    // of the file may lack the separator).
    const std::size_t remaining = totalBytes_ - cursor_.offset();
    if (element.count > (remaining + 1) / 2)
      fail("line {}: header claims {} {} but only {} bytes remain in the file", element.line, element.count,
           plural(element.name), remaining);
  }

  // One element per line; blank lines are tolerated.
  void beginRecord(std::uint64_t index) {
    index_ = index;
    std::string_view line;
    do {
      if (!cursor_.next(line))
        fail("line {}: file ends after {} of {} {}", cursor_.lineNumber(), firstIndex_ + index,
             firstIndex_ + element_->count, plural(element_->name));
      parse::splitWhitespace(line, tokens_);
    } while (tokens_.empty());
    nextToken_ = 0;
  }

  double number(const Property& property) {
    const std::string_view token = takeToken(property);
    // A float property's text denotes a float: parsing it as one avoids
    // rounding twice (decimal to double to float).
    if (property.type == ScalarType::Float32) {
      float value = 0;
      if (parse::parseNumber(token, value)) return value;
    } else {
      double value = 0;
      if (parse::parseNumber(token, value)) return value;
    }
    return cursor_.number(token, recordName());  // fails, naming line and token
  }

  std::uint64_t listCount(const Property& property) {
    const std::string_view token = takeToken(property);
    std::int64_t count = 0;
    if (!parse::parseInteger(token, count)) count = cursor_.integer(token, recordName());
    if (count < 0) fail("{}: {} has negative list count {} for '{}'", position(), recordName(), count, property.name);
    const std::size_t left = tokens_.size() - nextToken_;
    if (static_cast<std::uint64_t>(count) > left)
      fail("{}: {} lists {} values for '{}' but the line holds only {} more", position(), recordName(), count,
           property.name, left);
    return static_cast<std::uint64_t>(count);
  }

  // Skipped values are still parsed: a non-numeric token is a malformed line.
  void skipListItems(const Property& property, std::uint64_t count) {
    for (std::uint64_t i = 0; i < count; ++i) number(property);
  }

  void endRecord() const {
    if (nextToken_ != tokens_.size())
      fail("{}: {} has {} more values than its {} properties declare, starting at {}", position(), recordName(),
           tokens_.size() - nextToken_, element_->name, parse::quoted(tokens_[nextToken_]));
  }

  // Data after the last element means the header counts are wrong.
  void finish() {
    std::string_view line;
    while (cursor_.next(line)) {
      parse::splitWhitespace(line, tokens_);
      if (!tokens_.empty())
        fail("line {}: unexpected data after the last element: {}", cursor_.lineNumber(), parse::quoted(line));
    }
  }

  std::string position() const { return fmt::format("line {}", cursor_.lineNumber()); }

 private:
  std::string recordName() const { return fmt::format("{} {}", element_->name, firstIndex_ + index_); }

  std::string_view takeToken(const Property& property) {
    if (nextToken_ >= tokens_.size())
      fail("{}: {} has no value for property '{}'", position(), recordName(), property.name);
    return tokens_[nextToken_++];
  }

  parse::TextCursor cursor_;
  const std::size_t totalBytes_;
  const std::uint64_t firstIndex_;
  const Element* element_ = nullptr;
  std::uint64_t index_ = 0;
  std::vector<std::string_view> tokens_;
  std::size_t nextToken_ = 0;
};

// Fewest bytes one element can take in a binary body (empty lists).
std::uint64_t minimumBytes(const Element& element) {
  std::uint64_t bytes = 0;
  for (const Property& property : element.properties)
    bytes += byteSize(property.isList() ? *property.listCountType : property.type);
  return bytes;
}

class BinaryBody {
 public:
  BinaryBody(std::string_view bytes, std::size_t offset, bool bigEndian)
      : cursor_(bytes, offset), bigEndian_(bigEndian) {}

  void beginElement(const Element& element) {
    element_ = &element;
    what_ = fmt::format("{} data", element.name);
    parse::checkCountFits(element.count, minimumBytes(element), cursor_.remaining(), plural(element.name),
                          cursor_.offset());
  }

  void beginRecord(std::uint64_t index) {
    index_ = index;
    recordStart_ = cursor_.offset();
  }

  double number(const Property& property) { return read(property.type); }

  std::uint64_t listCount(const Property& property) {
    const double count = read(*property.listCountType);
    if (count < 0)
      fail("{}: {} {} has negative list count {} for '{}'", position(), element_->name, index_, count,
           property.name);
    const auto items = static_cast<std::uint64_t>(count);
    const std::size_t itemBytes = byteSize(property.type);
    if (items > cursor_.remaining() / itemBytes)
      fail("{}: {} {} lists {} values for '{}' ({} bytes each) but only {} bytes follow", position(),
           element_->name, index_, items, property.name, itemBytes, cursor_.remaining());
    return items;
  }

  void skipListItems(const Property& property, std::uint64_t count) {
    cursor_.skip(count * byteSize(property.type), what_);
  }

  // The faces of an element whose one property is a list of uchar
  // count and 32-bit indices, in this machine's byte order, decoded straight
  // from the bytes while each face is a triangle whose indices are in range
  // (the faces of nearly every mesh file): the generic path's per-value
  // conversions and checks took most of the 1.2M-triangle bunny's read.
  // Returns the face it stopped at; the generic path goes on from there, and
  // names a bad face as it always has.
  std::uint64_t triangleFaces(const Element& element, std::uint64_t vertexCount, std::vector<Triangle>& triangles) {
    constexpr std::size_t kBytes = 1 + 3 * sizeof(std::uint32_t);
    if (element.properties.size() != 1) return 0;
    const Property& list = element.properties.front();
    if (list.listCountType != ScalarType::UInt8 || (list.type != ScalarType::Int32 && list.type != ScalarType::UInt32) ||
        bigEndian_ != (std::endian::native == std::endian::big))
      return 0;
    // Signed indices: a negative one reads as 2^31 or more, out of range
    // unless M has that many vertices, which the generic path then takes.
    const std::uint64_t limit =
        list.type == ScalarType::Int32 ? std::min<std::uint64_t>(vertexCount, std::uint64_t{1} << 31) : vertexCount;
    std::uint64_t face = 0;
    for (; face < element.count && cursor_.remaining() >= kBytes; ++face) {
      const char* bytes = cursor_.here();
      std::array<std::uint32_t, 3> corners;
      std::memcpy(corners.data(), bytes + 1, sizeof(corners));
      if (static_cast<unsigned char>(bytes[0]) != 3 || corners[0] >= limit || corners[1] >= limit ||
          corners[2] >= limit)
        break;
      triangles.push_back({corners[0], corners[1], corners[2]});
      cursor_.advance(kBytes);
    }
    return face;
  }

  void endRecord() const {}
  // Trailing bytes after the last element are tolerated: some writers pad.
  void finish() const {}

  std::string position() const { return fmt::format("byte {}", recordStart_); }

 private:
  double read(ScalarType type) {
    switch (type) {
      case ScalarType::Int8: return cursor_.read<std::int8_t>(bigEndian_, what_);
      case ScalarType::UInt8: return cursor_.read<std::uint8_t>(bigEndian_, what_);
      case ScalarType::Int16: return cursor_.read<std::int16_t>(bigEndian_, what_);
      case ScalarType::UInt16: return cursor_.read<std::uint16_t>(bigEndian_, what_);
      case ScalarType::Int32: return cursor_.read<std::int32_t>(bigEndian_, what_);
      case ScalarType::UInt32: return cursor_.read<std::uint32_t>(bigEndian_, what_);
      case ScalarType::Float32: return cursor_.read<float>(bigEndian_, what_);
      case ScalarType::Float64: return cursor_.read<double>(bigEndian_, what_);
    }
    APO_CHECK(!"unhandled ScalarType");
    return 0;
  }

  parse::BinaryCursor cursor_;
  bool bigEndian_;
  const Element* element_ = nullptr;
  std::string what_;  // "vertex data": names truncated data in messages
  std::uint64_t index_ = 0;
  std::size_t recordStart_ = 0;
};

// --- Element readers ---------------------------------------------------------

// Doubles beyond float range become infinities (a plain cast would be
// undefined), so that cleaning drops them like other non-finite values.
float toFloat(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (value > kMax) return std::numeric_limits<float>::infinity();
  if (value < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(value);
}

// A lidar attribute stored as a byte; out-of-range values are clamped.
std::uint8_t attributeByte(double value) {
  if (!(value > 0)) return 0;
  if (value >= 255) return 255;
  return static_cast<std::uint8_t>(value);
}

// Integer channels are taken as 0..255; floating ones as 0..1, scaled.
std::uint8_t colorByte(double value, ScalarType type) {
  const double scaled = isFloating(type) ? value * 255.0 : value;
  if (!(scaled > 0)) return 0;  // also NaN
  if (scaled >= 255) return 255;
  return static_cast<std::uint8_t>(std::lround(scaled));
}

template <class Body>
void skipProperty(const Property& property, Body& body) {
  if (property.isList())
    body.skipListItems(property, body.listCount(property));
  else
    body.number(property);
}

template <class Body>
void readVertices(const VertexPlan& plan, Body& body, Scan& scan) {
  const Element& element = *plan.element;
  const auto count = static_cast<std::size_t>(element.count);
  PointSet& points = scan.points;
  PositionCollector positions;
  positions.reserve(count);
  if (plan.normals) points.normals.resize(count);
  if (plan.colors) points.colors.resize(count);
  if (plan.intensities) points.intensities.resize(count);
  if (plan.classifications) points.classifications.resize(count);
  if (plan.returns) {
    points.returnNumbers.resize(count);
    points.returnCounts.resize(count);
  }

  std::array<double, kSlotCount> values{};
  for (std::size_t i = 0; i < count; ++i) {
    body.beginRecord(i);
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const std::uint8_t slot = plan.slotOfProperty[p];
      if (slot == kSkip)
        skipProperty(element.properties[p], body);
      else
        values[slot] = body.number(element.properties[p]);
    }
    body.endRecord();

    positions.push(values[kX], values[kY], values[kZ]);
    if (plan.normals) points.normals[i] = Vec3f(toFloat(values[kNx]), toFloat(values[kNy]), toFloat(values[kNz]));
    if (plan.colors)
      points.colors[i] = {colorByte(values[kRed], plan.colorTypes[0]), colorByte(values[kGreen], plan.colorTypes[1]),
                          colorByte(values[kBlue], plan.colorTypes[2])};
    if (plan.intensities) points.intensities[i] = toFloat(values[kIntensity]);
    if (plan.classifications) points.classifications[i] = attributeByte(values[kClassification]);
    if (plan.returns) {
      points.returnNumbers[i] = attributeByte(values[kReturnNumber]);
      points.returnCounts[i] = attributeByte(values[kReturnCount]);
    }
  }
  positions.finishInto(scan);
}

template <class Body>
std::uint32_t vertexIndex(double value, std::uint64_t vertexCount, std::uint64_t face, const Body& body) {
  if (!(value >= 0 && value < static_cast<double>(vertexCount)))
    fail("{}: face {}: vertex index {} out of range ({} vertices)", body.position(), face, value, vertexCount);
  if (value != std::floor(value))
    fail("{}: face {}: vertex index {} is not an integer", body.position(), face, value);
  return static_cast<std::uint32_t>(value);
}

// Polygons become triangle fans (v0, vi, vi+1).
void appendFan(const std::vector<std::uint32_t>& polygon, std::vector<Triangle>& triangles) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
}

template <class Body>
void readFaces(const FacePlan& plan, std::uint64_t vertexCount, Body& body, std::vector<Triangle>& triangles) {
  const Element& element = *plan.element;
  triangles.reserve(triangles.size() + static_cast<std::size_t>(element.count));
  std::vector<std::uint32_t> polygon;
  std::uint64_t first = 0;
  if constexpr (std::is_same_v<Body, BinaryBody>) first = body.triangleFaces(element, vertexCount, triangles);
  for (std::uint64_t face = first; face < element.count; ++face) {
    body.beginRecord(face);
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      if (p != plan.indexProperty) {
        skipProperty(property, body);
        continue;
      }
      const std::uint64_t corners = body.listCount(property);
      if (corners < 3) fail("{}: face {} has {} vertices, need at least 3", body.position(), face, corners);
      polygon.resize(static_cast<std::size_t>(corners));
      for (std::uint32_t& index : polygon) index = vertexIndex(body.number(property), vertexCount, face, body);
    }
    body.endRecord();
    appendFan(polygon, triangles);
  }
}

// Triangle strips (older scanning software writes them): each list is a
// strip of vertex indices, -1 restarting it. Triangle i of a strip is
// (v_i, v_i+1, v_i+2), every other one turned round so that all keep the
// strip's winding. Triangles with a repeated vertex only join strips; they
// are counted, not kept. Returns their count.
template <class Body>
std::uint64_t readTristrips(const FacePlan& plan, std::uint64_t vertexCount, Body& body, std::vector<Triangle>& triangles) {
  const Element& element = *plan.element;
  std::uint64_t joins = 0;
  std::vector<std::uint32_t> strip;
  const auto flushStrip = [&] {
    for (std::size_t i = 0; i + 2 < strip.size(); ++i) {
      const std::uint32_t a = strip[i], b = strip[i + 1], c = strip[i + 2];
      if (a == b || b == c || a == c) {
        ++joins;
        continue;
      }
      triangles.push_back(i % 2 == 0 ? Triangle{a, b, c} : Triangle{b, a, c});
    }
    strip.clear();
  };
  for (std::uint64_t record = 0; record < element.count; ++record) {
    body.beginRecord(record);
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      if (p != plan.indexProperty) {
        skipProperty(property, body);
        continue;
      }
      const std::uint64_t items = body.listCount(property);
      for (std::uint64_t item = 0; item < items; ++item) {
        const double value = body.number(property);
        if (value == -1.0)
          flushStrip();
        else
          strip.push_back(vertexIndex(value, vertexCount, record, body));
      }
      flushStrip();
    }
    body.endRecord();
  }
  return joins;
}

// The vertex properties no slot takes, by name.
std::string skippedPropertyNames(const VertexPlan& plan) {
  std::string names;
  for (std::size_t p = 0; p < plan.element->properties.size(); ++p)
    if (plan.slotOfProperty[p] == kSkip) names += (names.empty() ? "" : ", ") + plan.element->properties[p].name;
  return names;
}

template <class Body>
void skipElement(const Element& element, Body& body) {
  for (std::uint64_t i = 0; i < element.count; ++i) {
    body.beginRecord(i);
    for (const Property& property : element.properties) skipProperty(property, body);
    body.endRecord();
  }
}

template <class Body>
Scan readBody(const Header& header, Body& body) {
  const VertexPlan vertexPlan = planVertices(header);
  const FacePlan facePlan = planFaces(header);
  const FacePlan stripPlan = planFaces(header, "tristrips");
  Scan scan;
  for (const Element& element : header.elements) {
    if (element.properties.empty()) continue;  // holds no data, whatever its count
    body.beginElement(element);
    if (&element == vertexPlan.element) {
      readVertices(vertexPlan, body, scan);
    } else if (&element == facePlan.element) {
      readFaces(facePlan, vertexPlan.element->count, body, scan.triangles);
    } else if (&element == stripPlan.element) {
      const std::size_t before = scan.triangles.size();
      const std::uint64_t joins = readTristrips(stripPlan, vertexPlan.element->count, body, scan.triangles);
      scan.readNotes.push_back(fmt::format("element tristrips: {} strips read as {} triangles ({} strip-joining "
                                           "triangles with a repeated vertex left out)",
                                           element.count, scan.triangles.size() - before, joins));
    } else {
      skipElement(element, body);
      scan.readNotes.push_back(fmt::format("element '{}' ({} {}) skipped: apo reads vertices, faces and tristrips",
                                           element.name, element.count, element.count == 1 ? "item" : "items"));
    }
  }
  body.finish();
  if (const std::string skipped = skippedPropertyNames(vertexPlan); !skipped.empty())
    scan.readNotes.push_back("vertex properties not kept: " + skipped);
  if (header.origin)
    for (int axis = 0; axis < 3; ++axis) scan.origin[axis] += (*header.origin)[axis];
  return scan;
}

// Whether the element holds data: elements without properties hold none,
// whatever their count.
bool holdsData(const Element& element) { return element.count > 0 && !element.properties.empty(); }

// The header with its vertex count set to `count` (the line rewritten, every
// other byte as it was).
std::string headerWithVertexCount(std::string_view head, std::uint64_t count) {
  std::string rewritten;
  parse::TextCursor cursor(head);
  std::string_view line;
  std::vector<std::string_view> tokens;
  std::size_t lineStart = 0;
  while (cursor.next(line)) {
    const std::size_t lineEnd = cursor.offset();
    parse::splitWhitespace(line, tokens);
    const bool vertexLine = tokens.size() == 3 && tokens[0] == "element" && tokens[1] == "vertex";
    // The line's end (its newline, and a carriage return before it) is kept either way.
    rewritten += vertexLine ? fmt::format("element vertex {}", count) : std::string(line);
    rewritten += head.substr(lineStart + line.size(), lineEnd - lineStart - line.size());
    lineStart = lineEnd;
  }
  return rewritten;
}

// The header of a PLY whose only data are its vertices (no faces, nothing
// before or after them), or nullopt.
std::optional<std::pair<Header, VertexPlan>> verticesAlone(std::string_view head) {
  if (head.find("end_header") == std::string_view::npos) return std::nullopt;
  Header header;
  VertexPlan plan;
  try {
    header = parseHeader(head);
    plan = planVertices(header);
  } catch (const parse::ParseFailure&) {
    return std::nullopt;  // the whole file's read says what is wrong
  }
  for (const Element& element : header.elements)
    if (&element != plan.element && holdsData(element)) return std::nullopt;
  return std::pair{std::move(header), plan};
}

}  // namespace

std::optional<RecordLayout> plyRecordLayout(std::string_view head) {
  const auto found = verticesAlone(head);
  if (!found || found->first.encoding == Encoding::Ascii) return std::nullopt;
  const auto& [header, plan] = *found;
  RecordLayout layout;
  for (const Property& property : plan.element->properties) {
    if (property.isList()) return std::nullopt;
    layout.recordBytes += byteSize(property.type);
  }
  layout.count = plan.element->count;
  layout.recordsAt = header.afterHeader.offset();
  return layout;
}

Scan readPlyRecords(std::string_view head, std::string_view records, const RecordLayout& layout) {
  std::string file = headerWithVertexCount(head.substr(0, layout.recordsAt), records.size() / layout.recordBytes);
  file += records;
  return readPly(file);
}

std::optional<TextLayout> plyTextLayout(std::string_view head) {
  const auto found = verticesAlone(head);
  if (!found || found->first.encoding != Encoding::Ascii) return std::nullopt;
  const Header& header = found->first;
  const std::size_t afterHeader = header.afterHeader.offset();
  return TextLayout{found->second.element->count, afterHeader, afterHeader, header.afterHeader.lineNumber()};
}

Scan readPlyLines(std::string_view head, std::string_view lines, const TextRun& run) {
  const std::string runHead = headerWithVertexCount(head, run.points);
  const Header header = parseHeader(runHead);
  AsciiBody body(parse::TextCursor(lines, static_cast<std::size_t>(run.linesBefore)), lines.size(), run.pointsBefore);
  return readBody(header, body);
}

Scan readPly(std::string_view bytes) {
  const Header header = parseHeader(bytes);
  if (header.encoding == Encoding::Ascii) {
    AsciiBody body(header.afterHeader, bytes.size());
    return readBody(header, body);
  }
  BinaryBody body(bytes, header.afterHeader.offset(), header.encoding == Encoding::BinaryBigEndian);
  return readBody(header, body);
}

}  // namespace apo::readers
