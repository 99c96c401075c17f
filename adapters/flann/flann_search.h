// The FLANN adapter (target apo_flann): exact k-d tree searches (one tree,
// searched to the end; randomised trees were wrong 58% of the time on our
// data, ../shared/STACK.md) behind core's closest-point seam and as plain
// functions over point vectors; nanoflann for points (their nearest point
// and disc radii) and the k-nearest graph. Every
// library exception comes back as an Internal error; the closest-point finders, called from worker threads,
// answer nothing instead of throwing.
#pragma once

#include "core/closest_point.h"
#include "core/error.h"
#include "core/geometry.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace apo {

// The closest point of M, a mesh with a unit normal per vertex or points with
// unit normals. Mesh: the nearest point of the triangles around the 8 nearest
// vertices, normal interpolated from the vertex normals (exact on even meshes
// up to about 10 edge lengths from the surface; otherwise a farther point of
// M, never a nearer one). Points: the nearest point and its normal. BadInput
// when M is empty, lacks normals or has a triangle index out of range. The
// finder copies what it needs.
Result<std::unique_ptr<ClosestPointFinder>> makeFlannClosestPoint(const Scan& detail);
// The same, with the k-d tree built on the first query (the bake's fallback,
// rarely needed). `detail` must outlive the finder.
Result<std::unique_ptr<ClosestPointFinder>> makeFlannClosestPointOnDemand(const Scan& detail);

// Radius of each point's disc: its local spacing (the mean distance to its 6
// nearest other points). Fewer than two points get radius 0.
Result<std::vector<float>> discRadii(const PointSet& points);

// Points with unit normals: their disc radii and their closest-point finder
// (makeFlannClosestPoint's), from one k-d tree; the same BadInput cases.
struct PointsSearch {
  std::vector<float> radii;
  std::unique_ptr<ClosestPointFinder> closest;
};
Result<PointsSearch> makeFlannPointsSearch(const PointSet& points);

namespace flann_adapter {

// Distance from each query to its nearest reference point (+infinity when
// there is no reference point); batch search on every core, the result
// independent of their number.
Result<std::vector<float>> nearestDistances(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

// Index of each query's nearest reference point (UINT32_MAX when there is no
// reference point).
Result<std::vector<std::uint32_t>> nearestIndices(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

// Each point's k nearest other points, nearest first: row i of `neighbours`
// (k entries) for point i. k is reduced to the number of other points.
// nanoflann on every core, the result independent of their number; equal
// distances in the order of the points' indices. BadInput above 2^32 points.
struct NeighbourGraph {
  std::size_t k = 0;
  std::vector<std::uint32_t> neighbours;  // points.size() x k
};
Result<NeighbourGraph> nearestNeighbourGraph(const std::vector<Vec3f>& points, std::size_t k);

// The k nearest reference points of each query, nearest first (row q, k
// entries, with their squared distances); k is reduced to the number of
// reference points. nanoflann on every core, equal distances in index order.
struct NearestRows {
  std::size_t k = 0;
  std::vector<std::uint32_t> indices;    // queries.size() x k
  std::vector<float> squaredDistances;   // queries.size() x k
};
Result<NearestRows> nearestOf(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries, std::size_t k);

}  // namespace flann_adapter
}  // namespace apo
