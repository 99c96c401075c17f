// The body shared by the scan readers' fuzz targets: a reader is a pure
// function from bytes to a Scan that either returns a consistent Scan or
// throws parse::ParseFailure. Anything else (another exception, a crash, a
// leak, undefined behaviour, a Scan whose attributes or triangles do not
// match its points) is a bug, and the target aborts on it.
#pragma once

#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string_view>

namespace apo::fuzz {

inline void checkConsistent(const Scan& scan) {
  const std::size_t n = scan.points.size();
  const bool attributesMatch = (scan.points.normals.empty() || scan.points.normals.size() == n) &&
                               (scan.points.colors.empty() || scan.points.colors.size() == n) &&
                               (scan.points.intensities.empty() || scan.points.intensities.size() == n);
  if (!attributesMatch) {
    std::fprintf(stderr, "reader returned attributes of another length than its %zu points\n", n);
    std::abort();
  }
  for (const Triangle& t : scan.triangles)
    for (const std::uint32_t v : t)
      if (v >= n) {
        std::fprintf(stderr, "reader returned a triangle with vertex %u of %zu\n", v, n);
        std::abort();
      }
}

template <class Reader>
int fuzzReader(Reader read, const std::uint8_t* data, std::size_t size) {
  try {
    checkConsistent(read(std::string_view(reinterpret_cast<const char*>(data), size)));
  } catch (const parse::ParseFailure&) {
    // Refused with a message: what bad input must get.
  }
  return 0;
}

// A text format's run path (readers.h, TextLayout): the input split at its
// head, its lines read as one run holding the header's count (or its data
// lines), as a file above --max-scan-points is read.
template <class Layout, class IsDataLine, class ReadLines>
int fuzzTextRuns(Layout layoutOf, IsDataLine isDataLine, ReadLines readLines, const std::uint8_t* data,
                 std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::optional<readers::TextLayout> layout = layoutOf(text);
  if (!layout) return 0;
  const std::string_view lines = text.substr(layout->dataBytes);
  std::uint64_t points = layout->count;
  if (points == 0) {
    parse::TextCursor cursor(lines);
    for (std::string_view line; cursor.next(line);) points += isDataLine(line) ? 1 : 0;
  }
  try {
    checkConsistent(readLines(text.substr(0, layout->headBytes), lines, {layout->linesBefore, 0, points}));
  } catch (const parse::ParseFailure&) {
  }
  return 0;
}

}  // namespace apo::fuzz
