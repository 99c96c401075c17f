// Point columns in text: XYZ (x y z), XYZN (x y z nx ny nz, as CGAL writes
// them), Leica PTS (an optional point-count line, then x y z [intensity]
// [r g b]) and CSV-style exports of scanner software and CloudCompare:
// values separated by commas, semicolons, tabs or spaces, with an optional
// header line naming the columns (x y z nx ny nz r g b intensity, any order,
// any case; CloudCompare writes it after "//"). Without a header, the first
// data line's column count decides the layout; every other line must have
// the same number of columns.
#include "ingest/parse_util.h"
#include "ingest/positions.h"
#include "ingest/readers.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

namespace apo::readers {
namespace {

using parse::fail;
using parse::TextCursor;

enum class Role : std::uint8_t { X, Y, Z, Nx, Ny, Nz, Red, Green, Blue, Intensity, Skip };

// How the lines split and what each column holds.
struct Layout {
  char separator = ' ';  // ' ': runs of spaces and tabs
  std::vector<Role> roles;
  bool normals = false, colors = false, intensities = false;
};

void splitLine(std::string_view line, char separator, std::vector<std::string_view>& tokens) {
  if (separator == ' ') return parse::splitWhitespace(line, tokens);
  tokens.clear();
  auto trim = [](std::string_view token) {
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.front()))) token.remove_prefix(1);
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.remove_suffix(1);
    return token;
  };
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i)
    if (i == line.size() || line[i] == separator) {
      tokens.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  // A line of only whitespace is blank, whatever the separator.
  if (tokens.size() == 1 && tokens[0].empty()) tokens.clear();
}

// The first line decides: commas, else semicolons, else whitespace.
char separatorOf(std::string_view line) {
  if (line.find(',') != std::string_view::npos) return ',';
  if (line.find(';') != std::string_view::npos) return ';';
  return ' ';
}

std::string_view trimmedLeft(std::string_view line) {
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.remove_prefix(1);
  return line;
}

// "#" and "//" start comments; a header may hide behind them (CloudCompare).
bool isComment(std::string_view line) {
  line = trimmedLeft(line);
  return line.starts_with('#') || line.starts_with("//");
}

std::string_view withoutCommentMark(std::string_view line) {
  line = trimmedLeft(line);
  return line.substr(line.starts_with("//") ? 2 : line.starts_with('#') ? 1 : 0);
}

std::optional<Role> roleNamed(std::string name) {
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  struct Named {
    const char* name;
    Role role;
  };
  static constexpr Named kNames[] = {
      {"x", Role::X},          {"y", Role::Y},          {"z", Role::Z},         {"nx", Role::Nx},
      {"ny", Role::Ny},        {"nz", Role::Nz},        {"normal_x", Role::Nx}, {"normal_y", Role::Ny},
      {"normal_z", Role::Nz},  {"r", Role::Red},        {"g", Role::Green},     {"b", Role::Blue},
      {"red", Role::Red},      {"green", Role::Green},  {"blue", Role::Blue},   {"intensity", Role::Intensity},
      {"i", Role::Intensity},  {"scalar_intensity", Role::Intensity}};
  for (const Named& named : kNames)
    if (name == named.name) return named.role;
  return std::nullopt;
}

bool allNumbers(const std::vector<std::string_view>& tokens) {
  double ignored = 0;
  return std::all_of(tokens.begin(), tokens.end(), [&](std::string_view t) { return parse::parseNumber(t, ignored); });
}

// The roles a header names; nullopt when the tokens are not a header: none
// is a column name, or (`strict`, a comment that may be a header) one is
// not. Unknown names are skipped columns, noted.
std::optional<Layout> headerLayout(const std::vector<std::string_view>& tokens, char separator, std::size_t line,
                                   bool strict, std::vector<std::string>& notes) {
  Layout layout{separator, {}};
  std::string unknown;
  bool any = false;
  for (const std::string_view token : tokens) {
    const std::optional<Role> role = roleNamed(std::string(token));
    if (strict && !role) return std::nullopt;
    any = any || role.has_value();
    if (role && std::find(layout.roles.begin(), layout.roles.end(), *role) != layout.roles.end())
      fail("line {}: column {} named twice in the header", line, parse::quoted(token));
    layout.roles.push_back(role.value_or(Role::Skip));
    if (!role) unknown += (unknown.empty() ? "" : ", ") + parse::quoted(token);
  }
  if (!any) return std::nullopt;
  auto has = [&](Role r) { return std::find(layout.roles.begin(), layout.roles.end(), r) != layout.roles.end(); };
  if (!has(Role::X) || !has(Role::Y) || !has(Role::Z)) fail("line {}: the header names no x, y and z columns", line);
  layout.normals = has(Role::Nx) && has(Role::Ny) && has(Role::Nz);
  layout.colors = has(Role::Red) && has(Role::Green) && has(Role::Blue);
  layout.intensities = has(Role::Intensity);
  if (has(Role::Nx) != layout.normals || has(Role::Ny) != layout.normals || has(Role::Nz) != layout.normals ||
      has(Role::Red) != layout.colors || has(Role::Green) != layout.colors || has(Role::Blue) != layout.colors)
    fail("line {}: the header names part of a normal or a colour (nx ny nz and r g b go by threes)", line);
  if (!unknown.empty()) notes.push_back(fmt::format("columns not kept (header line {}): {}", line, unknown));
  return layout;
}

