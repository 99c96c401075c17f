// nanoflann's searches: the k-nearest-neighbour graph of a point set, the
// points' disc radii and their nearest point. On a 1M-point scan it finds 47
// neighbours per point in about half the time FLANN's batch search takes
// (docs/benchmarks.md, "Raw acquisitions"); the graph is the one search
// ingest's normals make (PCA and the orientation graph share it), and the
// radii are most of the bake of every point (docs/benchmarks.md, "Every
// point").
//
// NANOFLANN_FIRST_MATCH makes the result set order equal distances by the
// lower index, so a row depends on the points alone, not on the tree's shape.
#define NANOFLANN_FIRST_MATCH
#include <nanoflann.hpp>

#include "adapters/flann/nanoflann_search.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

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

// Hands `visit(q, found, squaredDistances, count)` the k nearest points of
// the tree to every query q (`queryAt(q)`: its coordinates), nearest first,
// searched on every core. Each query is answered by exactly one task, so the
// answers do not depend on the number of threads.
template <class QueryAt, class Visit>
void forEachNearestIn(const Tree& tree, std::size_t queryCount, std::size_t k, QueryAt&& queryAt, Visit&& visit) {
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

// The same, over a tree of the reference points.
template <class QueryAt, class Visit>
void forEachNearest(const std::vector<Vec3f>& reference, std::size_t queryCount, std::size_t k, QueryAt&& queryAt,
                    Visit&& visit) {
  const PointsView view{reference};
  const Tree tree(3, view, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  forEachNearestIn(tree, queryCount, k, std::forward<QueryAt>(queryAt), std::forward<Visit>(visit));
}

// ---- Disc radii -------------------------------------------------------------

// Local spacing = mean distance to this many nearest other points.
constexpr std::size_t kSpacingNeighbours = 6;

// Radius = kDiscRadiusFactor x spacing. Discs centred on samples of spacing s
// cover the plane when their radius reaches the sampling's covering radius:
// s / sqrt(3) = 0.58 s for a hexagonal lattice (whose mean 6-NN distance is
// s), s / sqrt(2) = 0.71 s for a square lattice (mean 6-NN distance 1.14 s,
// so factor 0.62), and for a scan-like grid of s along lines and 4 s across,
// half the cell diagonal 2.06 s against a mean 6-NN distance of 2 s (factor
// 1.03). 1.0 covers the first two with a 1.6x margin for uneven sampling and
// nearly the last. Larger overlap is cheap: a ray hits a neighbour's disc a
// hair before the surface and takes that neighbour's (nearly equal) normal,
// while a hole costs a closest-point fallback.
constexpr float kDiscRadiusFactor = 1.0f;

// A k-d tree over the points' positions, with their normals when they have
// them (its own copies): their disc radii and nearest point.
class PointsTree final : public ClosestPointFinder {
 public:
  PointsTree(std::vector<Vec3f> positions, std::vector<Vec3f> normals)
      : positions_(std::move(positions)),
        normals_(std::move(normals)),
        view_{positions_},
        tree_(3, view_, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize)) {}
  PointsTree(const PointsTree&) = delete;
  PointsTree& operator=(const PointsTree&) = delete;

  // Each point's disc radius (0 for a lone point). The k + 1 nearest of a
  // point include itself, at distance 0, first: it is skipped (among
  // coincident points another one at distance 0, the same sum).
  std::vector<float> discRadii() const {
    const std::size_t n = positions_.size();
    std::vector<float> radii(n, 0.0f);
    const std::size_t k = std::min(kSpacingNeighbours, n - 1);
    if (k == 0) return radii;
    forEachNearestIn(
        tree_, n, k + 1, [&](std::size_t i) { return positions_[i].data(); },
        [&](std::size_t i, const std::uint32_t*, const float* squaredDistances, std::size_t count) {
          double sum = 0.0;
          for (std::size_t j = 1; j < count; ++j) sum += std::sqrt(static_cast<double>(squaredDistances[j]));
          radii[i] = static_cast<float>(kDiscRadiusFactor * sum / static_cast<double>(k));
        });
    return radii;
  }

  // The nearest point and its normal (points with normals only).
  std::optional<SurfacePoint> closest(const Vec3f& query) const override {
    std::uint32_t nearest = 0;
    float squaredDistance = 0.0f;
    nanoflann::KNNResultSet<float, std::uint32_t> result(1);
    result.init(&nearest, &squaredDistance);
    tree_.findNeighbors(result, query.data(), nanoflann::SearchParams());
    if (result.size() == 0) return std::nullopt;
    return SurfacePoint{positions_[nearest], normals_[nearest]};
  }

 private:
  std::vector<Vec3f> positions_, normals_;
  PointsView view_;
  Tree tree_;
};

}  // namespace

std::vector<float> flann_adapter::nanoflannDiscRadii(const std::vector<Vec3f>& positions) {
  return PointsTree(positions, {}).discRadii();
}

PointsSearch flann_adapter::nanoflannPointsSearch(const PointSet& points) {
  auto tree = std::make_unique<PointsTree>(points.positions, points.normals);
  PointsSearch search;
  search.radii = tree->discRadii();
  search.closest = std::move(tree);
  return search;
}

std::unique_ptr<ClosestPointFinder> flann_adapter::nanoflannNearestPoint(const PointSet& points) {
  return std::make_unique<PointsTree>(points.positions, points.normals);
}

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
