// Internal to ingest: normals for point clouds that have none.
#pragma once

#include "adapters/flann/flann_search.h"
#include "core/error.h"
#include "core/geometry.h"
#include "ingest/ingest.h"
#include "ingest/sensors.h"

#include <cstdint>
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

// Normals turned towards their sensors against normals oriented by
// propagation over the same points, each propagated island then signed by
// the majority of its points facing their sensors, and how many points are
// out of their sensor's sight (docs/ingest.md, "Sensor positions").
struct SensorAgreement {
  std::uint64_t compared = 0;     // points with a normal
  std::uint64_t disagreeing = 0;  // of those, turned opposite ways by the two
  line_of_sight::Sight sight;     // sampled points hidden from their sensor
  bool sensorsKept = true;        // false: the propagation kept
  double share() const { return compared == 0 ? 0.0 : static_cast<double>(disagreeing) / static_cast<double>(compared); }
};
// Over this share of disagreeing points, the sensors are kept only when at
// most this share of the points are hidden from them: a true position sees
// every point it measured (open scenes, where the propagation errs); a
// wrong one (a position beside the data, below it, inside it) does not.
inline constexpr double kMaxSensorDisagreement = 0.10;
inline constexpr double kMaxHiddenFromSensor = 0.10;

struct OrientedNormals {
  std::vector<Vec3f> normals;   // unit, or NaN where no plane could be fitted
  int neighbours = 0;           // k used
  std::string orientation;      // "viewpoint", "propagation" or "mst"
  std::size_t islands = 0;      // separate pieces, each oriented by its own MST
  std::size_t unoriented = 0;   // points no MST pass reached (oriented by their nearest neighbour)
  std::optional<SensorAgreement> agreement;  // when sensors were given
};

// Estimates normals (a plane fitted to each point and its k - 1 nearest
// neighbours; k = 0 chooses it) and orients them towards `sensors` when
// given and they agree with the propagation (SensorAgreement), else by
// `orientation`, island by island for scans in separate pieces
// (docs/ingest.md). Internal error when a library fails.
Result<OrientedNormals> estimateOrientedNormals(const std::vector<Vec3f>& points,
                                                const std::optional<Sensors>& sensors, int k,
                                                OrientationMethod orientation = OrientationMethod::Propagation);

// PCA normals of `queries` (each a point of `reference`) over their rows of
// `nearest` (each query's k nearest reference points, itself first), as
// estimateOrientedNormals fits them, each turned to agree with its guide (a
// unit normal: the nearest oriented point's, for a large scan's every point
// in its store); where no plane fits, the guide itself.
struct GuidedNormals {
  std::vector<Vec3f> normals;
  std::uint64_t unfitted = 0;  // normals that are their guide
};
GuidedNormals guidedNormals(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries,
                            const flann_adapter::NearestRows& nearest, const std::vector<Vec3f>& guides);

}  // namespace apo::normals
