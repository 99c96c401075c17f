// Internal to ingest: normals for point clouds that have none.
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "ingest/ingest.h"

#include <optional>
#include <string>
#include <vector>

namespace apo::normals {

// Neighbourhood sizes tried when k is chosen from the data.
inline constexpr int kCandidateNeighbourCounts[] = {8, 12, 16, 24, 32, 48};

// Chooses k for PCA normals from the data (docs/ingest.md): on a fixed
// subsample, the neighbourhoods of each candidate k are fitted with a plane;
// candidates whose neighbourhoods are mostly one-dimensional (scan lines:
// median lambda1/lambda2 below 0.25) are refused, and among the rest the one
// with the lowest mean surface variation lambda0/(lambda0+lambda1+lambda2)
// wins: small k is dominated by noise, large k by curvature.
// Internal error when PCL fails.
Result<int> chooseNeighbourCount(const std::vector<Vec3f>& points);

struct OrientedNormals {
  std::vector<Vec3f> normals;   // unit, or NaN where no plane could be fitted
  int neighbours = 0;           // k used
  std::string orientation;      // "viewpoint", "propagation" or "mst"
  std::size_t islands = 0;      // separate pieces, each oriented by its own MST
  std::size_t unoriented = 0;   // points no MST pass reached (oriented by their nearest neighbour)
};

// Estimates normals (a plane fitted to each point and its k - 1 nearest
// neighbours; k = 0 chooses it) and orients them towards `viewpoint` when
// given, else by `orientation`, island by island for scans in separate
// pieces (docs/ingest.md). Internal error when a library fails.
Result<OrientedNormals> estimateOrientedNormals(const std::vector<Vec3f>& points,
                                                const std::optional<Viewpoint>& viewpoint, int k,
                                                OrientationMethod orientation = OrientationMethod::Propagation);

}  // namespace apo::normals
