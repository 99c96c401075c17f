// Between the PCL adapter and its module (apo-pcl.so, beside apo-engine),
// which alone links PCL and is loaded when a job needs it: linked into
// apo-engine, PCL's six libraries took 35 ms of every start, most of a
// command such as `apo lookup` (docs/benchmarks.md). Plain C types across:
// the module links nothing of apo, so the two never hold two copies of it.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

// Points are packed x, y, z floats. Each function returns 0, or 1 with a
// NUL-terminated message in `error` (at most `errorBytes` bytes).
struct ApoPclModule {
  int version;  // kApoPclModuleVersion
  // keep[i] = 1 where point i stays (StatisticalOutlierRemoval).
  int (*statisticalOutlierKeepMask)(const float* xyz, std::size_t count, int k, double stdDevs, char* keep, char* error,
                                    std::size_t errorBytes);
  // neighbours[q * k + j]: the j-th nearest point to point queries[q] (itself
  // first), -1 past the neighbours found.
  int (*nearestNeighbours)(const float* xyz, std::size_t count, const std::uint32_t* queries, std::size_t queryCount,
                           int k, int* neighbours, char* error, std::size_t errorBytes);
  // nearest[q]: the reference point nearest to query q.
  int (*nearestInReference)(const float* reference, std::size_t referenceCount, const float* queries,
                            std::size_t queryCount, int* nearest, char* error, std::size_t errorBytes);
};

// The module's one exported symbol.
const ApoPclModule* apoPclModule();
}

namespace apo::pcl_adapter {
constexpr int kApoPclModuleVersion = 1;
constexpr const char* kApoPclModuleFile = "apo-pcl.so";
constexpr const char* kApoPclModuleSymbol = "apoPclModule";
}  // namespace apo::pcl_adapter
