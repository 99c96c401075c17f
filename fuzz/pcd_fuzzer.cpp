// libFuzzer target: the PCD reader (ingest/pcd_reader.cpp), whole and a run
// of lines at a time; and a binary_compressed body decoded a block at a time
// (ingest/lzf_blocks.h, as a file above --max-scan-points is read) against
// liblzf's decode of it whole: both refuse it, or both give the same bytes.
#include "adapters/pcl/pcl_points.h"
#include "fuzz/scan_reader_fuzzer.h"
#include "ingest/lzf_blocks.h"

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

// Decoded bodies larger than this are not compared (the fuzzer's memory).
constexpr std::uint64_t kMaxDecoded = std::uint64_t{1} << 24;

void decodeCompressedInBlocks(std::string_view file) {
  const auto layout = apo::readers::pcdCompressedLayout(file);
  if (!layout) return;
  apo::readers::PcdCompressedStream stream;
  try {
    stream = apo::readers::pcdCompressedStream(file.substr(layout->sizesAt), *layout, file.size());
  } catch (const apo::parse::ParseFailure&) {
    return;
  }
  if (stream.decodedBytes > kMaxDecoded) return;
  const std::string_view lzf = file.substr(layout->sizesAt + 8, stream.compressedBytes);
  std::string inBlocks;
  bool decoded = true;
  try {
    apo::lzf::decodeBlocks(lzf, stream.decodedBytes, 0, 100, [&](std::string_view block) { inBlocks += block; });
  } catch (const apo::parse::ParseFailure&) {
    decoded = false;
  }
  std::vector<char> whole(stream.decodedBytes);
  const bool byLiblzf = apo::pcl_adapter::lzfDecompress(lzf, whole);
  if (decoded != byLiblzf || (decoded && std::string_view(whole.data(), whole.size()) != inBlocks)) {
    std::fprintf(stderr, "LZF in blocks %s, liblzf %s, %s\n", decoded ? "decoded" : "refused",
                 byLiblzf ? "decoded" : "refused", decoded && byLiblzf ? "other bytes" : "");
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(apo::readers::readPcd, data, size);
  decodeCompressedInBlocks(std::string_view(reinterpret_cast<const char*>(data), size));
  return apo::fuzz::fuzzTextRuns(apo::readers::pcdTextLayout, apo::readers::isNonBlankLine, apo::readers::readPcdLines,
                                 data, size);
}
