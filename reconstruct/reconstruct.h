// reconstruct: turns scan points with oriented normals into a dense triangle
// mesh M (CGAL Poisson, advancing front or scale-space reconstruction), and
// simplifies a dense mesh M into a coarse mesh m (CGAL edge collapse).
// CGAL and FLANN are reached through their adapters (adapters/cgal,
// adapters/flann), which return every failure as an Error.
#pragma once

#include "core/checked.h"
#include "core/error.h"
#include "core/geometry.h"
#include "core/timing.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace apo {

// Auto: Poisson for closed objects, advancing front for open scans, told
// apart by the balance of the point normals (see closedSurfaceLikelihood).
enum class ReconstructionMethod { Auto, Poisson, AdvancingFront, ScaleSpace };
std::string methodName(ReconstructionMethod method);  // "auto", "poisson", ...

struct ReconstructOptions {
  ReconstructionMethod method = ReconstructionMethod::Auto;
  // Above this many points, reconstruct from a density-aware subsample
  // (CGAL grid simplification); 0 means never subsample. Unset: the method's
  // default (defaultMaxPoints), measured so that a 1M-point scan reconstructs
  // in well under a minute on 2 cores (docs/benchmarks.md).
  std::optional<std::uint64_t> maxPoints;
  // Poisson: drop triangles farther than trim x average spacing from the
  // nearest input point (Poisson closes holes with invented surface).
  double trim = 3.0;
  // Advancing front: refuse triangles whose circumradius exceeds this
  // multiple of the average spacing (they bridge holes).
  double radiusRatioBound = 5.0;
  // Drop connected components smaller than this fraction of M's total area.
  double minComponent = 0.01;
  // Average spacing over this many neighbours (CGAL compute_average_spacing).
  int spacingNeighbours = 6;
  // 0: derived from the data. Poisson: the mesher's distance bound in
  // average spacings; scale space: the smoothing scale in average spacings.
  double poissonSpacing = 0.0;
  double scaleSpaceScale = 0.0;
  // Poisson: bound on the mesher's triangle size (Delaunay-ball radius) in
  // average spacings; M must be dense enough to carry the scan's detail.
  double poissonRadius = 1.0;
  std::uint32_t seed = 1;  // CGAL's random generator (Poisson), for repeatability
};

// Topology and size figures of a triangle mesh.
struct MeshQuality {
  std::uint64_t vertices = 0, triangles = 0;
  std::uint64_t nonManifoldEdges = 0;     // edges with more than two triangles
  std::uint64_t nonManifoldVertices = 0;  // vertices whose triangles form several fans
  std::uint64_t boundaryLoops = 0;
  std::uint64_t components = 0;
  std::int64_t eulerCharacteristic = 0;   // V - E + F
  double area = 0.0;
  double diagonal = 0.0;                  // of the bounding box
};

struct ReconstructReport {
  std::string method;          // the method that ran (never "auto")
  double normalImbalance = 0;  // what --method auto decided on, see below
  std::uint64_t pointsIn = 0, pointsUsed = 0;  // pointsUsed < pointsIn when subsampled
  double averageSpacing = 0.0;                 // of the points used
  std::uint64_t trimmedTriangles = 0;
  double trimmedArea = 0.0;
  std::uint64_t droppedComponents = 0;
  double droppedArea = 0.0;
  MeshQuality quality;
  // Distance from the input points to M, as fractions of M's bbox diagonal.
  double pointToMeshMean = 0.0, pointToMeshP95 = 0.0;
  double seconds = 0.0;
};

struct Reconstruction {
  Scan mesh;  // M, with unit vertex normals
  ReconstructReport report;
};

// Length of the mean unit normal of the points: near 0 for a closed surface
// (the normals of a closed surface integrate to zero), near 1 for a
// one-sided scan whose normals all face the sensor. --method auto picks
// Poisson below kClosedImbalance and advancing front above.
double normalImbalance(const PointSet& points);
inline constexpr double kClosedImbalance = 0.3;

