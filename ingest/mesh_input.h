// Internal to ingest: is a mesh one surface, or a set of overlapping range
// scans stored as one soup (each scan's grid triangulated)? Simplifying such
// a soup gives a self-intersecting, faceted m; its points, reconstructed like
// any scan, give a good one.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo::mesh_input {

// A vertex counts as overlapping when another piece has a vertex within this
// many median edge lengths of it: two scans of the same surface, registered,
// lie within a few sample spacings of each other.
inline constexpr double kOverlapEdgeLengths = 3.0;
// The mesh is a set of scans when at least this fraction of its open
// pieces' vertices overlap another open piece, facing the same way (two
// scans of one surface agree on its normal; parts of a model meeting at a
// seam do not), and it has at least kMinReconstructionPoints of them
// (core/surface_limits.h). Closed pieces never count: range scans are open
// sheets.
inline constexpr double kScansOverlapFraction = 0.10;
// "Facing the same way": vertex normals within about 60 degrees.
inline constexpr double kSameFacingCosine = 0.5;

// Two pieces are one sheet seen from both sides where their vertices lie on
// each other: across the sheet within this many median edge lengths (range
// noise; a part thicker than this keeps two sides), along it within
// kOverlapEdgeLengths.
inline constexpr double kCoincidentEdgeLengths = 0.5;
// A pair of pieces is judged by at least this many such vertices, most of
// them agreeing on whether the two face the same way or opposite ways.
inline constexpr std::uint64_t kMinCoincidentVertices = 20;

// Scans of a part with no thickness (an open shell, a leaf, cloth) seen
// from both sides: each scan's faces face its own sensor, so coincident
// sheets face opposite ways and their points, reconstructed, cancel. The
// pieces of each group of coincident sheets are turned to face one way,
// whichever turns fewer vertices.
struct SheetAgreement {
  std::uint64_t coincidentPairs = 0;  // pairs of pieces judged coincident
  std::uint64_t opposedPairs = 0;     // of them, facing opposite ways before the turn
  std::uint64_t conflicts = 0;        // pairs whose verdict the stronger pairs overruled
  std::uint64_t turnedPieces = 0, turnedVertices = 0;
  std::vector<char> turnVertex;       // per vertex: its normal is to be reversed
};

struct Evidence {
  std::uint64_t pieces = 0;           // triangles connected through shared vertices
  double boundaryEdgeFraction = 0.0;  // edges with one triangle, of all edges
  double overlapFraction = 0.0;       // of the open pieces' vertices: within kOverlapEdgeLengths of another open piece
  double medianEdgeLength = 0.0;
  bool looksLikeScans = false;
  SheetAgreement sheets;              // what reading the mesh as scans would turn
};

// The figures and the verdict (deterministic). Internal error when the k-NN
// search fails.
Result<Evidence> judge(const Scan& mesh);

}  // namespace apo::mesh_input
