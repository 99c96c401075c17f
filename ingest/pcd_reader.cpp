// PCD reader (Point Cloud Library format, versions .5 to .7). The header and
// the body are parsed here rather than by PCL's loader, which prints to stderr
// and accepts garbage; only the LZF decompressor comes from PCL. Every check
// against the file's size happens before anything the header claims is
// allocated.
#include "adapters/pcl/pcl_points.h"
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace apo::readers {
namespace {

using parse::fail;
using parse::quoted;
using Tokens = std::span<const std::string_view>;

// PCD binary data is the writer's memory image; every known writer is
// little-endian, and the loads below copy bytes as they are.
static_assert(std::endian::native == std::endian::little, "the PCD reader assumes a little-endian host");

enum class Encoding { Ascii, Binary, BinaryCompressed };

// One element's type, from a field's TYPE and SIZE.
enum class Scalar { I8, I16, I32, I64, U8, U16, U32, U64, F32, F64 };

struct Field {
  std::string_view name;
  Scalar scalar = Scalar::F32;
  std::uint64_t size = 4;   // bytes per element
  std::uint64_t count = 1;  // elements per point
  // PCL pads binary records with fields named "_"; they carry no data.
  bool isPadding() const { return name == "_"; }
};

// The fields the Scan takes, as indices into Header::fields.
struct Columns {
  std::array<std::size_t, 3> position{};
  std::optional<std::array<std::size_t, 3>> normal;
  std::optional<std::size_t> color;  // packed 0xAARRGGBB
  std::optional<std::size_t> intensity;
};

// VIEWPOINT as written: its position in the file's coordinates, in double
// until the points' local frame is known.
struct FileViewpoint {
  std::array<double, 3> origin{};
  std::array<float, 4> orientationWxyz{};
};

struct Header {
  std::vector<Field> fields;
  Columns columns;
  std::uint64_t points = 0;
  std::uint64_t tokensPerPoint = 0;  // ascii: sum of COUNT
  std::uint64_t recordSize = 0;      // binary: sum of SIZE * COUNT
  std::uint64_t packedRecordSize = 0;  // binary_compressed: the same without padding
  Encoding encoding = Encoding::Ascii;
  std::optional<FileViewpoint> viewpoint;
  std::uint64_t width = 0, height = 1;  // the grid; HEIGHT > 1: an organised cloud
};

// a * b and a + b, or nothing when the result does not fit in 64 bits.
std::optional<std::uint64_t> product(std::uint64_t a, std::uint64_t b) {
  std::uint64_t result = 0;
  if (__builtin_mul_overflow(a, b, &result)) return std::nullopt;
  return result;
}
std::optional<std::uint64_t> sum(std::uint64_t a, std::uint64_t b) {
  std::uint64_t result = 0;
  if (__builtin_add_overflow(a, b, &result)) return std::nullopt;
  return result;
}

std::optional<Scalar> scalarOf(char type, std::uint64_t size) {
  constexpr std::array kSigned = {Scalar::I8, Scalar::I16, Scalar::I32, Scalar::I64};
  constexpr std::array kUnsigned = {Scalar::U8, Scalar::U16, Scalar::U32, Scalar::U64};
  const int log2Size = std::countr_zero(size);  // sizes are validated to be 1, 2, 4 or 8
  switch (type) {
    case 'I': return kSigned[log2Size];
    case 'U': return kUnsigned[log2Size];
    case 'F':
      if (size == 4) return Scalar::F32;
      if (size == 8) return Scalar::F64;
      return std::nullopt;
    default: return std::nullopt;
  }
}

std::optional<std::size_t> findField(const std::vector<Field>& fields, std::string_view name) {
  const auto it = std::find_if(fields.begin(), fields.end(), [&](const Field& f) { return f.name == name; });
  if (it == fields.end()) return std::nullopt;
  return static_cast<std::size_t>(it - fields.begin());
}

// One of the per-field header lines (FIELDS, SIZE, TYPE, COUNT) and where it was.
template <class T>
struct Listed {
  std::vector<T> values;
  std::size_t line = 0;  // 0: the header has no such line
};

// Reads the header up to and including the DATA line, checking each line as
// it comes and the lines against each other at the end.
class HeaderReader {
 public:
  explicit HeaderReader(parse::TextCursor& cursor) : cursor_(cursor) {}

  Header read() {
    std::string_view line;
    std::vector<std::string_view> tokens;
    while (!encoding_ && cursor_.next(line)) {
      parse::splitWhitespace(line, tokens);
      if (tokens.empty() || tokens.front().starts_with('#')) continue;
      readKeywordLine(tokens);
    }
    if (cursor_.lineNumber() == 0) fail("line 1: empty file, expected a PCD header");
    if (!encoding_) fail("line {}: header ends without a DATA line", cursor_.lineNumber());
    return finish();
  }

 private:
  using LineReader = void (HeaderReader::*)(Tokens values);

  void readKeywordLine(Tokens tokens) {
    // COLUMNS is the name of FIELDS in PCD .5 files.
    const std::string_view keyword = tokens.front() == "COLUMNS" ? "FIELDS" : tokens.front();
    const LineReader reader = lineReaderFor(keyword);
    if (reader == nullptr) {
      if (seen_.empty())
        fail("line {}: wrong magic, not a PCD header: expected a keyword such as VERSION or FIELDS, got {}",
             cursor_.lineNumber(), quoted(tokens.front()));
      fail("line {}: unknown PCD header keyword {}", cursor_.lineNumber(), quoted(tokens.front()));
    }
    noteFirstUse(keyword);
    (this->*reader)(tokens.subspan(1));
  }

  static LineReader lineReaderFor(std::string_view keyword) {
    static constexpr std::array<std::pair<std::string_view, LineReader>, 10> kReaders = {{
        {"VERSION", &HeaderReader::readVersion},
        {"FIELDS", &HeaderReader::readFields},
        {"SIZE", &HeaderReader::readSizes},
        {"TYPE", &HeaderReader::readTypes},
        {"COUNT", &HeaderReader::readCounts},
        {"WIDTH", &HeaderReader::readWidth},
        {"HEIGHT", &HeaderReader::readHeight},
        {"VIEWPOINT", &HeaderReader::readViewpoint},
        {"POINTS", &HeaderReader::readPoints},
        {"DATA", &HeaderReader::readData},
    }};
    for (const auto& [name, reader] : kReaders)
      if (name == keyword) return reader;
    return nullptr;
  }

  // A repeated keyword would silently override the first; refuse it.
  void noteFirstUse(std::string_view keyword) {
    for (const auto& [name, line] : seen_)
      if (name == keyword) fail("line {}: second {} line (the first is line {})", cursor_.lineNumber(), keyword, line);
    seen_.emplace_back(keyword, cursor_.lineNumber());
  }

  void expectValueCount(Tokens values, std::size_t expected, std::string_view keyword, std::string_view meaning) const {
    if (values.size() != expected)
      fail("line {}: {} needs {} value{} ({}), got {}", cursor_.lineNumber(), keyword, expected,
           expected == 1 ? "" : "s", meaning, values.size());
  }
  void expectSomeValues(Tokens values, std::string_view keyword) const {
    if (values.empty()) fail("line {}: {} lists no values", cursor_.lineNumber(), keyword);
  }

  std::uint64_t nonNegativeInteger(std::string_view token, std::string_view what) const {
    const std::int64_t value = cursor_.integer(token, what);
    if (value < 0) fail("line {}: {} must not be negative, got {}", cursor_.lineNumber(), what, value);
    return static_cast<std::uint64_t>(value);
  }

  // The version is not needed to read the file: .5 to .7 differ only in
  // which lines they have, and those are handled line by line.
  void readVersion(Tokens values) { expectValueCount(values, 1, "VERSION", "the format version"); }

  void readFields(Tokens values) {
    expectSomeValues(values, "FIELDS");
    names_ = {{values.begin(), values.end()}, cursor_.lineNumber()};
  }

  void readSizes(Tokens values) {
    expectSomeValues(values, "SIZE");
    sizes_.line = cursor_.lineNumber();
    for (const std::string_view token : values) {
      const std::uint64_t size = nonNegativeInteger(token, "SIZE");
      if (size != 1 && size != 2 && size != 4 && size != 8)
        fail("line {}: SIZE {} is not a valid element size (1, 2, 4 or 8)", cursor_.lineNumber(), size);
      sizes_.values.push_back(size);
    }
  }

  void readTypes(Tokens values) {
    expectSomeValues(values, "TYPE");
    types_.line = cursor_.lineNumber();
    for (const std::string_view token : values) {
      if (token != "I" && token != "U" && token != "F")
        fail("line {}: TYPE {} is not I, U or F", cursor_.lineNumber(), quoted(token));
      types_.values.push_back(token.front());
    }
  }

  void readCounts(Tokens values) {
    expectSomeValues(values, "COUNT");
    counts_.line = cursor_.lineNumber();
    for (const std::string_view token : values) {
      const std::uint64_t count = nonNegativeInteger(token, "COUNT");
      if (count == 0) fail("line {}: COUNT must be at least 1, got 0", cursor_.lineNumber());
      counts_.values.push_back(count);
    }
  }

  void readWidth(Tokens values) {
    expectValueCount(values, 1, "WIDTH", "points per row");
    width_ = nonNegativeInteger(values[0], "WIDTH");
    widthLine_ = cursor_.lineNumber();
  }

  void readHeight(Tokens values) {
    expectValueCount(values, 1, "HEIGHT", "number of rows");
    height_ = nonNegativeInteger(values[0], "HEIGHT");
  }

  void readPoints(Tokens values) {
    expectValueCount(values, 1, "POINTS", "number of points");
    points_ = nonNegativeInteger(values[0], "POINTS");
    pointsLine_ = cursor_.lineNumber();
  }

  void readViewpoint(Tokens values) {
    expectValueCount(values, 7, "VIEWPOINT", "tx ty tz qw qx qy qz");
    std::array<double, 7> v{};
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = cursor_.number(values[i], "VIEWPOINT");
    viewpoint_ = FileViewpoint{{v[0], v[1], v[2]}, {static_cast<float>(v[3]), static_cast<float>(v[4]),
                                                    static_cast<float>(v[5]), static_cast<float>(v[6])}};
  }

  void readData(Tokens values) {
    expectValueCount(values, 1, "DATA", "ascii, binary or binary_compressed");
    if (values[0] == "ascii") encoding_ = Encoding::Ascii;
    else if (values[0] == "binary") encoding_ = Encoding::Binary;
    else if (values[0] == "binary_compressed") encoding_ = Encoding::BinaryCompressed;
    else fail("line {}: unknown DATA encoding {}; expected ascii, binary or binary_compressed", cursor_.lineNumber(), quoted(values[0]));
  }

  Header finish() const {
    Header header;
    header.encoding = *encoding_;
    header.viewpoint = viewpoint_;
    header.fields = combineFieldLines();
    header.columns = selectColumns(header.fields);
    header.points = pointCount();
    header.width = width_.value_or(0);
    header.height = height_.value_or(1);
    computeRecordSizes(header);
    return header;
  }

  template <class T>
  void checkListsEveryField(const Listed<T>& list, std::string_view keyword) const {
    if (list.line != 0 && list.values.size() != names_.values.size())
      fail("line {}: {} lists {} values but FIELDS (line {}) lists {}", list.line, keyword, list.values.size(),
           names_.line, names_.values.size());
  }

  // Zips FIELDS, SIZE, TYPE and COUNT. PCD .5 files may lack SIZE, TYPE and
  // COUNT; like PCL, the fields are then 4-byte floats with one element.
  std::vector<Field> combineFieldLines() const {
    if (names_.line == 0) fail("line {}: header has no FIELDS line", cursor_.lineNumber());
    checkListsEveryField(sizes_, "SIZE");
    checkListsEveryField(types_, "TYPE");
    checkListsEveryField(counts_, "COUNT");
    std::vector<Field> fields;
    for (std::size_t i = 0; i < names_.values.size(); ++i) {
      Field field;
      field.name = names_.values[i];
      if (sizes_.line != 0) field.size = sizes_.values[i];
      if (counts_.line != 0) field.count = counts_.values[i];
      const char type = types_.line != 0 ? types_.values[i] : 'F';
      const std::optional<Scalar> scalar = scalarOf(type, field.size);
      if (!scalar)
        fail("line {}: field '{}' has TYPE F and SIZE {}; floats are 4 or 8 bytes",
             types_.line != 0 ? types_.line : sizes_.line, field.name, field.size);
      field.scalar = *scalar;
      if (!field.isPadding() && findField(fields, field.name))
        fail("line {}: field '{}' is listed twice", names_.line, field.name);
      fields.push_back(field);
    }
    return fields;
  }

  std::size_t requiredField(const std::vector<Field>& fields, std::string_view name) const {
    const std::optional<std::size_t> index = findField(fields, name);
    if (!index) fail("line {}: FIELDS has no '{}'; a scan needs x, y and z", names_.line, name);
    return *index;
  }

  // Fields the scan takes must be single numbers, and packed colors 32-bit.
  void checkScalarColumn(const Field& field) const {
    if (field.count != 1)
      fail("line {}: field '{}' has COUNT {}; x, y, z, normals, rgb and intensity must have COUNT 1", counts_.line,
           field.name, field.count);
  }

  Columns selectColumns(const std::vector<Field>& fields) const {
    Columns columns;
    columns.position = {requiredField(fields, "x"), requiredField(fields, "y"), requiredField(fields, "z")};
    const auto nx = findField(fields, "normal_x"), ny = findField(fields, "normal_y"), nz = findField(fields, "normal_z");
    // A partial normal (say normal_z alone) is not a normal: leave it out.
    if (nx && ny && nz) columns.normal = {{*nx, *ny, *nz}};
    columns.color = findField(fields, "rgb");
    if (!columns.color) columns.color = findField(fields, "rgba");
    columns.intensity = findField(fields, "intensity");

    for (const std::size_t index : columns.position) checkScalarColumn(fields[index]);
    if (columns.normal)
      for (const std::size_t index : *columns.normal) checkScalarColumn(fields[index]);
    if (columns.intensity) checkScalarColumn(fields[*columns.intensity]);
    if (columns.color) {
      const Field& color = fields[*columns.color];
      checkScalarColumn(color);
      if (color.size != 4)
        fail("line {}: field '{}' has SIZE {}; packed colors are 4 bytes", sizes_.line, color.name, color.size);
    }
    return columns;
  }

  // POINTS must equal WIDTH x HEIGHT when both are given; older files give
  // only one of them, and HEIGHT defaults to 1.
  std::uint64_t pointCount() const {
    if (!width_) {
      if (!points_) fail("line {}: header gives neither POINTS nor WIDTH", cursor_.lineNumber());
      return *points_;
    }
    const std::uint64_t height = height_.value_or(1);
    const std::optional<std::uint64_t> gridPoints = product(*width_, height);
    if (!gridPoints) fail("line {}: WIDTH {} x HEIGHT {} is too large", widthLine_, *width_, height);
    if (points_ && *points_ != *gridPoints)
      fail("line {}: POINTS {} does not match WIDTH {} x HEIGHT {} = {}", pointsLine_, *points_, *width_, height,
           *gridPoints);
    return *gridPoints;
  }

  void computeRecordSizes(Header& header) const {
    for (const Field& field : header.fields) {
      const auto bytes = product(field.size, field.count);
      const auto tokens = sum(header.tokensPerPoint, field.count);
      const auto record = bytes ? sum(header.recordSize, *bytes) : std::nullopt;
      if (!tokens || !record) fail("line {}: COUNT of field '{}' is too large", counts_.line, field.name);
      header.tokensPerPoint = *tokens;
      header.recordSize = *record;
      if (!field.isPadding()) header.packedRecordSize += *bytes;  // at most recordSize: cannot overflow
    }
  }

  parse::TextCursor& cursor_;
  std::vector<std::pair<std::string_view, std::size_t>> seen_;  // keyword, line
  Listed<std::string_view> names_;
  Listed<std::uint64_t> sizes_;
  Listed<char> types_;
  Listed<std::uint64_t> counts_;
  std::optional<std::uint64_t> width_, height_, points_;
  std::size_t widthLine_ = 0, pointsLine_ = 0;
  std::optional<FileViewpoint> viewpoint_;
  std::optional<Encoding> encoding_;
};

Rgb8 unpackRgb(std::uint32_t packed) {
  return {static_cast<std::uint8_t>((packed >> 16) & 0xff), static_cast<std::uint8_t>((packed >> 8) & 0xff),
          static_cast<std::uint8_t>(packed & 0xff)};
}

// What a body decodes into: positions in double until the local frame is
// chosen (positions.h), the other attributes as they are.
struct Body {
  PositionCollector positions;
  PointSet& points;
};

void reservePoints(Body& out, const Columns& columns, std::size_t count) {
  out.positions.reserve(count);
  if (columns.normal) out.points.normals.reserve(count);
  if (columns.color) out.points.colors.reserve(count);
  if (columns.intensity) out.points.intensities.reserve(count);
}

// Appends one point; `point` gives a field's first element as a number
// (number(f)) and a packed color's raw 32 bits (colorBits(f)).
template <class Point>
void appendPoint(const Columns& columns, const Point& point, Body& out) {
  const auto& xyz = columns.position;
  out.positions.push(point.number(xyz[0]), point.number(xyz[1]), point.number(xyz[2]));
  if (columns.normal) {
    const auto& f = *columns.normal;
    out.points.normals.push_back(Vec3f(static_cast<float>(point.number(f[0])), static_cast<float>(point.number(f[1])),
                                       static_cast<float>(point.number(f[2]))));
  }
  if (columns.color) out.points.colors.push_back(unpackRgb(point.colorBits(*columns.color)));
  if (columns.intensity) out.points.intensities.push_back(static_cast<float>(point.number(*columns.intensity)));
}

// ---- DATA ascii ----

// One text line's values: the first element of every field but the color,
// which is kept as its packed bits.
struct AsciiPoint {
  std::vector<double> numbers;
  std::uint32_t packedColor = 0;
  double number(std::size_t field) const { return numbers[field]; }
  std::uint32_t colorBits(std::size_t) const { return packedColor; }
};

std::string describePoint(std::uint64_t point, const Field& field) {
  return fmt::format("point {} (field '{}')", point, field.name);
}

// The message naming the point is only built for a bad token, so good tokens
// cost no formatting; TextCursor then fails with the line and the token.
double asciiNumber(const parse::TextCursor& cursor, std::string_view token, const Field& field, std::uint64_t point) {
  switch (field.scalar) {
    case Scalar::F32: {
      float value = 0;
      if (parse::parseNumber(token, value)) return value;
      return cursor.number(token, describePoint(point, field));
    }
    case Scalar::F64: {
      double value = 0;
      if (parse::parseNumber(token, value)) return value;
      return cursor.number(token, describePoint(point, field));
    }
    default: {
      std::int64_t value = 0;
      if (parse::parseInteger(token, value)) return static_cast<double>(value);
      return static_cast<double>(cursor.integer(token, describePoint(point, field)));
    }
  }
}

// A float-typed color is written as the float whose bits are the packed
// integer (e.g. 4.2108e+06); an integer-typed one as the integer itself.
std::uint32_t asciiPackedColor(const parse::TextCursor& cursor, std::string_view token, const Field& field,
                               std::uint64_t point) {
  if (field.scalar == Scalar::F32)
    return std::bit_cast<std::uint32_t>(static_cast<float>(asciiNumber(cursor, token, field, point)));
  std::int64_t value = 0;
  if (!parse::parseInteger(token, value)) value = cursor.integer(token, describePoint(point, field));
  return static_cast<std::uint32_t>(value);  // wraps like the writer's cast, so -1 is white
}

// Parses every token of a point line (so garbage in skipped fields is caught
// too) and keeps the first element of each field.
void parseAsciiPoint(const parse::TextCursor& cursor, Tokens tokens, const Header& header, std::uint64_t point,
                     AsciiPoint& out) {
  std::size_t next = 0;
  for (std::size_t f = 0; f < header.fields.size(); ++f) {
    const Field& field = header.fields[f];
    for (std::uint64_t element = 0; element < field.count; ++element) {
      const std::string_view token = tokens[next++];
      if (element > 0) asciiNumber(cursor, token, field, point);  // checked, not kept
      else if (header.columns.color == f) out.packedColor = asciiPackedColor(cursor, token, field, point);
      else out.numbers[f] = asciiNumber(cursor, token, field, point);
    }
  }
}

void rejectDataAfterLastPoint(parse::TextCursor& cursor, std::vector<std::string_view>& tokens, std::uint64_t points) {
  std::string_view line;
  while (cursor.next(line)) {
    parse::splitWhitespace(line, tokens);
    if (!tokens.empty())
      fail("line {}: more data after the {} points the header declares", cursor.lineNumber(), points);
  }
}

// `firstPoint`: points of the file before the body's (a run of its lines),
// so that messages name the file's point.
void readAsciiBody(parse::TextCursor& cursor, std::size_t bodyBytes, const Header& header, Body& out,
                   std::uint64_t firstPoint = 0) {
  // Each point takes at least one character and one separator per token, so
  // a lying POINTS cannot make this reserve more than the file could hold.
  reservePoints(out, header.columns, std::min<std::uint64_t>(header.points, bodyBytes / header.tokensPerPoint / 2 + 1));
  AsciiPoint point{std::vector<double>(header.fields.size())};
  std::vector<std::string_view> tokens;
  std::string_view line;
  std::uint64_t done = 0;
  while (done < header.points) {
    if (!cursor.next(line))
      fail("line {}: file ends after {} of {} points", cursor.lineNumber(), firstPoint + done,
           firstPoint + header.points);
    parse::splitWhitespace(line, tokens);
    if (tokens.empty()) continue;  // blank lines are allowed, as in PCL
    if (tokens.size() != header.tokensPerPoint)
      fail("line {}: point {} has {} values, expected {} (the sum of COUNT)", cursor.lineNumber(), firstPoint + done,
           tokens.size(), header.tokensPerPoint);
    parseAsciiPoint(cursor, tokens, header, firstPoint + done, point);
    appendPoint(header.columns, point, out);
    ++done;
  }
  rejectDataAfterLastPoint(cursor, tokens, firstPoint + header.points);
}

// ---- DATA binary and binary_compressed ----

// Where one field's values lie: the first point's, then every `stride` bytes.
struct FieldView {
  const char* first = nullptr;
  std::size_t stride = 0;
  Scalar scalar = Scalar::F32;
};

template <class T>
T load(const char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

double loadNumber(const char* bytes, Scalar scalar) {
  switch (scalar) {
    case Scalar::I8: return load<std::int8_t>(bytes);
    case Scalar::I16: return load<std::int16_t>(bytes);
    case Scalar::I32: return load<std::int32_t>(bytes);
    case Scalar::I64: return static_cast<double>(load<std::int64_t>(bytes));
    case Scalar::U8: return load<std::uint8_t>(bytes);
    case Scalar::U16: return load<std::uint16_t>(bytes);
    case Scalar::U32: return load<std::uint32_t>(bytes);
    case Scalar::U64: return static_cast<double>(load<std::uint64_t>(bytes));
    case Scalar::F32: return load<float>(bytes);
    case Scalar::F64: return load<double>(bytes);
  }
  return 0.0;
}

class BinaryPoint {
 public:
  BinaryPoint(const std::vector<FieldView>& views, std::size_t index) : views_(views), index_(index) {}
  double number(std::size_t field) const { return loadNumber(at(field), views_[field].scalar); }
  std::uint32_t colorBits(std::size_t field) const { return load<std::uint32_t>(at(field)); }

 private:
  const char* at(std::size_t field) const { return views_[field].first + index_ * views_[field].stride; }
  const std::vector<FieldView>& views_;
  std::size_t index_;
};

void decodeRecords(const std::vector<FieldView>& views, const Header& header, Body& out) {
  reservePoints(out, header.columns, header.points);
  for (std::size_t i = 0; i < header.points; ++i) appendPoint(header.columns, BinaryPoint(views, i), out);
}

// Point-major: each point's fields side by side, padding included.
void readBinaryBody(std::string_view bytes, std::size_t offset, const Header& header, Body& out) {
  parse::checkCountFits(header.points, header.recordSize, bytes.size() - offset, "points", offset);
  std::vector<FieldView> views;
  std::size_t fieldOffset = 0;
  for (const Field& field : header.fields) {
    views.push_back({bytes.data() + offset + fieldOffset, header.recordSize, field.scalar});
    fieldOffset += field.size * field.count;
  }
  decodeRecords(views, header, out);
}

// Refuses the two sizes at byte `at` where they do not fit the header's
// `points` of `packed` bytes or the file, before anything is allocated.
void checkCompressedSizes(std::uint64_t at, std::uint32_t compressedSize, std::uint32_t uncompressedSize,
                          std::uint64_t fileSize, std::uint64_t points, std::uint64_t packed) {
  const std::uint64_t left = fileSize - at - 8;
  if (compressedSize > left)
    fail("byte {}: compressed size {} runs past the end of the file ({} bytes left)", at, compressedSize, left);
  if (product(points, packed) != uncompressedSize)
    fail("byte {}: uncompressed size {} does not match POINTS {} x {} bytes per point", at + 4, uncompressedSize,
         points, packed);
  // LZF expands data at most ~100 times in practice; a header claiming much
  // more than that describes a file that was cut or forged.
  constexpr std::uint64_t kMaxExpansion = 64, kSlack = 1 << 20;
  if (uncompressedSize > kMaxExpansion * fileSize + kSlack)
    fail("byte {}: uncompressed size {} is implausible for a file of {} bytes", at + 4, uncompressedSize,
         fileSize);
}

std::vector<char> decompressLzf(std::string_view compressed, std::size_t uncompressedSize, std::size_t atByte) {
  std::vector<char> plain(uncompressedSize);
  if (!pcl_adapter::lzfDecompress(compressed, plain)) fail("byte {}: corrupt LZF data", atByte);
  return plain;
}

// Sizes then LZF data; decompressed it is field-major (all x, then all y,
// ...), and padding fields are left out.
void readCompressedBody(std::string_view bytes, std::size_t offset, const Header& header, Body& out) {
  parse::BinaryCursor in(bytes, offset);
  const auto compressedSize = in.read<std::uint32_t>(false, "compressed size");
  const auto uncompressedSize = in.read<std::uint32_t>(false, "uncompressed size");
  checkCompressedSizes(offset, compressedSize, uncompressedSize, bytes.size(), header.points, header.packedRecordSize);
  const std::vector<char> plain = decompressLzf(bytes.substr(in.offset(), compressedSize), uncompressedSize, in.offset());

  std::vector<FieldView> views;
  std::size_t blockOffset = 0;
  for (const Field& field : header.fields) {
    const std::size_t elementBytes = field.size * field.count;
    if (field.isPadding()) {
      views.push_back({});  // never read: padding is not a column
      continue;
    }
    views.push_back({plain.data() + blockOffset, elementBytes, field.scalar});
    blockOffset += header.points * elementBytes;
  }
  decodeRecords(views, header, out);
}

// PCL writes VIEWPOINT 0 0 0 1 0 0 0 whether or not a sensor stood there.
bool isPclDefault(const FileViewpoint& viewpoint) {
  return viewpoint.origin == std::array<double, 3>{0.0, 0.0, 0.0} &&
         viewpoint.orientationWxyz == std::array<float, 4>{1.0f, 0.0f, 0.0f, 0.0f};
}

Viewpoint inLocalFrame(const FileViewpoint& viewpoint, const std::array<double, 3>& origin) {
  Viewpoint local;
  for (int axis = 0; axis < 3; ++axis) local.origin[axis] = static_cast<float>(viewpoint.origin[axis] - origin[axis]);
  local.orientationWxyz = viewpoint.orientationWxyz;
  local.isFormatDefault = isPclDefault(viewpoint);
  return local;
}

// The scan's positions into its local frame, and its viewpoint into that frame.
void finishScan(const Header& header, Body& body, Scan& scan) {
  body.positions.finishInto(scan);
  if (header.viewpoint) scan.viewpoint = inLocalFrame(*header.viewpoint, scan.origin);
}

// The header with each line given by `rewrite(keyword, line)`, or kept as it
// was where that returns nullopt.
template <class Rewrite>
std::string rewrittenHeader(std::string_view header, const Rewrite& rewrite) {
  std::string rewritten;
  std::vector<std::string_view> tokens;
  for (std::size_t at = 0; at < header.size();) {
    const std::size_t newline = header.find('\n', at);
    const std::size_t end = newline == std::string_view::npos ? header.size() : newline + 1;
    const std::string_view line = header.substr(at, end - at);
    parse::splitWhitespace(line, tokens);
    const std::optional<std::string> replaced = rewrite(tokens.empty() ? std::string_view() : tokens.front());
    rewritten += replaced ? std::string_view(*replaced) : line;
    at = end;
  }
  return rewritten;
}

// The header with the grid and the count of one row of `count` points:
// WIDTH and POINTS set to it, HEIGHT to 1, every other line as it was.
std::string headerWithPointCount(std::string_view header, std::uint64_t count) {
  return rewrittenHeader(header, [&](std::string_view keyword) -> std::optional<std::string> {
    if (keyword == "WIDTH" || keyword == "POINTS") return std::string(keyword) + " " + std::to_string(count) + "\n";
    if (keyword == "HEIGHT") return "HEIGHT 1\n";
    return std::nullopt;
  });
}

// The header with its DATA line set to `encoding`, every other line as it was.
std::string headerWithEncoding(std::string_view header, std::string_view encoding) {
  return rewrittenHeader(header, [&](std::string_view keyword) -> std::optional<std::string> {
    if (keyword == "DATA") return "DATA " + std::string(encoding) + "\n";
    return std::nullopt;
  });
}

// The header of a PCD of one row, and the cursor just after it; nullopt when
// it does not parse (the whole file's read then says what is wrong) or the
// cloud is organised (its grid is triangulated whole: docs/ingest.md).
std::optional<std::pair<Header, parse::TextCursor>> oneRowHeader(std::string_view head) {
  parse::TextCursor cursor(head);
  Header header;
  try {
    header = HeaderReader(cursor).read();
  } catch (const parse::ParseFailure&) {
    return std::nullopt;
  }
  if (header.height > 1) return std::nullopt;
  return std::pair{std::move(header), cursor};
}

}  // namespace

std::optional<PcdCompressedLayout> pcdCompressedLayout(std::string_view head) {
  const auto found = oneRowHeader(head);
  if (!found || found->first.encoding != Encoding::BinaryCompressed) return std::nullopt;
  const auto& [header, cursor] = *found;
  PcdCompressedLayout layout;
  layout.count = header.points;
  layout.sizesAt = cursor.offset();
  std::uint64_t recordOffset = 0;
  for (const Field& field : header.fields) {
    layout.fields.push_back({field.size * field.count, recordOffset, field.isPadding()});
    recordOffset += field.size * field.count;
  }
  layout.binaryHead = headerWithEncoding(head.substr(0, cursor.offset()), "binary");
  layout.binary = RecordLayout{header.points, layout.binaryHead.size(), header.recordSize};
  return layout;
}

PcdCompressedStream pcdCompressedStream(std::string_view sizes, const PcdCompressedLayout& layout,
                                        std::uint64_t fileBytes) {
  const std::uint64_t at = layout.sizesAt;
  if (sizes.size() < 8) fail("byte {}: the file ends inside the compressed body's sizes", at);
  std::uint32_t compressedSize = 0, uncompressedSize = 0;
  std::memcpy(&compressedSize, sizes.data(), 4);
  std::memcpy(&uncompressedSize, sizes.data() + 4, 4);
  std::uint64_t packed = 0;
  for (const PcdCompressedLayout::Block& field : layout.fields) packed += field.padding ? 0 : field.pointBytes;
  checkCompressedSizes(at, compressedSize, uncompressedSize, fileBytes, layout.count, packed);
  return {compressedSize, uncompressedSize};
}

std::optional<RecordLayout> pcdRecordLayout(std::string_view head) {
  const auto found = oneRowHeader(head);
  if (!found || found->first.encoding != Encoding::Binary) return std::nullopt;
  const auto& [header, cursor] = *found;
  return RecordLayout{header.points, cursor.offset(), header.recordSize};
}

std::optional<TextLayout> pcdTextLayout(std::string_view head) {
  const auto found = oneRowHeader(head);
  if (!found || found->first.encoding != Encoding::Ascii) return std::nullopt;
  const auto& [header, cursor] = *found;
  return TextLayout{header.points, cursor.offset(), cursor.offset(), cursor.lineNumber()};
}

Scan readPcdLines(std::string_view head, std::string_view lines, const TextRun& run) {
  const std::string runHead = headerWithPointCount(head, run.points);
  parse::TextCursor headCursor(runHead);
  const Header header = HeaderReader(headCursor).read();
  Scan scan;
  Body body{{}, scan.points};
  parse::TextCursor cursor(lines, static_cast<std::size_t>(run.linesBefore));
  readAsciiBody(cursor, lines.size(), header, body, run.pointsBefore);
  finishScan(header, body, scan);
  return scan;
}

Scan readPcdRecords(std::string_view head, std::string_view records, const RecordLayout& layout) {
  std::string file = headerWithPointCount(head.substr(0, layout.recordsAt), records.size() / layout.recordBytes);
  file += records;
  return readPcd(file);
}

Scan readPcd(std::string_view bytes) {
  parse::TextCursor cursor(bytes);
  const Header header = HeaderReader(cursor).read();
  Scan scan;
  // pointCount() checked WIDTH x HEIGHT = POINTS.
  if (header.height > 1 && header.width <= std::numeric_limits<std::uint32_t>::max())
    scan.gridWidth = static_cast<std::uint32_t>(header.width);
  Body body{{}, scan.points};
  switch (header.encoding) {
    case Encoding::Ascii: readAsciiBody(cursor, bytes.size() - cursor.offset(), header, body); break;
    case Encoding::Binary: readBinaryBody(bytes, cursor.offset(), header, body); break;
    case Encoding::BinaryCompressed: readCompressedBody(bytes, cursor.offset(), header, body); break;
  }
  finishScan(header, body, scan);
  return scan;
}

}  // namespace apo::readers