// CGAL Poisson costs about 0.4 ms per point here, advancing front a tenth.
inline std::uint64_t defaultMaxPoints(ReconstructionMethod method) {
  return method == ReconstructionMethod::AdvancingFront || method == ReconstructionMethod::ScaleSpace ? 150000 : 50000;
}

// Usage error naming the option when one is out of range.
template <>
Result<Checked<ReconstructOptions>> check(const ReconstructOptions& options);

// Reconstructs M from points with oriented normals. BadInput when there are
// too few points, no normals, or the points are all on a plane (Poisson), and
// when CGAL produces no surface.
// `onProgress` hears the fraction done by phase (subsample and spacing, the
// CGAL method, clean-up and measures): CGAL's methods report nothing inside.
Result<Reconstruction> reconstructSurface(const PointSet& points, const Checked<ReconstructOptions>& options,
                                          const ProgressCallback& onProgress = {});

// M for a scan: a mesh is adopted as it is (method "input-mesh", figures
// measured), a point cloud is reconstructed.
Result<Reconstruction> reconstructScan(const Scan& scan, const Checked<ReconstructOptions>& options,
                                       const ProgressCallback& onProgress = {});

enum class SimplifyPolicy { GarlandHeckbert, LindstromTurk };
std::string policyName(SimplifyPolicy policy);

struct SimplifyOptions {
  std::uint64_t targetFaces = 3000;  // used when ratio == 0
  double ratio = 0.0;                // (0, 1]: target = ratio x input faces
  SimplifyPolicy policy = SimplifyPolicy::GarlandHeckbert;
  // Large meshes first go down to about kQuickCollapseFaces triangles by
  // meshoptimizer's collapses (a second for a million triangles, where CGAL's
  // take thirty), then CGAL's finish at the target. False: CGAL alone.
  bool quickFirstPass = true;
};

// The quick first pass runs when M has more than twice this many triangles
// (and the target is well below it): it stops at this count.
inline constexpr std::uint64_t kQuickCollapseFaces = 100000;

// Usage error naming the option when one is out of range.
template <>
Result<Checked<SimplifyOptions>> check(const SimplifyOptions& options);

struct SimplifyReport {
  std::string policy;
  std::uint64_t facesIn = 0, facesOut = 0, targetFaces = 0;
  // Borders are kept unless they alone hold more faces than the target; then
  // border edges collapse too, in a second, shape-keeping pass.
  bool bordersCollapsed = false;
  // Faces left by the quick first pass (meshoptimizer), 0 when it did not
  // run, and its error as a fraction of M's extent.
  std::uint64_t quickPassFaces = 0;
  double quickPassError = 0.0;
  std::uint64_t quickPassPockets = 0;  // folds and pinched pockets it made, removed before CGAL
  std::uint64_t filledHoles = 0;  // small holes of M closed before collapsing
  // Two-sided Hausdorff and mean distances between m and M, as fractions of
  // M's bounding-box diagonal.
  double hausdorff = 0.0, meanDistance = 0.0;
  MeshQuality quality;
  double seconds = 0.0;
};

struct Simplification {
  Scan mesh;  // m, with unit vertex normals
  SimplifyReport report;
};

// Edge-collapse simplification of a triangle mesh to the target face count
// (within 1%), borders kept. Deterministic. `onProgress` hears the fraction
// done: the collapses by faces removed, then the distance measures.
Result<Simplification> simplifyMesh(const Scan& mesh, const Checked<SimplifyOptions>& options,
                                    const ProgressCallback& onProgress = {});

// A quick preview of a large mesh (the report's viewer): meshoptimizer's
// collapses alone down to about `targetFaces`, M's vertices keeping their
// normals; neither manifoldness nor borders are guarded and nothing is
// measured, unlike simplifyMesh. Seconds for millions of triangles.
Result<Scan> previewMesh(const Scan& mesh, std::uint64_t targetFaces);

// Figures of a mesh, counted on its triangles as a soup (sorted edge lists and
// union-find), so that non-manifold input is measured, not refused.
MeshQuality measureMesh(const Scan& mesh);

// JSON text of the reports (format_version 1, stable key order).
std::string reconstructReportJson(const ReconstructReport& report);
std::string simplifyReportJson(const SimplifyReport& report);

}  // namespace apo
