// Shared by the reader tests: what a reader says about malformed bytes.
#pragma once

#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <gtest/gtest.h>

#include <string>
#include <string_view>

namespace apo::test {

// The ParseFailure message `read` throws on `bytes`; a test failure (and an
// empty string) if it accepts them.
inline std::string readerFailure(Scan (*read)(std::string_view), std::string_view bytes) {
  try {
    read(bytes);
  } catch (const parse::ParseFailure& failure) {
    return failure.what();
  }
  ADD_FAILURE() << "the reader accepted " << bytes.size() << " malformed bytes";
  return {};
}

}  // namespace apo::test
