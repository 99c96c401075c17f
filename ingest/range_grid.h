// Internal to ingest: a range grid (one view of a scanner or depth camera,
// a vertex per cell that has a return) triangulated as range software does,
// for the virtual scanner's soups and for organised clouds.
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo::range_grid {

inline constexpr std::uint32_t kNoReturn = ~0u;

// A grid cell is triangulated only when its edges are at most a number of
// times the ray spacing at its depth (no bridge across a depth jump: at
// least kMaxEdgeInSpacings, more on a noisy frame, see GridSpacing) and its
// triangles face the scanner by at least kMinFacingCosine (grazing
// triangles dropped, as range software does).
inline constexpr float kMaxEdgeInSpacings = 4.0f;
inline constexpr float kMinFacingCosine = 0.1f;
// An edge of 1 / kMinFacingCosine spacings is already as grazing as the
// facing test allows: no noisier frame raises the jump test beyond it.
inline constexpr float kMaxEdgeInSpacingsCap = 1.0f / kMinFacingCosine;
// Neighbour distances (in ray spacings) of a frame's smooth surfaces spread
// with its noise and its grazing surfaces: the jump test lies this many
// times above their 95th percentile (depth jumps are the rare pairs beyond).
inline constexpr float kJumpOverSpread = 2.0f;

struct GridTriangles {
  std::uint64_t candidates = 0;  // triangles (two per cell) whose three corners have a return
  std::uint64_t triangles = 0;   // of those, added
  std::uint64_t refused = 0;     // of those, refused: across a depth jump or grazing
};

// Adds to `mesh` the triangles of a width x height grid whose cell (row,
// column) is vertex index[row * width + column] of `mesh` (kNoReturn: no
// return there), seen from `sensor` with rays `angularStep` radians apart,
// cells with an edge over `maxEdgeInSpacings` spacings refused; each
// triangle wound to face the sensor.
GridTriangles triangulate(const std::vector<std::uint32_t>& index, std::size_t width, std::size_t height,
                          const Vec3f& sensor, float angularStep, float maxEdgeInSpacings, Scan& mesh);

// An organised cloud's spacing, measured from the data over row and column
// neighbours that both have a return, seen from `sensor`: the angle between
// neighbouring rays (the median of their distance over their range; 0 when
// no two neighbours have returns), and the jump test: kJumpOverSpread times
// the 95th percentile of those distances in spacings, within
// [kMaxEdgeInSpacings, kMaxEdgeInSpacingsCap].
struct GridSpacing {
  float angularStep = 0.0f;
  float maxEdgeInSpacings = kMaxEdgeInSpacings;
};
GridSpacing measureSpacing(const std::vector<Vec3f>& positions, std::size_t width, const Vec3f& sensor);

}  // namespace apo::range_grid
