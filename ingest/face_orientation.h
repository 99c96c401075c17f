// Internal to ingest: meshes whose faces are wound inward (the whole mesh, a
// piece, or one range scan of a soup: some converters of range grids write
// them so) turned outward, piece by piece, before anything else sees them.
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"

#include <cstdint>
#include <functional>
#include <memory>

namespace apo::faces {

struct FaceOrientation {
  std::uint64_t components = 0;         // pieces (triangles connected through shared vertices)
  std::uint64_t flippedComponents = 0;  // pieces found wound inward and flipped
  std::uint64_t flippedTriangles = 0;
  std::uint64_t byVolume = 0;           // closed pieces decided by their signed volume
  std::uint64_t byVisibility = 0;       // open pieces decided by which side rays from outside see
  std::uint64_t byNeighbours = 0;       // open pieces no ray reached, turned like the decided pieces nearest to them
  std::uint64_t undecided = 0;          // pieces left as they are: no ray reached them and no piece was decided
};

// Decides each piece's side and flips the inward ones (every triangle's
// winding reversed): a closed piece (every edge shared by exactly two of its
// triangles) is inward when its signed volume is negative; an open piece
// (a range scan, a terrain) when rays from 64 directions outside the mesh,
// cast through a caster `makeCaster` builds over `mesh` as it is (only when
// a piece is open: closed meshes need no rays), see the back of its
// triangles more than twice as often as the front (a lone sheet, seen from
// both sides alike, stays as it is). A piece fewer than 8 rays reach agrees
// with the decided triangles nearest to it. Deterministic. Internal error
// when the nearest-triangle search or the caster fails.
using CasterFactory = std::function<Result<std::unique_ptr<RayCaster>>(const Scan&)>;
Result<FaceOrientation> orientFacesOutward(Scan& mesh, const CasterFactory& makeCaster);

}  // namespace apo::faces
