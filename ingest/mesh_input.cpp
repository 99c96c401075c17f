#include "ingest/mesh_input.h"

#include "adapters/flann/flann_search.h"

#include <algorithm>
#include <numeric>
#include <vector>

namespace apo::mesh_input {
namespace {

// Neighbours looked at for another piece's vertex.
constexpr std::size_t kNeighbours = 8;

// Piece of each vertex (through shared triangles); unused vertices alone.
std::vector<std::uint32_t> vertexPieces(const Scan& mesh, std::uint64_t& pieces) {
  std::vector<std::uint32_t> parent(mesh.points.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const Triangle& t : mesh.triangles)
    for (int corner = 1; corner < 3; ++corner) {
      const std::uint32_t a = root(t[0]), b = root(t[corner]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<char> used(mesh.points.size(), 0);
  for (const Triangle& t : mesh.triangles)
    for (std::uint32_t v : t) used[v] = 1;
  std::vector<std::uint32_t> piece(mesh.points.size());
  pieces = 0;
  for (std::uint32_t i = 0; i < piece.size(); ++i) {
    piece[i] = root(i);
    pieces += used[i] && piece[i] == i;
  }
  return piece;
}

struct EdgeFigures {
  double boundaryFraction = 0.0;
  double medianLength = 0.0;
};

EdgeFigures edgeFigures(const Scan& mesh) {
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = t[k], b = t[(k + 1) % 3];
      edges.push_back(std::min(a, b) << 32 | std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  std::size_t unique = 0, boundary = 0;
  std::vector<float> lengths;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    ++unique;
    boundary += j - i == 1;
    const auto& p = mesh.points.positions;
    lengths.push_back((p[edges[i] >> 32] - p[edges[i] & 0xFFFFFFFFu]).norm());
    i = j;
  }
  EdgeFigures figures;
  if (unique == 0) return figures;
  figures.boundaryFraction = static_cast<double>(boundary) / static_cast<double>(unique);
  const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
  std::nth_element(lengths.begin(), middle, lengths.end());
  figures.medianLength = *middle;
  return figures;
}

}  // namespace

Result<Evidence> judge(const Scan& mesh) {
  Evidence evidence;
  if (!mesh.isMesh()) return evidence;
  const std::vector<std::uint32_t> piece = vertexPieces(mesh, evidence.pieces);
  const EdgeFigures edges = edgeFigures(mesh);
  evidence.boundaryEdgeFraction = edges.boundaryFraction;
  evidence.medianEdgeLength = edges.medianLength;
  if (evidence.pieces < 2) return evidence;

  const auto graph = flann_adapter::nearestNeighbourGraph(mesh.points.positions, kNeighbours);
  if (!graph) return graph.error();
  const double reach2 = kOverlapEdgeLengths * kOverlapEdgeLengths * edges.medianLength * edges.medianLength;
  std::size_t overlapping = 0;
  const auto& p = mesh.points.positions;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t n = 0; n < graph->k; ++n) {
      const std::uint32_t j = graph->neighbours[i * graph->k + n];
      if (piece[j] != piece[i] && (p[j] - p[i]).squaredNorm() <= reach2) {
        ++overlapping;
        break;
      }
    }
  evidence.overlapFraction = static_cast<double>(overlapping) / static_cast<double>(p.size());
  evidence.looksLikeScans = evidence.overlapFraction >= kScansOverlapFraction;
  return evidence;
}

}  // namespace apo::mesh_input
