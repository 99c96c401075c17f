// libFuzzer target: the XYZ reader (ingest/xyz_reader.cpp), whole and a run of lines at a time.
#include "fuzz/scan_reader_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(apo::readers::readXyz, data, size);
  return apo::fuzz::fuzzTextRuns(apo::readers::xyzTextLayout, apo::readers::isXyzDataLine, apo::readers::readXyzLines, data, size);
}
