// The FLANN adapter: exact k-d tree searches for every nearest-point job of
// the project. FLANN here: M's closest point on a mesh for the bake, the
// nearest input points for reconstruct; nanoflann (nanoflann_search.cpp):
// the points' nearest point and disc radii, the k-nearest graph.
//
// Thread safety (read in FLANN 1.9.2, flann/flann.hpp,
// flann/algorithms/nn_index.h and kdtree_single_index.h): Index::knnSearch is
// const and forwards to NNIndex::knnSearch, whose result set is a local of the
// call; KDTreeSingleIndex::findNeighbors and searchLevel are const, keep their
// per-dimension distances in a local vector and only read the tree, the
// reordered copy of the points and the `removed_` flag (never set here: we
// remove no point). No mutable members, no statics. So one built index can
// answer single queries from several threads at once, as long as each call
// has its own output buffers (here: arrays on its stack).
#include "adapters/flann/flann_search.h"
#include "adapters/flann/nanoflann_search.h"

#include "core/triangle_geometry.h"

#include <flann/flann.hpp>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

namespace apo {
namespace {

// FLANN reads our points in place, as rows of three floats.
static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");

using KdTree = flann::Index<flann::L2_Simple<float>>;  // distances are squared

flann::Matrix<float> pointRows(const Vec3f* first, std::size_t count) {
  // FLANN takes a mutable matrix but only reads queries, and (with the default
  // `reorder`) copies the reference points into its own storage at build time.
  return {const_cast<float*>(first->data()), count, 3};
}

// Exact k-NN: one k-d tree searched to the end (KDTreeSingleIndex ignores
// `checks`, and eps = 0). Randomised trees are not used: they returned a wrong
// nearest neighbour 58% of the time on our data (../shared/STACK.md), and
// both the closest point and the spacing must be exact to be testable.
std::unique_ptr<KdTree> buildKdTree(const std::vector<Vec3f>& points) {
  auto tree = std::make_unique<KdTree>(pointRows(points.data(), points.size()), flann::KDTreeSingleIndexParams());
  tree->buildIndex();
  return tree;
}

flann::SearchParams exactSearch(int cores) {
  flann::SearchParams params;
  params.eps = 0.0f;
  params.cores = cores;
  return params;
}

// The k nearest tree points of one query, nearest first, into the caller's
// buffers (k at most the tree's size). Safe to call concurrently (see top).
// False if FLANN threw (it allocates its result set): the callers run on
// worker threads, where nothing may escape.
bool searchOne(const KdTree& tree, const Vec3f& query, std::size_t k, std::size_t* indices, float* squaredDistances) {
  std::array<float, 3> row = {query.x(), query.y(), query.z()};
  flann::Matrix<std::size_t> indexRow(indices, 1, k);
  flann::Matrix<float> distanceRow(squaredDistances, 1, k);
  try {
    tree.knnSearch(flann::Matrix<float>(row.data(), 1, 3), indexRow, distanceRow, k, exactSearch(1));
    return true;
  } catch (...) {
    return false;
  }
}

// ---- Mesh: the closest point on the triangles around the nearest vertices --

// The triangles around each vertex, as compressed rows: vertex v's triangles
// are triangles[offsets[v] .. offsets[v + 1]).
struct VertexTriangles {
  std::vector<std::uint32_t> offsets, triangles;
};

VertexTriangles incidentTriangles(const std::vector<Triangle>& triangles, std::size_t vertexCount) {
  VertexTriangles incident;
  incident.offsets.assign(vertexCount + 1, 0);
  for (const Triangle& t : triangles)
    for (std::uint32_t v : t) ++incident.offsets[v + 1];
  for (std::size_t v = 0; v < vertexCount; ++v) incident.offsets[v + 1] += incident.offsets[v];
  incident.triangles.resize(incident.offsets.back());
  std::vector<std::uint32_t> next(incident.offsets.begin(), incident.offsets.end() - 1);
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (std::uint32_t v : triangles[i]) incident.triangles[next[v]++] = static_cast<std::uint32_t>(i);
  return incident;
}


class FlannMeshClosest final : public ClosestPointFinder {
 public:
  // Copies what it needs: `mesh` may go away afterwards.
  explicit FlannMeshClosest(const Scan& mesh)
      : positions_(mesh.points.positions),
        normals_(mesh.points.normals),
        triangles_(mesh.triangles),
        incident_(incidentTriangles(triangles_, positions_.size())) {
    buildVertexTree();
  }

