// libFuzzer target: the LAS reader (ingest/las_reader.cpp).
#include "fuzz/scan_reader_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return apo::fuzz::fuzzReader(apo::readers::readLas, data, size);
}