// Without a header: 3 columns x y z; 4 with intensity; 6 with normals, or
// with colours after a PTS point-count line (Leica's convention); 7 with
// intensity and colours.
Layout layoutForCount(std::size_t columns, bool afterPointCount, char separator, std::size_t line) {
  using enum Role;
  Layout layout{separator, {X, Y, Z}};
  switch (columns) {
    case 3: break;
    case 4: layout.roles.push_back(Intensity); break;
    case 6:
      if (afterPointCount)
        layout.roles.insert(layout.roles.end(), {Red, Green, Blue});
      else
        layout.roles.insert(layout.roles.end(), {Nx, Ny, Nz});
      break;
    case 7: layout.roles.insert(layout.roles.end(), {Intensity, Red, Green, Blue}); break;
    default:
      fail("line {}: expected 3, 4, 6 or 7 columns (x y z [intensity] [nx ny nz | r g b]) or a header naming them, "
           "got {}",
           line, columns);
  }
  layout.intensities = columns == 4 || columns == 7;
  layout.normals = columns == 6 && !afterPointCount;
  layout.colors = columns == 7 || (columns == 6 && afterPointCount);
  return layout;
}

// Reads the PTS point count. It is only a hint (writers get it wrong), so it
// sizes a reservation capped by what the file could hold: a point needs at
// least "0 0 0\n", 6 bytes.
std::size_t reservationForPointCount(const TextCursor& cursor, std::string_view token, std::size_t fileSize) {
  const std::int64_t count = cursor.integer(token, "the point count line");
  if (count < 0) fail("line {}: negative point count {}", cursor.lineNumber(), count);
  return static_cast<std::size_t>(std::min(static_cast<std::uint64_t>(count), std::uint64_t{fileSize / 6}));
}

std::uint8_t colorChannel(const TextCursor& cursor, std::string_view token) {
  const double value = cursor.number(token, "a color");
  if (!(value >= 0.0 && value <= 255.0))
    fail("line {}: color value {} out of range 0..255", cursor.lineNumber(), parse::quoted(token));
  return static_cast<std::uint8_t>(std::lround(value));
}

// Doubles beyond float range become infinities, which cleaning drops.
float attribute(const TextCursor& cursor, std::string_view token) {
  const double value = cursor.number(token, "a point");
  constexpr double kMax = std::numeric_limits<float>::max();
  return value > kMax ? std::numeric_limits<float>::infinity()
                      : value < -kMax ? -std::numeric_limits<float>::infinity() : static_cast<float>(value);
}

class XyzReader {
 public:
  XyzReader(std::string_view bytes, std::size_t linesBefore = 0) : cursor_(bytes, linesBefore), fileSize_(bytes.size()) {}

  // The column layout, from a header or from the first data line, which is
  // then the scan's first point; the cursor stops after that line.
  Layout readLayout() {
    std::string_view line;
    std::optional<Layout> layout;
    bool afterPointCount = false;
    std::vector<std::string> notes;
    while (!layout) {
      dataStart_ = {cursor_.offset(), cursor_.lineNumber()};
      if (!nextLine(line)) failNoPoints(afterPointCount);
      const char separator = separatorOf(line);
      if (isComment(line)) {
        splitLine(withoutCommentMark(line), separator, tokens_);
        if (!tokens_.empty() && !allNumbers(tokens_))
          layout = headerLayout(tokens_, separator, cursor_.lineNumber(), true, notes);
        continue;
      }
      splitLine(line, separator, tokens_);
      if (tokens_.size() == 1 && !afterPointCount && separator == ' ') {
        positions_.reserve(reservationForPointCount(cursor_, tokens_[0], fileSize_));
        afterPointCount = true;
        continue;
      }
      if (!allNumbers(tokens_)) {
        layout = headerLayout(tokens_, separator, cursor_.lineNumber(), false, notes);
        if (!layout) failOnFirstNonNumber();
        dataStart_ = {cursor_.offset(), cursor_.lineNumber()};
        continue;
      }
      layout = layoutForCount(tokens_.size(), afterPointCount, separator, cursor_.lineNumber());
      appendPoint(*layout);
    }
    scan_.readNotes = std::move(notes);
    return *layout;
  }