  // Exact on the candidate triangles (those around the kNeighbours vertices
  // nearest the query), not a global guarantee: when the closest triangle has
  // no corner among those vertices (a query over the middle of a triangle much
  // larger than its neighbours, or far from the surface) the answer is a
  // farther point of M, never a nearer one. On even meshes (an icosphere, a
  // torus) the tests found it exact up to 10 edge lengths from the surface.
  std::optional<SurfacePoint> closest(const Vec3f& query) const override {
    std::array<std::size_t, kNeighbours> rows{};
    std::array<float, kNeighbours> squaredDistances{};
    const std::size_t k = std::min(kNeighbours, treeVertices_.size());
    if (!searchOne(*tree_, query, k, rows.data(), squaredDistances.data())) return std::nullopt;
    TrianglePoint best;
    std::uint32_t bestTriangle = 0;
    for (std::size_t i = 0; i < k; ++i) {
      const std::uint32_t vertex = treeVertices_[rows[i]];
      for (std::uint32_t j = incident_.offsets[vertex]; j < incident_.offsets[vertex + 1]; ++j)
        considerTriangle(query, incident_.triangles[j], best, bestTriangle);
    }
    return surfacePoint(best, triangles_[bestTriangle]);
  }

 private:
  // A vertex of a regular mesh has 6 neighbours: 8 nearest vertices reach past
  // the one-ring of the nearest, whose triangles hold the closest point on an
  // even mesh.
  static constexpr std::size_t kNeighbours = 8;

  // Only vertices that are in some triangle go into the tree, so every
  // neighbour brings candidates.
  void buildVertexTree() {
    std::vector<Vec3f> rows;
    for (std::size_t v = 0; v < positions_.size(); ++v)
      if (incident_.offsets[v + 1] > incident_.offsets[v]) {
        treeVertices_.push_back(static_cast<std::uint32_t>(v));
        rows.push_back(positions_[v]);
      }
    tree_ = buildKdTree(rows);  // FLANN keeps its own reordered copy of `rows`
  }

  // A triangle seen from two candidate vertices is simply measured twice; on
  // equal distances the lowest triangle index wins, so the answer does not
  // depend on the order in which FLANN returns the vertices.
  void considerTriangle(const Vec3f& query, std::uint32_t triangle, TrianglePoint& best, std::uint32_t& bestTriangle) const {
    const Triangle& t = triangles_[triangle];
    const TrianglePoint candidate = closestPointOnTriangle(query, positions_[t[0]], positions_[t[1]], positions_[t[2]]);
    if (candidate.squaredDistance < best.squaredDistance ||
        (candidate.squaredDistance == best.squaredDistance && triangle < bestTriangle)) {
      best = candidate;
      bestTriangle = triangle;
    }
  }

  // The vertex normals interpolated by the barycentrics; where they cancel
  // (opposite normals across a fold) the face normal is the honest answer.
  SurfacePoint surfacePoint(const TrianglePoint& point, const Triangle& t) const {
    const Vec3f interpolated =
        point.weights.x() * normals_[t[0]] + point.weights.y() * normals_[t[1]] + point.weights.z() * normals_[t[2]];
    if (interpolated.squaredNorm() > kMinSquaredNorm) return {point.position, interpolated.normalized()};
    const Vec3f face = (positions_[t[1]] - positions_[t[0]]).cross(positions_[t[2]] - positions_[t[0]]);
    if (face.squaredNorm() > 0.0f) return {point.position, face.normalized()};
    return {point.position, normals_[t[0]]};  // no area and cancelling normals: any corner's
  }

  static constexpr float kMinSquaredNorm = 1e-12f;

  std::vector<Vec3f> positions_, normals_;
  std::vector<Triangle> triangles_;
  VertexTriangles incident_;
  std::vector<std::uint32_t> treeVertices_;  // tree row -> vertex
  std::unique_ptr<KdTree> tree_;
};

Status checkDetail(const PointSet& points, const std::vector<Triangle>& triangles) {
  const std::size_t n = points.size();
  const bool mesh = !triangles.empty();
  const char* kind = mesh ? "mesh" : "point cloud";
  if (n == 0) return badInput("closest point: the detail {} is empty", kind);
  if (points.normals.size() != n)
    return badInput("closest point: the detail {} needs a unit normal per {}: {} {}, {} normals", kind,
                    mesh ? "vertex" : "point", n, mesh ? "vertices" : "points", points.normals.size());
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (std::uint32_t v : triangles[i])
      if (v >= n) return badInput("closest point: triangle {} of the detail mesh uses vertex {} of {}", i, v, n);
  return okStatus();
}

Status checkDetail(const Scan& detail) { return checkDetail(detail.points, detail.triangles); }

std::unique_ptr<ClosestPointFinder> newClosestPointFinder(const Scan& detail) {
  if (detail.isMesh()) return std::make_unique<FlannMeshClosest>(detail);
  return flann_adapter::nanoflannNearestPoint(detail.points);
}

// ---- Built on the first query ---------------------------------------------

// FLANN's k-d tree over M takes longer to build than Embree's BVH and the bake
// needs it only when both rays of a sample miss M (none do on a good m), so
// it is built on the first query, from whichever worker thread asks first.
// A failed build is logged once and every query then answers nothing.
class ClosestPointOnDemand final : public ClosestPointFinder {
 public:
  explicit ClosestPointOnDemand(const Scan& detail) : detail_(detail) {}

