#include "ingest/lzf_blocks.h"

#include "ingest/parse_util.h"

#include <algorithm>
#include <cstring>
#include <vector>

namespace apo::lzf {
namespace {

// The longest instruction's output: a back-reference of 7 + 255 + 2 bytes.
constexpr std::size_t kLongestCopy = 264;

// The output not yet handed on, behind up to kHistory bytes of what was.
class Window {
 public:
  Window(std::size_t blockBytes, const std::function<void(std::string_view)>& sink)
      : blockBytes_(blockBytes), bytes_(kHistory + blockBytes + kLongestCopy), sink_(sink) {}

  std::uint64_t produced() const { return produced_; }

  // Room for one instruction's output: full blocks handed on first.
  void makeRoom() {
    if (end_ - start_ >= blockBytes_) flush();
  }

  void literal(const char* from, std::size_t count) {
    std::memcpy(bytes_.data() + end_, from, count);
    end_ += count;
    produced_ += count;
  }

  // Copies `count` bytes from `distance` behind the end, byte by byte: the
  // source may overlap what the copy writes (a run).
  void copy(std::size_t distance, std::size_t count) {
    char* out = bytes_.data() + end_;
    const char* from = out - distance;
    for (std::size_t i = 0; i < count; ++i) out[i] = from[i];
    end_ += count;
    produced_ += count;
  }

  // Bytes behind the end that a reference may reach.
  std::size_t reachable() const { return end_; }

  void flush() {
    if (end_ > start_) sink_(std::string_view(bytes_.data() + start_, end_ - start_));
    const std::size_t keep = std::min(end_, kHistory);
    std::memmove(bytes_.data(), bytes_.data() + end_ - keep, keep);
    start_ = end_ = keep;
  }

 private:
  std::size_t blockBytes_;
  std::vector<char> bytes_;
  const std::function<void(std::string_view)>& sink_;
  std::size_t start_ = 0, end_ = 0;  // [start_, end_): not yet handed on
  std::uint64_t produced_ = 0;
};

}  // namespace

void decodeBlocks(std::string_view compressed, std::uint64_t expected, std::uint64_t atByte, std::size_t blockBytes,
                  const std::function<void(std::string_view block)>& sink) {
  // Nothing to decode whatever follows, as the whole read takes it
  // (pcl_adapter::lzfDecompress).
  if (expected == 0) return;
  Window window(std::max<std::size_t>(blockBytes, 1), sink);
  const auto* in = reinterpret_cast<const unsigned char*>(compressed.data());
  const std::size_t size = compressed.size();
  const auto corrupt = [&](std::size_t at, const char* why) {
    parse::fail("byte {}: corrupt LZF data: {} (after {} of its {} bytes decoded)", atByte + at, why,
                window.produced(), expected);
  };
  for (std::size_t at = 0; at < size;) {
    const std::size_t instruction = at;
    const unsigned control = in[at++];
    window.makeRoom();
    if (control < 32) {  // a literal run of control + 1 bytes
      const std::size_t count = control + 1;
      if (count > size - at) corrupt(instruction, "a literal run cut by the stream's end");
      if (count > expected - window.produced()) corrupt(instruction, "more output than the header's size");
      window.literal(compressed.data() + at, count);
      at += count;
      continue;
    }
    std::size_t length = control >> 5;
    if (at >= size) corrupt(instruction, "a back-reference cut by the stream's end");
    if (length == 7) {
      length += in[at++];
      if (at >= size) corrupt(instruction, "a back-reference cut by the stream's end");
    }
    const std::size_t distance = ((control & 0x1FU) << 8) + in[at++] + 1;
    length += 2;
    if (distance > window.reachable()) corrupt(instruction, "a back-reference before the output's start");
    if (length > expected - window.produced()) corrupt(instruction, "more output than the header's size");
    window.copy(distance, length);
  }
  if (window.produced() != expected) corrupt(size, "the stream ends early");
  window.flush();
}

}  // namespace apo::lzf
