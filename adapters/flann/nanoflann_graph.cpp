// The k-nearest-neighbour graph of a point set, with nanoflann: on a 1M-point
// scan it finds 47 neighbours per point in about half the time FLANN's batch
// search takes (docs/benchmarks.md, "Raw acquisitions"), and it is the one
// search ingest's normals make (PCA and the orientation graph share it).
//
// NANOFLANN_FIRST_MATCH makes the result set order equal distances by the
// lower index, so a row depends on the points alone, not on the tree's shape.
#define NANOFLANN_FIRST_MATCH
#include <nanoflann.hpp>

#include "adapters/flann/flann_search.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

namespace apo {
namespace {

// nanoflann reads the points in place.
struct PointsView {
  const std::vector<Vec3f>& points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t axis) const { return points[i][static_cast<int>(axis)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsView>, PointsView, 3,
                                                 std::uint32_t>;
constexpr std::size_t kLeafSize = 20;
constexpr std::size_t kRowsPerTask = 4096;

// Hands `visit(q, found, squaredDistances, count)` the k nearest reference
// points of every query q (`queryAt(q)`: its coordinates), nearest first,
// searched on every core. Each query is answered by exactly one task, so the
// answers do not depend on the number of threads.
template <class QueryAt, class Visit>
void forEachNearest(const std::vector<Vec3f>& reference, std::size_t queryCount, std::size_t k, QueryAt&& queryAt,
                    Visit&& visit) {
  const PointsView view{reference};
  const Tree tree(3, view, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queryCount, kRowsPerTask), [&](const auto& range) {
    std::vector<std::uint32_t> found(k);
    std::vector<float> squaredDistances(k);
    for (std::size_t q = range.begin(); q < range.end(); ++q) {
      nanoflann::KNNResultSet<float, std::uint32_t> results(k);
      results.init(found.data(), squaredDistances.data());
      tree.findNeighbors(results, queryAt(q), nanoflann::SearchParams());
      visit(q, found.data(), squaredDistances.data(), results.size());
    }
  });
}

}  // namespace

Result<flann_adapter::NeighbourGraph> flann_adapter::nearestNeighbourGraph(const std::vector<Vec3f>& points,
                                                                           std::size_t k) {
  NeighbourGraph graph;
  graph.k = points.empty() ? 0 : std::min(k, points.size() - 1);
  if (graph.k == 0) return graph;
  if (points.size() > std::numeric_limits<std::uint32_t>::max())
    return badInput("{} points: more than a 32-bit neighbour index can hold", points.size());
  return catchLibraryErrors("nanoflann k-nearest graph", [&]() -> Result<NeighbourGraph> {
    graph.neighbours.resize(points.size() * graph.k);
    // Row i: the k + 1 nearest points of point i with i itself left out
    // (among more than k + 1 coincident points it may be missing; then the
    // k nearest found).
    forEachNearest(
        points, points.size(), graph.k + 1, [&](std::size_t i) { return points[i].data(); },
        [&](std::size_t i, const std::uint32_t* found, const float*, std::size_t count) {
          std::uint32_t* row = &graph.neighbours[i * graph.k];
          std::size_t written = 0;
          for (std::size_t j = 0; j < count && written < graph.k; ++j)
            if (found[j] != i) row[written++] = found[j];
        });
    return std::move(graph);
  });
}

Result<flann_adapter::NearestRows> flann_adapter::nearestOf(const std::vector<Vec3f>& reference,
                                                           const std::vector<Vec3f>& queries, std::size_t k) {
  NearestRows rows;
  rows.k = std::min(k, reference.size());
  if (rows.k == 0 || queries.empty()) return rows;
  if (reference.size() > std::numeric_limits<std::uint32_t>::max())
    return badInput("{} points: more than a 32-bit neighbour index can hold", reference.size());
  return catchLibraryErrors("nanoflann k-nearest search", [&]() -> Result<NearestRows> {
    rows.indices.resize(queries.size() * rows.k);
    rows.squaredDistances.resize(queries.size() * rows.k);
    forEachNearest(
        reference, queries.size(), rows.k, [&](std::size_t q) { return queries[q].data(); },
        [&](std::size_t q, const std::uint32_t* found, const float* squaredDistances, std::size_t count) {
          std::copy(found, found + count, &rows.indices[q * rows.k]);
          std::copy(squaredDistances, squaredDistances + count, &rows.squaredDistances[q * rows.k]);
        });
    return std::move(rows);
  });
}

}  // namespace apo
