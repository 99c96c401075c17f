// libFuzzer target: the PLY reader (ingest/ply_reader.cpp), whole and a run of lines at a time.
#include "fuzz/scan_reader_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(apo::readers::readPly, data, size);
  return apo::fuzz::fuzzTextRuns(apo::readers::plyTextLayout, apo::readers::isNonBlankLine, apo::readers::readPlyLines, data, size);
}
