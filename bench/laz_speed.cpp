// Our LAZ decoder's speed on one file, for bench/laz_bench.sh: the best wall
// time of RUNS decompressions (readers::lasPointRecords: header, LASzip VLR,
// chunk table and every point record, the file already in memory), printed
// as JSON like tests/ingest/lazperf_decode.mjs prints laz-perf's.
//   build/laz_speed FILE.laz [RUNS]
#include "core/file_io.h"
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: laz_speed FILE.laz [RUNS]\n");
    return 2;
  }
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const auto bytes = apo::readFileBytes(argv[1]);
  if (!bytes.ok()) {
    std::fprintf(stderr, "%s\n", bytes.error().message.c_str());
    return 1;
  }
  double best = 1e300;
  std::string records;
  try {
    for (int run = 0; run < runs; ++run) {
      const auto start = std::chrono::steady_clock::now();
      records = apo::readers::lasPointRecords(*bytes);
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  } catch (const apo::parse::ParseFailure& failure) {
    std::fprintf(stderr, "%s\n", failure.what());
    return 1;
  }
  std::uint16_t recordLength = 0;
  std::memcpy(&recordLength, bytes->data() + 105, 2);
  fmt::print("{{\"points\":{},\"recordLength\":{},\"sha256\":\"{}\",\"seconds\":{}}}\n", records.size() / recordLength,
             recordLength, apo::sha256OfBytes(records), best);
  return 0;
}
