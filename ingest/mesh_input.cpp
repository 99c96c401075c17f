#include "ingest/mesh_input.h"

#include "adapters/flann/flann_search.h"
#include "core/surface_limits.h"

#include <algorithm>
#include <vector>

namespace apo::mesh_input {
namespace {

// Neighbours looked at for another piece's vertex.
constexpr std::size_t kNeighbours = 8;

struct EdgeFigures {
  double boundaryFraction = 0.0;
  double medianLength = 0.0;
  std::vector<char> onBoundary;  // per vertex: on an edge with one triangle
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
  EdgeFigures figures;
  figures.onBoundary.assign(mesh.points.size(), 0);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    ++unique;
    if (j - i == 1) {
      ++boundary;
      figures.onBoundary[edges[i] >> 32] = figures.onBoundary[edges[i] & 0xFFFFFFFFu] = 1;
    }
    const auto& p = mesh.points.positions;
    lengths.push_back((p[edges[i] >> 32] - p[edges[i] & 0xFFFFFFFFu]).norm());
    i = j;
  }
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
  const MeshPieces pieces = meshPieces(mesh);
  const std::vector<std::uint32_t>& piece = pieces.ofVertex;
  evidence.pieces = pieces.count;
  const EdgeFigures edges = edgeFigures(mesh);
  evidence.boundaryEdgeFraction = edges.boundaryFraction;
  evidence.medianEdgeLength = edges.medianLength;
  if (evidence.pieces < 2) return evidence;

  // Range scans are open sheets: a closed piece (a part of a model, however
  // close to the others) is a surface and does not count.
  std::vector<char> openPiece(pieces.count, 0);
  for (std::size_t i = 0; i < piece.size(); ++i)
    if (edges.onBoundary[i] && piece[i] != MeshPieces::kNoPiece) openPiece[piece[i]] = 1;
  const auto open = [&](std::uint32_t v) { return piece[v] != MeshPieces::kNoPiece && openPiece[piece[v]]; };
  const std::vector<Vec3f> normals =
      mesh.points.hasNormals() ? mesh.points.normals : areaWeightedVertexNormals(mesh);
  const auto graph = flann_adapter::nearestNeighbourGraph(mesh.points.positions, kNeighbours);
  if (!graph) return graph.error();
  const double reach2 = kOverlapEdgeLengths * kOverlapEdgeLengths * edges.medianLength * edges.medianLength;
  std::size_t overlapping = 0, referenced = 0;
  const auto& p = mesh.points.positions;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    if (!open(i)) continue;
    ++referenced;
    for (std::size_t n = 0; n < graph->k; ++n) {
      const std::uint32_t j = graph->neighbours[i * graph->k + n];
      if (open(j) && piece[j] != piece[i] && (p[j] - p[i]).squaredNorm() <= reach2 &&
          normals[i].dot(normals[j]) >= kSameFacingCosine * normals[i].norm() * normals[j].norm()) {
        ++overlapping;
        break;
      }
    }
  }
  evidence.overlapFraction = referenced ? static_cast<double>(overlapping) / static_cast<double>(referenced) : 0.0;
  // A mesh of fewer vertices than a surface is reconstructed from stays one
  // surface, whatever its pieces do.
  evidence.looksLikeScans =
      evidence.overlapFraction >= kScansOverlapFraction && referenced >= kMinReconstructionPoints;
  return evidence;
}

}  // namespace apo::mesh_input