  // Bytes and lines read so far, and where the data lines start (at the
  // line that decided the layout when it was one).
  std::size_t offset() const { return cursor_.offset(); }
  std::size_t lineNumber() const { return cursor_.lineNumber(); }
  struct Place {
    std::size_t bytes = 0, lines = 0;
  };
  const Place& dataStart() const { return dataStart_; }
  // What readLayout noted (columns not kept).
  const std::vector<std::string>& notes() const { return scan_.readNotes; }

  // The data lines from the cursor on, as the scan's (next) points.
  Scan readPoints(const Layout& layout) {
    while (nextDataLine(layout.separator)) appendPoint(layout);
    positions_.finishInto(scan_);
    return std::move(scan_);
  }

 private:
  // The next non-blank line.
  bool nextLine(std::string_view& line) {
    while (cursor_.next(line)) {
      parse::splitWhitespace(line, tokens_);
      if (!tokens_.empty()) return true;
    }
    return false;
  }

  bool nextDataLine(char separator) {
    std::string_view line;
    while (nextLine(line)) {
      if (isComment(line)) continue;
      splitLine(line, separator, tokens_);
      return true;
    }
    return false;
  }

  // A data line that is not a header: the first token that is no number.
  [[noreturn]] void failOnFirstNonNumber() const {
    for (const std::string_view token : tokens_) cursor_.number(token, "a point");
    fail("line {}: not a line of numbers", cursor_.lineNumber());
  }

  [[noreturn]] void failNoPoints(bool afterPointCount) const {
    if (cursor_.lineNumber() == 0) fail("line 1: empty file");
    if (afterPointCount) fail("line {}: no points after the point count", cursor_.lineNumber());
    fail("line {}: no points: the file holds only comments and blank lines", cursor_.lineNumber());
  }

  void appendPoint(const Layout& layout) {
    if (tokens_.size() != layout.roles.size())
      fail("line {}: expected {} columns, got {}", cursor_.lineNumber(), layout.roles.size(), tokens_.size());
    std::array<double, 3> position{};
    Vec3f normal = Vec3f::Zero();
    std::array<std::uint8_t, 3> color{};
    float intensity = 0.0f;
    for (std::size_t c = 0; c < tokens_.size(); ++c) {
      const std::string_view token = tokens_[c];
      switch (layout.roles[c]) {
        case Role::X: position[0] = cursor_.number(token, "a point"); break;
        case Role::Y: position[1] = cursor_.number(token, "a point"); break;
        case Role::Z: position[2] = cursor_.number(token, "a point"); break;
        case Role::Nx: normal.x() = attribute(cursor_, token); break;
        case Role::Ny: normal.y() = attribute(cursor_, token); break;
        case Role::Nz: normal.z() = attribute(cursor_, token); break;
        case Role::Red: color[0] = colorChannel(cursor_, token); break;
        case Role::Green: color[1] = colorChannel(cursor_, token); break;
        case Role::Blue: color[2] = colorChannel(cursor_, token); break;
        case Role::Intensity: intensity = attribute(cursor_, token); break;
        case Role::Skip: break;
      }
    }
    positions_.push(position[0], position[1], position[2]);
    PointSet& points = scan_.points;
    if (layout.normals) points.normals.push_back(normal);
    if (layout.colors) points.colors.push_back({color[0], color[1], color[2]});
    if (layout.intensities) points.intensities.push_back(intensity);
  }

  TextCursor cursor_;
  Place dataStart_;
  std::size_t fileSize_;
  std::vector<std::string_view> tokens_;
  PositionCollector positions_;
  Scan scan_;
};

}  // namespace

Scan readXyz(std::string_view bytes) {
  XyzReader reader(bytes);
  const Layout layout = reader.readLayout();
  Scan scan = reader.readPoints(layout);
  if (scan.points.size() == 0) fail("line {}: no points after the header", reader.lineNumber());
  return scan;
}

std::optional<TextLayout> xyzTextLayout(std::string_view head) {
  XyzReader reader(head);
  try {
    reader.readLayout();
  } catch (const parse::ParseFailure&) {
    return std::nullopt;  // the whole file's read says what is wrong
  }
  return TextLayout{0, reader.offset(), reader.dataStart().bytes, reader.dataStart().lines};
}

bool isNonBlankLine(std::string_view line) { return line.find_first_not_of(" \t\r\n\f\v") != std::string_view::npos; }

bool isXyzDataLine(std::string_view line) { return isNonBlankLine(line) && !isComment(line); }

Scan readXyzLines(std::string_view head, std::string_view lines, const TextRun& run) {
  XyzReader headReader(head);
  const Layout layout = headReader.readLayout();
  Scan scan = XyzReader(lines, static_cast<std::size_t>(run.linesBefore)).readPoints(layout);
  scan.readNotes.insert(scan.readNotes.begin(), headReader.notes().begin(), headReader.notes().end());
  return scan;
}

}  // namespace apo::readers
