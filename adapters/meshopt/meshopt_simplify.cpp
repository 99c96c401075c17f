#include "adapters/meshopt/meshopt_simplify.h"

#include "core/mesh_edges.h"
#include "core/mesh_edit.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <numeric>
#include <utility>
#include <vector>

namespace apo::meshopt_adapter {
namespace {

// meshoptimizer's collapses can fold a thin region into a "fin": two
// triangles over the same three vertices, back to back, whose edges are then
// shared by four triangles (about one per 400 faces on a 100,000-face
// sphere). Such pairs enclose nothing: every copy is removed, which leaves
// the surface around them manifold for CGAL. Returns how many were removed.
std::uint64_t dropCoincidentTriangles(std::vector<Triangle>& triangles) {
  std::vector<std::pair<Triangle, std::uint32_t>> sorted;  // (vertex set, index)
  sorted.reserve(triangles.size());
  for (std::uint32_t i = 0; i < triangles.size(); ++i) {
    Triangle key = triangles[i];
    std::sort(key.begin(), key.end());
    sorted.emplace_back(key, i);
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<char> drop(triangles.size(), 0);
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i + 1;
    while (j < sorted.size() && sorted[j].first == sorted[i].first) ++j;
    if (j - i > 1)
      for (std::size_t k = i; k < j; ++k) drop[sorted[k].second] = 1;
    i = j;
  }
  std::vector<Triangle> kept;
  kept.reserve(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (!drop[i]) kept.push_back(triangles[i]);
  const std::uint64_t removed = triangles.size() - kept.size();
  triangles = std::move(kept);
  return removed;
}

// Pieces joined to the rest only through a vertex or a non-manifold edge
// (meshoptimizer pinches off small closed pockets the same way it folds
// fins), of at most this many triangles, are removed.
constexpr std::size_t kMaxPocketTriangles = 64;

// Returns how many pockets were removed.
std::uint64_t dropPinchedPockets(std::vector<Triangle>& triangles, std::size_t vertexCount) {
  // Triangles joined through edges that exactly two of them share.
  DisjointSets pieces(triangles.size());
  const std::vector<TriangleSide> sides = sortedSides(triangles);
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    if (last - first == 2) pieces.unite(sides[first].triangle, sides[first + 1].triangle);
  });
  const auto root = [&](std::uint32_t i) { return pieces.find(i); };
  std::vector<std::uint32_t> size(triangles.size(), 0);
  for (std::uint32_t i = 0; i < triangles.size(); ++i) ++size[root(i)];
  // A small piece touching another piece at a vertex is a pocket.
  std::vector<std::uint32_t> pieceAtVertex(vertexCount, ~0u);
  std::vector<char> pocket(triangles.size(), 0);
  for (std::uint32_t i = 0; i < triangles.size(); ++i)
    for (std::uint32_t v : triangles[i]) {
      const std::uint32_t piece = root(i);
      std::uint32_t& seen = pieceAtVertex[v];
      if (seen == ~0u || seen == piece) {
        seen = piece;
        continue;
      }
      const std::uint32_t smaller = size[piece] < size[seen] || (size[piece] == size[seen] && piece > seen) ? piece : seen;
      if (size[smaller] <= kMaxPocketTriangles) pocket[smaller] = 1;
    }
  std::uint64_t pockets = 0;
  for (std::uint32_t i = 0; i < triangles.size(); ++i) pockets += root(i) == i && pocket[i];
  std::vector<Triangle> kept;
  kept.reserve(triangles.size());
  for (std::uint32_t i = 0; i < triangles.size(); ++i)
    if (!pocket[root(i)]) kept.push_back(triangles[i]);
  triangles = std::move(kept);
  return pockets;
}

}  // namespace

Result<QuickCollapse> quickCollapse(const Scan& mesh, std::uint64_t targetFaces, double maxRelativeError) {
  const std::size_t vertexCount = mesh.points.size();
  for (const Triangle& t : mesh.triangles)
    for (std::uint32_t v : t)
      if (v >= vertexCount) return badInput("triangle names vertex {} of {}", v, vertexCount);
  if (mesh.triangles.empty()) {
    QuickCollapse unchanged{mesh};
    unchanged.sourceVertex.resize(vertexCount);
    std::iota(unchanged.sourceVertex.begin(), unchanged.sourceVertex.end(), 0u);
    return unchanged;
  }
  return catchLibraryErrors("meshoptimizer simplify", [&]() -> Result<QuickCollapse> {
    std::vector<unsigned int> indices;
    indices.reserve(3 * mesh.triangles.size());
    for (const Triangle& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
    std::vector<unsigned int> kept(indices.size());
    float error = 0.0f;
    static_assert(sizeof(Vec3f) == 3 * sizeof(float), "positions are read as packed floats");
    const std::size_t keptCount = meshopt_simplify(
        kept.data(), indices.data(), indices.size(), mesh.points.positions.front().data(), vertexCount, sizeof(Vec3f),
        static_cast<std::size_t>(3 * targetFaces), static_cast<float>(maxRelativeError), 0, &error);
    QuickCollapse result;
    result.relativeError = error;
    result.mesh.points = mesh.points;
    result.mesh.origin = mesh.origin;
    result.mesh.triangles.resize(keptCount / 3);
    for (std::size_t i = 0; i < result.mesh.triangles.size(); ++i)
      result.mesh.triangles[i] = {kept[3 * i], kept[3 * i + 1], kept[3 * i + 2]};
    result.coincidentTriangles = dropCoincidentTriangles(result.mesh.triangles);
    result.pockets = dropPinchedPockets(result.mesh.triangles, vertexCount);
    std::vector<char> used(vertexCount, 0);
    for (const Triangle& t : result.mesh.triangles)
      for (std::uint32_t v : t) used[v] = 1;
    for (std::uint32_t v = 0; v < vertexCount; ++v)
      if (used[v]) result.sourceVertex.push_back(v);
    dropUnreferencedVertices(result.mesh);  // keeps the order, so vertex i is sourceVertex[i]
    return result;
  });
}

}  // namespace apo::meshopt_adapter
