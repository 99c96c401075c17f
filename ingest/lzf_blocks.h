// Internal to ingest: LZF (liblzf's format, which PCD's binary_compressed
// bodies use) decoded a block at a time, so that a body larger than memory
// can be decoded through. liblzf decodes only into one buffer holding the
// whole output; its format lets a back-reference reach at most 8 KiB back,
// so 8 KiB of history is all a block decoder keeps.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string_view>

namespace apo::lzf {

// Back-references reach at most this far behind the output's end.
inline constexpr std::size_t kHistory = 8192;

// Decodes `compressed`, which must decode to exactly `expected` bytes, handing
// the output to `sink` in order, in blocks of at most `blockBytes` (the last
// may hold fewer). Throws parse::ParseFailure naming byte `atByte` + the
// offset in `compressed` where the stream is corrupt: an instruction cut by
// its end, a reference before the output's start, more output than
// `expected`, or less. An `expected` of 0 decodes from any stream, as the
// whole read's liblzf does.
void decodeBlocks(std::string_view compressed, std::uint64_t expected, std::uint64_t atByte, std::size_t blockBytes,
                  const std::function<void(std::string_view block)>& sink);

}  // namespace apo::lzf
