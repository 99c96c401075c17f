// The PCL adapter (target apo_pcl): the point-cloud jobs ingest hands to PCL.
// Plain vectors in and out, so no PCL type leaks and only this adapter pays
// for PCL's headers; every PCL exception is caught here and returned as an
// Internal error.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace apo::pcl_adapter {

// PCL StatisticalOutlierRemoval: keep[i] is 1 when point i's mean distance to
// its k neighbours is within mean + stdDevs * stddev over the cloud.
Result<std::vector<char>> statisticalOutlierKeepMask(const std::vector<Vec3f>& points, int k, double stdDevs);

// The k nearest neighbours (the point itself first) of points[queries[i]], by
// an exact k-d tree search (PCL KdTreeFLANN).
Result<std::vector<std::vector<int>>> nearestNeighbours(const std::vector<Vec3f>& points,
                                                        const std::vector<std::uint32_t>& queries, int k);

// Index into `reference` of the nearest reference point to each query
// (exact k-d tree search; `reference` must not be empty).
Result<std::vector<int>> nearestInReference(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

// PCD's LZF decompressor (binary_compressed; liblzf, pcl_lzf.cpp): decodes
// `compressed` into exactly `out.size()` bytes; false when the data is corrupt
// or decodes to another size. Never reads or writes outside the two buffers.
bool lzfDecompress(std::string_view compressed, std::vector<char>& out);

}  // namespace apo::pcl_adapter
