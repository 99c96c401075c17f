// Internal to ingest: a range grid (one view of a scanner or depth camera,
// a vertex per cell that has a return) triangulated as range software does,
// for the virtual scanner's soups and for organised clouds.
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo::range_grid {

inline constexpr std::uint32_t kNoReturn = ~0u;

// A grid cell is triangulated only when its edges are at most this many
// times the ray spacing at its depth (no bridge across a depth jump) and its
// triangles face the scanner by at least this cosine (grazing triangles
// dropped, as range software does).
inline constexpr float kMaxEdgeInSpacings = 4.0f;
inline constexpr float kMinFacingCosine = 0.1f;

struct GridTriangles {
  std::uint64_t candidates = 0;  // triangles (two per cell) whose three corners have a return
  std::uint64_t triangles = 0;   // of those, added
  std::uint64_t refused = 0;     // of those, refused: across a depth jump or grazing
};

// Adds to `mesh` the triangles of a width x height grid whose cell (row,
// column) is vertex index[row * width + column] of `mesh` (kNoReturn: no
// return there), seen from `sensor` with rays `angularStep` radians apart;
// each triangle wound to face the sensor.
GridTriangles triangulate(const std::vector<std::uint32_t>& index, std::size_t width, std::size_t height,
                          const Vec3f& sensor, float angularStep, Scan& mesh);

// The angle between neighbouring rays of an organised cloud seen from
// `sensor`, estimated from the data: the median, over row and column
// neighbours that both have a return, of their distance over their range.
// 0 when no two neighbours have returns.
float medianAngularStep(const std::vector<Vec3f>& positions, std::size_t width, const Vec3f& sensor);

}  // namespace apo::range_grid
