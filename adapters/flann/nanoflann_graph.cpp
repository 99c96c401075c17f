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

// Row i of the graph: the k + 1 nearest points of point i with i itself left
// out (among more than k + 1 coincident points it may be missing; then the
// k nearest found).
void fillRow(const Tree& tree, const std::vector<Vec3f>& points, std::size_t i, std::size_t k,
             std::vector<std::uint32_t>& found, std::vector<float>& squaredDistances, std::uint32_t* row) {
  nanoflann::KNNResultSet<float, std::uint32_t> results(k + 1);
  results.init(found.data(), squaredDistances.data());
  tree.findNeighbors(results, points[i].data(), nanoflann::SearchParams());
  std::size_t written = 0;
  for (std::size_t j = 0; j < results.size() && written < k; ++j)
    if (found[j] != i) row[written++] = found[j];
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
    const PointsView view{points};
    const Tree tree(3, view, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
    // Each row is written by exactly one task: the graph does not depend on
    // the number of threads.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), kRowsPerTask), [&](const auto& rows) {
      std::vector<std::uint32_t> found(graph.k + 1);
      std::vector<float> squaredDistances(graph.k + 1);
      for (std::size_t i = rows.begin(); i < rows.end(); ++i)
        fillRow(tree, points, i, graph.k, found, squaredDistances, &graph.neighbours[i * graph.k]);
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
    const PointsView view{reference};
    const Tree tree(3, view, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), kRowsPerTask), [&](const auto& range) {
      for (std::size_t q = range.begin(); q < range.end(); ++q) {
        nanoflann::KNNResultSet<float, std::uint32_t> results(rows.k);
        results.init(&rows.indices[q * rows.k], &rows.squaredDistances[q * rows.k]);
        tree.findNeighbors(results, queries[q].data(), nanoflann::SearchParams());
      }
    });
    return std::move(rows);
  });
}

}  // namespace apo
