// Limits the stages share about what a surface can be made from.
#pragma once

#include <cstddef>

namespace apo {

// The fewest points a surface is reconstructed from: below this a surface is
// not worth fitting (and CGAL's methods misbehave). Reconstruct refuses
// fewer; ingest never reads a mesh as points it could not reconstruct.
inline constexpr std::size_t kMinReconstructionPoints = 100;

}  // namespace apo
