// libFuzzer target: the PCD reader (ingest/pcd_reader.cpp), whole and a run of lines at a time.
#include "fuzz/scan_reader_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(apo::readers::readPcd, data, size);
  return apo::fuzz::fuzzTextRuns(apo::readers::pcdTextLayout, apo::readers::isNonBlankLine, apo::readers::readPcdLines, data, size);
}
