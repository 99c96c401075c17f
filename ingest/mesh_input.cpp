#include "ingest/mesh_input.h"

#include "adapters/flann/flann_search.h"
#include "core/mesh_edges.h"
#include "core/surface_limits.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>
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
  const std::vector<TriangleSide> sides = sortedSides(mesh.triangles);
  std::size_t unique = 0, boundary = 0;
  std::vector<float> lengths;
  EdgeFigures figures;
  figures.onBoundary.assign(mesh.points.size(), 0);
  const auto& p = mesh.points.positions;
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    const TriangleSide& side = sides[first];
    ++unique;
    if (last - first == 1) {
      ++boundary;
      figures.onBoundary[side.from()] = figures.onBoundary[side.to()] = 1;
    }
    lengths.push_back((p[side.from()] - p[side.to()]).norm());
  });
  if (unique == 0) return figures;
  figures.boundaryFraction = static_cast<double>(boundary) / static_cast<double>(unique);
  const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
  std::nth_element(lengths.begin(), middle, lengths.end());
  figures.medianLength = *middle;
  return figures;
}

// Per pair of pieces (lower piece first): vertices of one lying on the
// other, facing the same way and facing opposite ways.
struct PairVotes {
  std::uint64_t same = 0, opposite = 0;
};

std::map<std::pair<std::uint32_t, std::uint32_t>, PairVotes> coincidentVotes(
    const Scan& mesh, const std::vector<std::uint32_t>& piece, const std::vector<Vec3f>& normals,
    const flann_adapter::NeighbourGraph& graph, double medianEdge) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, PairVotes> votes;
  const auto& p = mesh.points.positions;
  const double across = kCoincidentEdgeLengths * medianEdge, along = kOverlapEdgeLengths * medianEdge;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    if (piece[i] == MeshPieces::kNoPiece) continue;
    const Vec3f n = normals[i].normalized();
    for (std::size_t k = 0; k < graph.k; ++k) {
      const std::uint32_t j = graph.neighbours[i * graph.k + k];
      if (piece[j] == MeshPieces::kNoPiece || piece[j] == piece[i]) continue;
      const Vec3f d = p[j] - p[i];
      const double offset = std::abs(d.dot(n));
      const double cosine = n.dot(normals[j].normalized());
      if (offset > across || d.squaredNorm() - offset * offset > along * along || std::abs(cosine) < kSameFacingCosine)
        continue;
      PairVotes& vote = votes[{std::min(piece[i], piece[j]), std::max(piece[i], piece[j])}];
      (cosine > 0.0 ? vote.same : vote.opposite) += 1;
      break;  // one vote per vertex: its nearest coincident neighbour
    }
  }
  return votes;
}

// Each group of coincident pieces made to face one way: the pairs, strongest
// first, join pieces into groups with a parity (turned relative to the
// group's first piece or not), a union-find; a pair contradicting stronger
// ones is counted and left. Then each group turns the side of fewer vertices.
SheetAgreement agreeCoincidentSheets(const Scan& mesh, const MeshPieces& pieces, const std::vector<Vec3f>& normals,
                                     const flann_adapter::NeighbourGraph& graph, double medianEdge) {
  SheetAgreement agreement;
  struct Pair {
    std::uint64_t strength;
    std::uint32_t a, b;
    bool opposed;
  };
  std::vector<Pair> pairs;
  for (const auto& [key, vote] : coincidentVotes(mesh, pieces.ofVertex, normals, graph, medianEdge)) {
    const std::uint64_t total = vote.same + vote.opposite, margin = std::max(vote.same, vote.opposite);
    if (total < kMinCoincidentVertices || 4 * margin < 3 * total) continue;  // too few, or no clear verdict
    pairs.push_back({margin, key.first, key.second, vote.opposite > vote.same});
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return std::tie(y.strength, x.a, x.b) < std::tie(x.strength, y.a, y.b);
  });
  std::vector<std::uint32_t> parent(pieces.count);
  std::iota(parent.begin(), parent.end(), 0u);
  std::vector<char> parity(pieces.count, 0);  // turned relative to the parent
  const auto find = [&](std::uint32_t x) {
    char turned = 0;
    while (parent[x] != x) {
      turned ^= parity[x];
      x = parent[x];
    }
    return std::pair{x, turned};
  };
  for (const Pair& pair : pairs) {
    ++agreement.coincidentPairs;
    agreement.opposedPairs += pair.opposed;
    const auto [ra, ta] = find(pair.a);
    const auto [rb, tb] = find(pair.b);
    const char wanted = pair.opposed ? 1 : 0;  // turned relative to each other
    if (ra == rb) {
      agreement.conflicts += (ta ^ tb) != wanted;
      continue;
    }
    parent[std::max(ra, rb)] = std::min(ra, rb);
    parity[std::max(ra, rb)] = static_cast<char>(ta ^ tb ^ wanted);
  }
  std::vector<std::uint64_t> verticesOf(pieces.count, 0);
  for (const std::uint32_t v : pieces.ofVertex)
    if (v != MeshPieces::kNoPiece) ++verticesOf[v];
  // Per group: vertices on the side to turn if its root stays.
  std::vector<std::uint64_t> groupVertices(pieces.count, 0), turnedIfRootStays(pieces.count, 0);
  std::vector<char> turnedFromRoot(pieces.count, 0);
  std::vector<std::uint32_t> rootOf(pieces.count);
  for (std::uint32_t c = 0; c < pieces.count; ++c) {
    const auto [root, turned] = find(c);
    rootOf[c] = root;
    turnedFromRoot[c] = turned;
    groupVertices[root] += verticesOf[c];
    if (turned) turnedIfRootStays[root] += verticesOf[c];
  }
  std::vector<char> turnPiece(pieces.count, 0);
  for (std::uint32_t c = 0; c < pieces.count; ++c) {
    const std::uint32_t root = rootOf[c];
    const bool rootTurns = 2 * turnedIfRootStays[root] > groupVertices[root];
    turnPiece[c] = static_cast<char>(turnedFromRoot[c] ^ rootTurns);
    agreement.turnedPieces += turnPiece[c];
  }
  agreement.turnVertex.assign(mesh.points.size(), 0);
  for (std::size_t v = 0; v < pieces.ofVertex.size(); ++v)
    if (pieces.ofVertex[v] != MeshPieces::kNoPiece && turnPiece[pieces.ofVertex[v]]) {
      agreement.turnVertex[v] = 1;
      ++agreement.turnedVertices;
    }
  return agreement;
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
  evidence.sheets = agreeCoincidentSheets(mesh, pieces, normals, *graph, edges.medianLength);
  // A mesh of fewer vertices than a surface is reconstructed from stays one
  // surface, whatever its pieces do.
  evidence.looksLikeScans =
      evidence.overlapFraction >= kScansOverlapFraction && referenced >= kMinReconstructionPoints;
  return evidence;
}

}  // namespace apo::mesh_input
