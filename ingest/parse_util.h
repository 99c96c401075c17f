// Bounds-checked cursors over a file's bytes, shared by the readers. They throw
// ParseFailure with the position already in the message; each reader's entry
// point catches it and returns a BadInput Error prefixed with the file name.
#pragma once

#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include <fmt/format.h>

namespace apo::parse {

struct ParseFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

template <class... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw ParseFailure(fmt::format(format, std::forward<Args>(args)...));
}

// Quotes a token for an error message, shortened so garbage stays readable.
std::string quoted(std::string_view token);

// Parses a whole token as a number; nullopt-like failure via bool.
bool parseNumber(std::string_view token, double& out);
bool parseNumber(std::string_view token, float& out);
bool parseInteger(std::string_view token, std::int64_t& out);

// Splits on ASCII whitespace (space, tab, CR, vertical tab, form feed).
void splitWhitespace(std::string_view line, std::vector<std::string_view>& tokens);

// Line-by-line reading of text. Line numbers start at 1 and are those of the
// line last returned by next().
class TextCursor {
 public:
  // `linesBefore`: lines of the file before `text` (a run of its lines),
  // so that line numbers are the file's.
  explicit TextCursor(std::string_view text, std::size_t linesBefore = 0) : text_(text), line_(linesBefore) {}

  // Next line without its terminator (\n, \r\n or \r); false at the end.
  bool next(std::string_view& line);
  std::size_t lineNumber() const { return line_; }
  // Byte offset just after the last line returned (start of the next one).
  std::size_t offset() const { return pos_; }
  bool atEnd() const { return pos_ >= text_.size(); }

  // The current line's tokens parsed as numbers; fails naming the line, the
  // token and `what` ("vertex 12", "point 3") on a non-numeric token.
  double number(std::string_view token, std::string_view what) const;
  std::int64_t integer(std::string_view token, std::string_view what) const;

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_;
};

// Sequential binary reading with explicit endianness and bounds checks.
class BinaryCursor {
 public:
  BinaryCursor(std::string_view bytes, std::size_t offset) : bytes_(bytes), pos_(offset) {}

  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  // Fails "byte N: truncated <what>: need K bytes, M left" when short.
  void require(std::size_t count, std::string_view what) const;
  void skip(std::size_t count, std::string_view what) {
    require(count, what);
    pos_ += count;
  }

  // The bytes not read yet, and a step over some of them (at most
  // remaining(): for callers that decode a run of records themselves).
  const char* here() const { return bytes_.data() + pos_; }
  void advance(std::size_t count) { pos_ += count; }

  template <class T>
  T read(bool bigEndian, std::string_view what) {
    static_assert(std::is_arithmetic_v<T>);
    require(sizeof(T), what);
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    if (bigEndian != (std::endian::native == std::endian::big)) {
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
    }
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return value;
  }

 private:
  std::string_view bytes_;
  std::size_t pos_;
};

// Checks `count * bytesEach <= available` without overflow; fails with a
// message naming `what` and the sizes, before anything is allocated.
void checkCountFits(std::uint64_t count, std::uint64_t bytesEach, std::uint64_t available,
                    std::string_view what, std::size_t atByte);

}  // namespace apo::parse
