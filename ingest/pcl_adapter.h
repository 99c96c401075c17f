// Internal to ingest: the only door to PCL. Plain vectors in and out, so no
// PCL type leaks and only pcl_adapter.cpp pays for PCL's headers.
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo::pcl_adapter {

// PCL StatisticalOutlierRemoval: keep[i] is 1 when point i's mean distance to
// its k neighbours is within mean + stdDevs * stddev over the cloud.
std::vector<char> statisticalOutlierKeepMask(const std::vector<Vec3f>& points, int k, double stdDevs);

// PCL NormalEstimationOMP over k nearest neighbours (PCA of the neighbourhood).
// Normals are unit length and face `viewpoint`; NaN where PCL could not fit a
// plane. Deterministic: each point's normal depends on its neighbours only.
std::vector<Vec3f> estimateNormals(const std::vector<Vec3f>& points, int k, const Vec3f& viewpoint);

// The k nearest neighbours (the point itself first) of points[queries[i]], by
// an exact k-d tree search (PCL KdTreeFLANN).
std::vector<std::vector<int>> nearestNeighbours(const std::vector<Vec3f>& points,
                                                const std::vector<std::uint32_t>& queries, int k);

// Index into `reference` of the nearest reference point to each query
// (exact k-d tree search; `reference` must not be empty).
std::vector<int> nearestInReference(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

}  // namespace apo::pcl_adapter
