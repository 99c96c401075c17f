// LZF decoded a block at a time (ingest/lzf_blocks.h) against liblzf's own
// decoder (through PCL's copy of it, the one compressed PCD bodies were
// decoded with): byte for byte, whatever the block size, and every kind of
// corruption refused with its byte.
#include "ingest/lzf_blocks.h"
#include "ingest/parse_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <pcl/io/lzf.h>

#include <cstdint>
#include <random>
#include <string>

namespace apo {
namespace {

using ::testing::HasSubstr;

// Runs, repeats far apart (references up to 8 KiB back) and noise.
std::string plainBytes(std::size_t size, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::string plain;
  while (plain.size() < size) {
    const auto kind = random() % 3;
    if (kind == 0) plain.append(1 + random() % 300, static_cast<char>(random()));
    if (kind == 1 && plain.size() > 16) {
      const std::size_t from = plain.size() - 1 - random() % std::min<std::size_t>(plain.size() - 1, 9000);
      plain += plain.substr(from, 3 + random() % 200);
    }
    if (kind == 2)
      for (int i = 0; i < 40; ++i) plain += static_cast<char>(random());
  }
  plain.resize(size);
  return plain;
}

std::string compress(const std::string& plain) {
  std::string out(plain.size() * 2 + 64, '\0');
  const unsigned size =
      pcl::lzfCompress(plain.data(), static_cast<unsigned>(plain.size()), out.data(), static_cast<unsigned>(out.size()));
  out.resize(size);
  return out;
}

std::string decode(const std::string& compressed, std::uint64_t expected, std::size_t blockBytes,
                   std::size_t* largestBlock = nullptr) {
  std::string out;
  lzf::decodeBlocks(compressed, expected, 100, blockBytes, [&](std::string_view block) {
    if (largestBlock) *largestBlock = std::max(*largestBlock, block.size());
    out += block;
  });
  return out;
}

std::string failureOf(const std::string& compressed, std::uint64_t expected) {
  try {
    decode(compressed, expected, 4096);
  } catch (const parse::ParseFailure& failure) {
    return failure.what();
  }
  return "";
}

TEST(LzfBlocks, DecodesAsLiblzfDoesWhateverTheBlockSize) {
  const std::string plain = plainBytes(300000, 1);
  const std::string compressed = compress(plain);
  ASSERT_FALSE(compressed.empty());
  ASSERT_LT(compressed.size(), plain.size() / 2);  // the references are exercised
  std::string byLiblzf(plain.size(), '\0');
  ASSERT_EQ(pcl::lzfDecompress(compressed.data(), static_cast<unsigned>(compressed.size()), byLiblzf.data(),
                               static_cast<unsigned>(byLiblzf.size())),
            plain.size());
  ASSERT_EQ(byLiblzf, plain);
  for (const std::size_t block : {1UL, 7UL, 4096UL, 8192UL, 100000UL, 1UL << 24}) {
    std::size_t largest = 0;
    EXPECT_EQ(decode(compressed, plain.size(), block, &largest), plain) << block;
    // A block holds at most its size and one instruction's output.
    EXPECT_LE(largest, block + 264) << block;
  }
}

TEST(LzfBlocks, CorruptStreamsAreRefusedWithTheirByte) {
  const std::string plain = plainBytes(20000, 2);
  const std::string compressed = compress(plain);
  // Cut inside: the stream ends early, or an instruction is cut.
  EXPECT_THAT(failureOf(compressed.substr(0, compressed.size() / 2), plain.size()), HasSubstr("corrupt LZF data"));
  // Claims more than it decodes to, and less.
  EXPECT_THAT(failureOf(compressed, plain.size() + 1), HasSubstr("the stream ends early"));
  EXPECT_THAT(failureOf(compressed, plain.size() - 1), HasSubstr("more output than the header's size"));
  // A reference as the first instruction reaches before the output's start:
  // control 0x20 (length 1 + 2, distance high bits 0), low byte 0.
  EXPECT_THAT(failureOf(std::string("\x20\x00", 2), 3), HasSubstr("byte 100: corrupt LZF data: a back-reference before"));
  // A literal run longer than what is left of the stream.
  EXPECT_THAT(failureOf(std::string("\x05" "abc", 4), 6), HasSubstr("byte 100: corrupt LZF data: a literal run cut"));
  // A long reference cut before its length byte.
  EXPECT_THAT(failureOf(std::string("\x00" "a" "\xE0", 3), 20), HasSubstr("byte 102: corrupt LZF data: a back-reference cut"));
}

}  // namespace
}  // namespace apo
