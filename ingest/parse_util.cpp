#include "ingest/parse_util.h"

#include <cstdlib>
#include <limits>

namespace apo::parse {

std::string quoted(std::string_view token) {
  constexpr std::size_t kMaxShown = 40;
  std::string shown;
  for (char c : token.substr(0, kMaxShown)) {
    const auto u = static_cast<unsigned char>(c);
    shown += (u >= 0x20 && u < 0x7f) ? std::string(1, c) : fmt::format("\\x{:02x}", u);
  }
  if (token.size() > kMaxShown) shown += "...";
  return "'" + shown + "'";
}

template <class T>
static bool parseFloating(std::string_view token, T& out) {
  if (token.empty()) return false;
  // from_chars rejects a leading '+', which some writers emit.
  if (token.front() == '+') token.remove_prefix(1);
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  if (ptr != end) return false;
  // from_chars reports overflow and underflow alike; strtod tells them apart:
  // overflow becomes an infinity (which cleaning drops and counts), underflow
  // a denormal or zero.
  if (ec == std::errc::result_out_of_range) {
    const std::string copy(token);
    out = static_cast<T>(std::strtod(copy.c_str(), nullptr));
    return true;
  }
  return ec == std::errc();
}

bool parseNumber(std::string_view token, double& out) { return parseFloating(token, out); }
bool parseNumber(std::string_view token, float& out) { return parseFloating(token, out); }

bool parseInteger(std::string_view token, std::int64_t& out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  return ec == std::errc() && ptr == end;
}

void splitWhitespace(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  auto isSpace = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isSpace(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !isSpace(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

bool TextCursor::next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  std::size_t end = pos_;
  while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
  line = text_.substr(pos_, end - pos_);
  if (end < text_.size() && text_[end] == '\r') ++end;
  if (end < text_.size() && text_[end] == '\n') ++end;
  pos_ = end;
  ++line_;
  return true;
}

double TextCursor::number(std::string_view token, std::string_view what) const {
  double value = 0;
  if (!parseNumber(token, value)) fail("line {}: non-numeric token {} in {}", line_, quoted(token), what);
  return value;
}

std::int64_t TextCursor::integer(std::string_view token, std::string_view what) const {
  std::int64_t value = 0;
  if (!parseInteger(token, value)) fail("line {}: expected an integer, got {} in {}", line_, quoted(token), what);
  return value;
}

void BinaryCursor::require(std::size_t count, std::string_view what) const {
  if (count > remaining())
    fail("byte {}: truncated {}: need {} bytes, {} left", pos_, what, count, remaining());
}

void checkCountFits(std::uint64_t count, std::uint64_t bytesEach, std::uint64_t available,
                    std::string_view what, std::size_t atByte) {
  if (bytesEach != 0 && count > available / bytesEach)
    fail("byte {}: header claims {} {} ({} bytes each) but only {} bytes follow", atByte, count, what,
         bytesEach, available);
}

}  // namespace apo::parse
