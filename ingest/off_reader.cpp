// ASCII OFF (Geomview): "[C][N]OFF", the counts "vertices faces edges", then
// the vertices "x y z [nx ny nz] [r g b [a]]" and the faces "k i0 .. ik-1
// [color]". The format is free-form, so the values an element needs are
// taken from a token stream that may cross lines (as CGAL reads it), and the
// optional values after them (colors) are the rest of that element's last line.
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace apo::readers {
namespace {

using parse::fail;
using parse::TextCursor;

// Tokens after stripping '#' comments, with the line of the last one returned.
class OffTokens {
 public:
  explicit OffTokens(std::string_view text) : cursor_(text) {}

  // Next token, crossing lines; false at the end of the file.
  bool next(std::string_view& token) {
    while (index_ == tokens_.size()) {
      if (!nextLine()) return false;
    }
    token = tokens_[index_++];
    return true;
  }

  // The tokens left on the current line, consumed. Valid until next().
  std::span<const std::string_view> restOfLine() {
    const std::span<const std::string_view> rest(tokens_.data() + index_, tokens_.size() - index_);
    index_ = tokens_.size();
    return rest;
  }

  // For TextCursor::number/integer, whose messages name the current line.
  const TextCursor& cursor() const { return cursor_; }
  // At least 1, so that an empty file still has a position to report.
  std::size_t line() const { return std::max<std::size_t>(cursor_.lineNumber(), 1); }

 private:
  bool nextLine() {
    std::string_view line;
    if (!cursor_.next(line)) return false;
    parse::splitWhitespace(line.substr(0, line.find('#')), tokens_);
    index_ = 0;
    return true;
  }

  TextCursor cursor_;
  std::vector<std::string_view> tokens_;
  std::size_t index_ = 0;
};

struct OffHeader {
  bool hasNormals = false;
  bool hasColors = false;
  std::int64_t vertexCount = 0;
  std::int64_t faceCount = 0;
};

// Sets which per-vertex attributes the keyword announces. Geomview's other
// prefixes (ST texture coordinates, 4 dimensions, n dimensions) change the
// vertex layout and are refused rather than misread.
void parseOffKeyword(std::string_view keyword, std::size_t line, OffHeader& header) {
  if (!keyword.ends_with("OFF")) fail("line {}: wrong magic: expected OFF, got {}", line, parse::quoted(keyword));
  const std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  if (!prefix.empty() && prefix != "C" && prefix != "N" && prefix != "CN")
    fail("line {}: unsupported OFF variant {} (supported: OFF, COFF, NOFF, CNOFF)", line, parse::quoted(keyword));
  header.hasColors = prefix.starts_with('C');
  header.hasNormals = prefix.ends_with('N');
}

std::string_view nextOffHeaderToken(OffTokens& tokens, std::string_view what) {
  std::string_view token;
  if (!tokens.next(token)) fail("line {}: file ends before the {}", tokens.line(), what);
  return token;
}

std::int64_t offCount(OffTokens& tokens, std::string_view token, std::string_view what) {
  const std::int64_t count = tokens.cursor().integer(token, what);
  if (count < 0) fail("line {}: negative {} {}", tokens.line(), what, count);
  return count;
}

// The counts may follow the keyword on its line ("OFF 8 6 0") or not.
OffHeader readOffHeader(OffTokens& tokens) {
  OffHeader header;
  std::string_view keyword;
  if (!tokens.next(keyword)) fail("line {}: empty file", tokens.line());
  parseOffKeyword(keyword, tokens.line(), header);

  const std::string_view first = nextOffHeaderToken(tokens, "vertex count");
  if (first == "BINARY") fail("line {}: binary OFF is not supported", tokens.line());
  header.vertexCount = offCount(tokens, first, "vertex count");
  header.faceCount = offCount(tokens, nextOffHeaderToken(tokens, "face count"), "face count");
  // The edge count is unused, but it must be consumed to reach the vertices.
  tokens.cursor().integer(nextOffHeaderToken(tokens, "edge count"), "edge count");
  tokens.restOfLine();
  return header;
}

// Runs before anything is reserved, so that a header claiming billions of
// elements in a small file fails instead of exhausting memory. Every element
// is counted with the newline before it: a vertex takes at least "\n0 0 0"
// (6 bytes) and a face "\n3 0 1 2" (8).
void checkOffCountsFit(const OffHeader& header, std::size_t headerLine, const TextCursor& cursor,
                       std::size_t fileSize) {
  if (header.vertexCount == 0) fail("line {}: no points: the header declares 0 vertices", headerLine);
  if (cursor.atEnd()) fail("line {}: file ends after the header", headerLine);
  const std::size_t newlineAfterHeader = cursor.offset() - 1;
  const std::uint64_t available = fileSize - newlineAfterHeader;
  const auto vertexCount = static_cast<std::uint64_t>(header.vertexCount);
  parse::checkCountFits(vertexCount, 6, available, "vertices", newlineAfterHeader);
  parse::checkCountFits(static_cast<std::uint64_t>(header.faceCount), 8, available - vertexCount * 6, "faces",
                        newlineAfterHeader);
  if (vertexCount > std::numeric_limits<std::uint32_t>::max())
    fail("line {}: {} vertices are more than a scan can index", headerLine, vertexCount);
}

std::array<double, 3> readOffPosition(OffTokens& tokens, std::int64_t vertex, std::int64_t vertexCount) {
  std::array<double, 3> p{};
  std::string_view token;
  for (int axis = 0; axis < 3; ++axis) {
    if (!tokens.next(token)) fail("line {}: file ends after {} of {} vertices", tokens.line(), vertex, vertexCount);
    p[axis] = tokens.cursor().number(token, "a vertex");
  }
  return p;
}

Vec3f readOffVector(OffTokens& tokens, std::int64_t vertex, std::int64_t vertexCount) {
  Vec3f v;
  std::string_view token;
  for (int axis = 0; axis < 3; ++axis) {
    if (!tokens.next(token)) fail("line {}: file ends after {} of {} vertices", tokens.line(), vertex, vertexCount);
    // Doubles beyond float range round to infinities, which cleaning drops.
    v[axis] = static_cast<float>(tokens.cursor().number(token, "a vertex"));
  }
  return v;
}

// Geomview colors are integers 0..255 or reals 0..1; alpha is not kept.
Rgb8 readOffColor(const TextCursor& cursor, std::span<const std::string_view> values, std::int64_t vertex) {
  if (values.size() != 3 && values.size() != 4)
    fail("line {}: vertex {}: expected a color (r g b [a]) after the coordinates, got {} values",
         cursor.lineNumber(), vertex, values.size());
  const auto rgb = values.first(3);
  const bool integers = std::ranges::all_of(rgb, [](std::string_view token) {
    std::int64_t ignored = 0;
    return parse::parseInteger(token, ignored);
  });
  const double scale = integers ? 1.0 : 255.0;
  std::uint8_t channels[3];
  for (int c = 0; c < 3; ++c) {
    const double value = cursor.number(rgb[c], "a vertex color") * scale;
    if (!(value >= 0.0 && value <= 255.0))
      fail("line {}: vertex {}: color value {} out of range {}", cursor.lineNumber(), vertex,
           parse::quoted(rgb[c]), integers ? "0..255" : "0..1");
    channels[c] = static_cast<std::uint8_t>(std::lround(value));
  }
  return {channels[0], channels[1], channels[2]};
}

// Positions in double, into the local frame (positions.h).
void readOffVertices(OffTokens& tokens, const OffHeader& header, Scan& scan) {
  const auto count = static_cast<std::size_t>(header.vertexCount);
  PointSet& points = scan.points;
  PositionCollector positions;
  positions.reserve(count);
  if (header.hasNormals) points.normals.reserve(count);
  if (header.hasColors) points.colors.reserve(count);
  for (std::int64_t v = 0; v < header.vertexCount; ++v) {
    const std::array<double, 3> p = readOffPosition(tokens, v, header.vertexCount);
    positions.push(p[0], p[1], p[2]);
    if (header.hasNormals) points.normals.push_back(readOffVector(tokens, v, header.vertexCount));
    // Values after those a plain vertex needs (texture coordinates, colors
    // in an "OFF" file) are ignored, as CGAL does.
    const auto extra = tokens.restOfLine();
    if (header.hasColors) points.colors.push_back(readOffColor(tokens.cursor(), extra, v));
  }
  positions.finishInto(scan);
}

std::uint32_t readOffIndex(OffTokens& tokens, std::int64_t face, std::size_t vertexCount) {
  std::string_view token;
  if (!tokens.next(token)) fail("line {}: file ends inside face {}", tokens.line(), face);
  const std::int64_t index = tokens.cursor().integer(token, "a face");
  if (index < 0 || static_cast<std::uint64_t>(index) >= vertexCount)
    fail("line {}: face {}: vertex index {} out of range ({} vertices)", tokens.line(), face, index, vertexCount);
  return static_cast<std::uint32_t>(index);
}

// Fan-triangulates each polygon around its first vertex. A huge corner count
// cannot loop long: every corner consumes a token of the file.
void readOffFaces(OffTokens& tokens, std::int64_t faceCount, std::size_t vertexCount,
                  std::vector<Triangle>& triangles) {
  triangles.reserve(static_cast<std::size_t>(faceCount));
  std::string_view token;
  for (std::int64_t face = 0; face < faceCount; ++face) {
    if (!tokens.next(token)) fail("line {}: file ends after {} of {} faces", tokens.line(), face, faceCount);
    const std::int64_t corners = tokens.cursor().integer(token, "a face's vertex count");
    if (corners < 3)
      fail("line {}: face {} has {} vertices, a face needs at least 3", tokens.line(), face, corners);
    const std::uint32_t first = readOffIndex(tokens, face, vertexCount);
    std::uint32_t previous = readOffIndex(tokens, face, vertexCount);
    for (std::int64_t corner = 2; corner < corners; ++corner) {
      const std::uint32_t current = readOffIndex(tokens, face, vertexCount);
      triangles.push_back({first, previous, current});
      previous = current;
    }
    tokens.restOfLine();  // an optional face color, not kept
  }
}

}  // namespace

Scan readOff(std::string_view bytes) {
  OffTokens tokens(bytes);
  const OffHeader header = readOffHeader(tokens);
  checkOffCountsFit(header, tokens.line(), tokens.cursor(), bytes.size());
  Scan scan;
  readOffVertices(tokens, header, scan);
  readOffFaces(tokens, header.faceCount, scan.points.size(), scan.triangles);
  return scan;
}

}  // namespace apo::readers
