// Shared by the LAZ tests: what laz-perf (npm laz-perf, WASM, pinned in
// package-lock.json; run through tests/ingest/lazperf_decode.mjs) decodes
// from a file, the independent check of our LAZ decoder and encoder.
#pragma once

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace apo::test {

// Its point count, record length and the SHA-256 of all its records;
// {"error": ...} when it refuses the file.
inline nlohmann::json decodedByLazPerf(const std::filesystem::path& file) {
  const std::filesystem::path source(APO_SOURCE_DIR);
  const std::filesystem::path output =
      std::filesystem::path(testing::TempDir()) / (file.filename().string() + ".lazperf.json");
  const std::string command = "node '" + (source / "tests/ingest/lazperf_decode.mjs").string() + "' '" +
                              file.string() + "' > '" + output.string() + "'";
  const int status = std::system(command.c_str());
  std::ifstream in(output);
  const nlohmann::json read = nlohmann::json::parse(in, nullptr, false);
  EXPECT_EQ(status, 0) << command << ": " << read.dump().substr(0, 300);
  return read;
}

}  // namespace apo::test