  std::optional<SurfacePoint> closest(const Vec3f& query) const override {
    std::call_once(built_, [this] {
      auto made = catchLibraryErrors("FLANN closest-point search over M", [this] { return newClosestPointFinder(detail_); });
      if (made) finder_ = std::move(made).value();
      else spdlog::error("{}", made.error().message);
    });
    if (!finder_) return std::nullopt;
    return finder_->closest(query);
  }

 private:
  const Scan& detail_;
  mutable std::once_flag built_;
  mutable std::unique_ptr<ClosestPointFinder> finder_;
};

// ---- Nearest reference point of each query (batch) -------------------------

struct Nearest {
  std::vector<std::size_t> indices;
  std::vector<float> squaredDistances;  // FLANN's L2 is the squared distance
};

// cores = 0 lets OpenMP use every core; each query writes its own row, so
// the result does not depend on the thread count.
Nearest searchNearest(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  Nearest nearest;
  nearest.indices.resize(queries.size());
  nearest.squaredDistances.resize(queries.size());
  const auto tree = buildKdTree(reference);
  flann::Matrix<std::size_t> indices(nearest.indices.data(), queries.size(), 1);
  flann::Matrix<float> distances(nearest.squaredDistances.data(), queries.size(), 1);
  tree->knnSearch(pointRows(queries.data(), queries.size()), indices, distances, 1, exactSearch(0));
  return nearest;
}

}  // namespace

Result<std::unique_ptr<ClosestPointFinder>> makeFlannClosestPoint(const Scan& detail) {
  APO_RETURN_IF_ERROR(checkDetail(detail));
  return catchLibraryErrors("FLANN closest-point search", [&] { return newClosestPointFinder(detail); });
}

Result<std::unique_ptr<ClosestPointFinder>> makeFlannClosestPointOnDemand(const Scan& detail) {
  APO_RETURN_IF_ERROR(checkDetail(detail));
  return std::unique_ptr<ClosestPointFinder>(std::make_unique<ClosestPointOnDemand>(detail));
}

// Fewer than two points have no spacing: their radii are 0, which the disc
// caster refuses. Coincident points can also make a spacing 0.
Result<std::vector<float>> discRadii(const PointSet& points) {
  if (points.size() < 2) return std::vector<float>(points.size(), 0.0f);
  return catchLibraryErrors("nanoflann disc radii", [&] { return flann_adapter::nanoflannDiscRadii(points.positions); });
}

Result<PointsSearch> makeFlannPointsSearch(const PointSet& points) {
  APO_RETURN_IF_ERROR(checkDetail(points, {}));
  return catchLibraryErrors("nanoflann search over the points", [&] { return flann_adapter::nanoflannPointsSearch(points); });
}

namespace flann_adapter {

// With no reference point, every distance is +infinity.
Result<std::vector<float>> nearestDistances(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  if (queries.empty()) return std::vector<float>{};
  if (reference.empty()) return std::vector<float>(queries.size(), std::numeric_limits<float>::infinity());
  return catchLibraryErrors("FLANN nearest search", [&] {
    std::vector<float> distances = searchNearest(reference, queries).squaredDistances;
    for (float& d : distances) d = std::sqrt(d);
    return distances;
  });
}

// With no reference point, every index is UINT32_MAX.
Result<std::vector<std::uint32_t>> nearestIndices(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  if (queries.empty()) return std::vector<std::uint32_t>{};
  if (reference.empty()) return std::vector<std::uint32_t>(queries.size(), std::numeric_limits<std::uint32_t>::max());
  return catchLibraryErrors("FLANN nearest search", [&] {
    const Nearest nearest = searchNearest(reference, queries);
    return std::vector<std::uint32_t>(nearest.indices.begin(), nearest.indices.end());
  });
}

}  // namespace flann_adapter
}  // namespace apo
