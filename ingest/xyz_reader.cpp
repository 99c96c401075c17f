// Whitespace-separated point columns: XYZ (x y z), XYZN (x y z nx ny nz, as
// CGAL writes them) and Leica PTS (an optional point-count line, then
// x y z [intensity] [r g b]). The first data line decides the layout; every
// other line must have the same number of columns.
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace apo::readers {
namespace {

using parse::fail;
using parse::TextCursor;

enum class XyzLayout { Xyz, XyzIntensity, XyzNormal, XyzRgb, XyzIntensityRgb };

bool isXyzComment(std::string_view firstToken) {
  return firstToken.starts_with('#') || firstToken.starts_with("//");
}

// Moves to the next line holding data (not blank, not a comment) and splits
// it into `tokens`; false at the end of the file.
bool nextXyzDataLine(TextCursor& cursor, std::vector<std::string_view>& tokens) {
  std::string_view line;
  while (cursor.next(line)) {
    parse::splitWhitespace(line, tokens);
    if (!tokens.empty() && !isXyzComment(tokens.front())) return true;
  }
  return false;
}

[[noreturn]] void failNoXyzPoints(const TextCursor& cursor) {
  if (cursor.lineNumber() == 0) fail("line 1: empty file");
  fail("line {}: no points: the file holds only comments and blank lines", cursor.lineNumber());
}

// Six columns are ambiguous: XYZN normals, or PTS colors when the file began
// with a point-count line (Leica's convention).
XyzLayout xyzLayoutFor(std::size_t columns, bool startsWithPointCount, std::size_t line) {
  switch (columns) {
    case 3: return XyzLayout::Xyz;
    case 4: return XyzLayout::XyzIntensity;
    case 6: return startsWithPointCount ? XyzLayout::XyzRgb : XyzLayout::XyzNormal;
    case 7: return XyzLayout::XyzIntensityRgb;
    default:
      fail("line {}: expected 3, 4, 6 or 7 columns (x y z [intensity] [nx ny nz | r g b]), got {}", line,
           columns);
  }
}

// Reads the PTS point count. It is only a hint (writers get it wrong), so it
// sizes a reservation capped by what the file could hold: a point needs at
// least "0 0 0\n", 6 bytes.
void reserveForPointCount(const TextCursor& cursor, std::string_view token, std::size_t fileSize,
                          PointSet& points) {
  const std::int64_t count = cursor.integer(token, "the point count line");
  if (count < 0) fail("line {}: negative point count {}", cursor.lineNumber(), count);
  points.positions.reserve(std::min(static_cast<std::uint64_t>(count), std::uint64_t{fileSize / 6}));
}

void reserveAttributes(XyzLayout layout, PointSet& points) {
  const std::size_t capacity = points.positions.capacity();
  if (layout == XyzLayout::XyzNormal) points.normals.reserve(capacity);
  if (layout == XyzLayout::XyzIntensity || layout == XyzLayout::XyzIntensityRgb)
    points.intensities.reserve(capacity);
  if (layout == XyzLayout::XyzRgb || layout == XyzLayout::XyzIntensityRgb) points.colors.reserve(capacity);
}

float xyzValue(const TextCursor& cursor, std::string_view token) {
  // Doubles beyond float range round to infinities, which cleaning drops.
  return static_cast<float>(cursor.number(token, "a point"));
}

Vec3f xyzVector(const TextCursor& cursor, const std::string_view* tokens) {
  return {xyzValue(cursor, tokens[0]), xyzValue(cursor, tokens[1]), xyzValue(cursor, tokens[2])};
}

std::uint8_t ptsColorChannel(const TextCursor& cursor, std::string_view token) {
  const double value = cursor.number(token, "a color");
  if (!(value >= 0.0 && value <= 255.0))
    fail("line {}: color value {} out of range 0..255", cursor.lineNumber(), parse::quoted(token));
  return static_cast<std::uint8_t>(std::lround(value));
}

Rgb8 ptsColor(const TextCursor& cursor, const std::string_view* tokens) {
  return {ptsColorChannel(cursor, tokens[0]), ptsColorChannel(cursor, tokens[1]),
          ptsColorChannel(cursor, tokens[2])};
}

void appendXyzPoint(const TextCursor& cursor, const std::vector<std::string_view>& tokens, XyzLayout layout,
                    PointSet& points) {
  const std::string_view* columns = tokens.data();
  points.positions.push_back(xyzVector(cursor, columns));
  switch (layout) {
    case XyzLayout::Xyz: break;
    case XyzLayout::XyzIntensity: points.intensities.push_back(xyzValue(cursor, columns[3])); break;
    case XyzLayout::XyzNormal: points.normals.push_back(xyzVector(cursor, columns + 3)); break;
    case XyzLayout::XyzRgb: points.colors.push_back(ptsColor(cursor, columns + 3)); break;
    case XyzLayout::XyzIntensityRgb:
      points.intensities.push_back(xyzValue(cursor, columns[3]));
      points.colors.push_back(ptsColor(cursor, columns + 4));
      break;
  }
}

}  // namespace

Scan readXyz(std::string_view bytes) {
  TextCursor cursor(bytes);
  std::vector<std::string_view> tokens;
  Scan scan;
  PointSet& points = scan.points;

  if (!nextXyzDataLine(cursor, tokens)) failNoXyzPoints(cursor);
  const bool startsWithPointCount = tokens.size() == 1;
  if (startsWithPointCount) {
    reserveForPointCount(cursor, tokens.front(), bytes.size(), points);
    if (!nextXyzDataLine(cursor, tokens)) fail("line {}: no points after the point count", cursor.lineNumber());
  }

  const std::size_t columns = tokens.size();
  const XyzLayout layout = xyzLayoutFor(columns, startsWithPointCount, cursor.lineNumber());
  reserveAttributes(layout, points);
  do {
    if (tokens.size() != columns)
      fail("line {}: expected {} columns, got {}", cursor.lineNumber(), columns, tokens.size());
    appendXyzPoint(cursor, tokens, layout, points);
  } while (nextXyzDataLine(cursor, tokens));
  return scan;
}

}  // namespace apo::readers
