// libFuzzer target: the LAS reader on LAZ files (ingest/laz_decoder.cpp and
// the item decoders under it), seeded from fuzz/corpus/laz/.
#include "fuzz/scan_reader_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return apo::fuzz::fuzzReader(apo::readers::readLas, data, size);
}
