// STL, binary or ASCII. STL stores each triangle with its own three corners,
// so every triangle gets three new vertices (cleaning merges the duplicates)
// and facet normals, which are not vertex normals, are ignored.
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>

namespace apo::readers {
namespace {

using parse::fail;
using parse::TextCursor;

constexpr std::size_t kStlHeaderBytes = 80;
constexpr std::size_t kStlCountBytes = 4;
constexpr std::size_t kStlPrefixBytes = kStlHeaderBytes + kStlCountBytes;
// normal, three corners (12 floats), attribute byte count (uint16)
constexpr std::uint64_t kStlTriangleBytes = 50;
// Triangles whose three new vertices can still be indexed with uint32.
constexpr std::uint64_t kStlMaxTriangles = std::numeric_limits<std::uint32_t>::max() / 3;

void appendStlTriangle(const Vec3f& a, const Vec3f& b, const Vec3f& c, Scan& scan) {
  const auto first = static_cast<std::uint32_t>(scan.points.positions.size());
  scan.points.positions.push_back(a);
  scan.points.positions.push_back(b);
  scan.points.positions.push_back(c);
  scan.triangles.push_back({first, first + 1, first + 2});
}

// ---- binary ----

std::optional<std::uint32_t> binaryStlTriangleCount(std::string_view bytes) {
  if (bytes.size() < kStlPrefixBytes) return std::nullopt;
  return parse::BinaryCursor(bytes, kStlHeaderBytes).read<std::uint32_t>(false, "triangle count");
}

std::uint64_t binaryStlSize(std::uint32_t triangleCount) { return kStlPrefixBytes + kStlTriangleBytes * triangleCount; }

Vec3f readStlVector(parse::BinaryCursor& cursor) {
  const float x = cursor.read<float>(false, "vertex");
  const float y = cursor.read<float>(false, "vertex");
  const float z = cursor.read<float>(false, "vertex");
  return {x, y, z};
}

// Called once the file size matches the count, so the reads cannot run short.
Scan readBinaryStl(std::string_view bytes, std::uint32_t triangleCount) {
  if (triangleCount == 0) fail("byte {}: no triangles: the binary triangle count is 0", kStlHeaderBytes);
  if (triangleCount > kStlMaxTriangles)
    fail("byte {}: {} triangles are more than a scan can index", kStlHeaderBytes, triangleCount);
  Scan scan;
  scan.points.positions.reserve(std::size_t{3} * triangleCount);
  scan.triangles.reserve(triangleCount);
  parse::BinaryCursor cursor(bytes, kStlPrefixBytes);
  for (std::uint32_t t = 0; t < triangleCount; ++t) {
    cursor.skip(12, "facet normal");
    const Vec3f a = readStlVector(cursor);
    const Vec3f b = readStlVector(cursor);
    const Vec3f c = readStlVector(cursor);
    cursor.skip(2, "attribute byte count");
    appendStlTriangle(a, b, c, scan);
  }
  return scan;
}

// ---- ASCII ----

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
  return std::ranges::equal(a, b, [&](char x, char y) { return lower(x) == lower(y); });
}

// Keywords are lowercase in the spec; some old CAD exporters write them in
// uppercase, which costs nothing to accept.
bool startsWithSolid(std::string_view bytes) {
  const std::size_t start = bytes.find_first_not_of(" \t\r\n\v\f");
  return start != std::string_view::npos && equalsIgnoringCase(bytes.substr(start, 5), "solid");
}

// Moves to the next non-blank line and splits it; false at the end.
bool nextStlLine(TextCursor& cursor, std::vector<std::string_view>& tokens) {
  std::string_view line;
  while (cursor.next(line)) {
    parse::splitWhitespace(line, tokens);
    if (!tokens.empty()) return true;
  }
  return false;
}

bool isStlKeyword(const std::vector<std::string_view>& tokens, std::string_view keyword) {
  return equalsIgnoringCase(tokens.front(), keyword);
}

void expectStlKeyword(const TextCursor& cursor, const std::vector<std::string_view>& tokens,
                      std::string_view keyword) {
  if (!isStlKeyword(tokens, keyword))
    fail("line {}: expected '{}', got {}", cursor.lineNumber(), keyword, parse::quoted(tokens.front()));
}

void expectStlKeywords(const TextCursor& cursor, const std::vector<std::string_view>& tokens,
                       std::string_view first, std::string_view second) {
  expectStlKeyword(cursor, tokens, first);
  if (tokens.size() < 2 || !equalsIgnoringCase(tokens[1], second))
    fail("line {}: expected '{} {}', got {}", cursor.lineNumber(), first, second,
         tokens.size() < 2 ? std::string("nothing after it") : parse::quoted(tokens[1]));
}

// The next line of a facet, which must exist.
void nextStlFacetLine(TextCursor& cursor, std::vector<std::string_view>& tokens, std::string_view expected) {
  if (!nextStlLine(cursor, tokens))
    fail("line {}: file ends inside a facet, expected '{}'", cursor.lineNumber(), expected);
}

Vec3f readStlVertexLine(const TextCursor& cursor, const std::vector<std::string_view>& tokens) {
  if (tokens.size() != 4)
    fail("line {}: expected 3 coordinates after 'vertex', got {}", cursor.lineNumber(), tokens.size() - 1);
  // Doubles beyond float range round to infinities, which cleaning drops.
  return {static_cast<float>(cursor.number(tokens[1], "a vertex")),
          static_cast<float>(cursor.number(tokens[2], "a vertex")),
          static_cast<float>(cursor.number(tokens[3], "a vertex"))};
}

// "facet normal ..." (current line), "outer loop", three "vertex x y z",
// "endloop", "endfacet".
void readStlFacet(TextCursor& cursor, std::vector<std::string_view>& tokens, Scan& scan) {
  expectStlKeywords(cursor, tokens, "facet", "normal");
  nextStlFacetLine(cursor, tokens, "outer loop");
  expectStlKeywords(cursor, tokens, "outer", "loop");
  Vec3f corners[3];
  for (int i = 0; i < 3; ++i) {
    nextStlFacetLine(cursor, tokens, "vertex");
    if (isStlKeyword(tokens, "endloop"))
      fail("line {}: facet has {} vertices, expected 3", cursor.lineNumber(), i);
    expectStlKeyword(cursor, tokens, "vertex");
    corners[i] = readStlVertexLine(cursor, tokens);
  }
  nextStlFacetLine(cursor, tokens, "endloop");
  if (isStlKeyword(tokens, "vertex")) fail("line {}: facet has more than 3 vertices", cursor.lineNumber());
  expectStlKeyword(cursor, tokens, "endloop");
  nextStlFacetLine(cursor, tokens, "endfacet");
  expectStlKeyword(cursor, tokens, "endfacet");
  if (scan.triangles.size() == kStlMaxTriangles)
    fail("line {}: more than {} triangles", cursor.lineNumber(), kStlMaxTriangles);
  appendStlTriangle(corners[0], corners[1], corners[2], scan);
}

// One or more "solid [name]" ... "endsolid [name]" blocks (some exporters
// write one solid per part).
Scan readAsciiStl(std::string_view bytes) {
  TextCursor cursor(bytes);
  std::vector<std::string_view> tokens;
  Scan scan;
  while (nextStlLine(cursor, tokens)) {
    expectStlKeyword(cursor, tokens, "solid");
    while (true) {
      if (!nextStlLine(cursor, tokens)) fail("line {}: file ends before 'endsolid'", cursor.lineNumber());
      if (isStlKeyword(tokens, "endsolid")) break;
      readStlFacet(cursor, tokens, scan);
    }
  }
  if (!scan.isMesh()) fail("line {}: no triangles", cursor.lineNumber());
  return scan;
}

// ---- detection ----

[[noreturn]] void failNotStl(std::string_view bytes, std::optional<std::uint32_t> triangleCount,
                             bool startsWithSolidKeyword) {
  const std::size_t position = triangleCount ? kStlHeaderBytes : 0;
  const std::string sizeProblem =
      triangleCount ? fmt::format("its size does not match the binary triangle count ({} triangles need {} "
                                  "bytes, file has {})",
                                  *triangleCount, binaryStlSize(*triangleCount), bytes.size())
                    : fmt::format("it is shorter than the {}-byte binary header ({} bytes)", kStlPrefixBytes,
                                  bytes.size());
  if (startsWithSolidKeyword)
    fail("byte {}: not an STL file: it starts with 'solid' but holds binary data, and {} (truncated binary STL?)",
         position, sizeProblem);
  fail("byte {}: not an STL file: {} and it does not start with 'solid'", position, sizeProblem);
}

}  // namespace

// Binary when the size matches the triangle count: binary headers often
// start with "solid" too. ASCII STL never holds a NUL byte, so a "solid" file
// that does is a damaged binary one, reported as such.
Scan readStl(std::string_view bytes) {
  if (bytes.empty()) fail("byte 0: empty file");
  const std::optional<std::uint32_t> triangleCount = binaryStlTriangleCount(bytes);
  if (triangleCount && binaryStlSize(*triangleCount) == bytes.size()) return readBinaryStl(bytes, *triangleCount);
  const bool solid = startsWithSolid(bytes);
  if (solid && bytes.find('\0') == std::string_view::npos) return readAsciiStl(bytes);
  failNotStl(bytes, triangleCount, solid);
}

}  // namespace apo::readers
