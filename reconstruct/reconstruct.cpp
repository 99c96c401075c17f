// Points to M: validation, density-aware subsampling, the chosen CGAL method,
// removal of invented or bridging surface and of debris, consistent
// orientation, and the quality figures of reconstruct.json.
#include "reconstruct/reconstruct.h"

#include "adapters/cgal/cgal_jobs.h"
#include "adapters/flann/flann_search.h"
#include "core/mesh_edit.h"
#include "core/surface_limits.h"
#include "core/timing.h"
#include "reconstruct/mesh_quality.h"

#include <Eigen/Eigenvalues>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace apo {
namespace {

// Points whose distance to M is measured, at most (evenly strided).
constexpr std::size_t kMaxDistanceSamples = 200000;
// Relative thickness below which the points count as one plane.
constexpr double kPlanarThickness = 1e-6;

}  // namespace

template <>
Result<Checked<ReconstructOptions>> check(const ReconstructOptions& o) {
  if (!(o.trim > 0.0)) return usageError("--trim must be positive, got {}", o.trim);
  if (!(o.radiusRatioBound > 0.0)) return usageError("--radius-ratio must be positive, got {}", o.radiusRatioBound);
  if (!(o.minComponent >= 0.0 && o.minComponent < 1.0))
    return usageError("--min-component must be in [0, 1), got {}", o.minComponent);
  if (o.spacingNeighbours < 2) return usageError("--spacing-k must be at least 2, got {}", o.spacingNeighbours);
  if (o.maxPoints && *o.maxPoints != 0 && *o.maxPoints < 1000)
    return usageError("--max-points must be 0 (no limit) or at least 1000, got {}", *o.maxPoints);
  if (!(o.poissonRadius > 0.0)) return usageError("--poisson-radius must be positive, got {}", o.poissonRadius);
  if (!(o.poissonSpacing >= 0.0) || !(o.scaleSpaceScale >= 0.0))
    return usageError("--poisson-distance and --scale must be >= 0 (0: derived from the data)");
  return Checked<ReconstructOptions>(o);
}

namespace {

// Smallest over largest covariance eigenvalue: 0 for points on one plane.
double relativeThickness(const std::vector<Vec3f>& points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vec3f& p : points) mean += p.cast<double>();
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vec3f& p : points) {
    const Eigen::Vector3d d = p.cast<double>() - mean;
    covariance += d * d.transpose();
  }
  const Eigen::Vector3d lambda = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance, Eigen::EigenvaluesOnly).eigenvalues();
  return lambda[2] > 0.0 ? std::max(0.0, lambda[0]) / lambda[2] : 0.0;
}

Status validatePoints(const PointSet& points) {
  if (points.size() < kMinReconstructionPoints)
    return badInput("{} points are too few to reconstruct a surface (need at least {})", points.size(), kMinReconstructionPoints);
  if (!points.hasNormals())
    return badInput("the points have no normals: run `apo ingest` first, which estimates and orients them");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points.positions[i].allFinite() || !points.normals[i].allFinite())
      return badInput("point {} has a non-finite coordinate or normal: run `apo ingest` first, which drops them", i);
  if (relativeThickness(points.positions) < kPlanarThickness)
    return badInput("all {} points lie on one plane: there is no surface to reconstruct in 3D", points.size());
  return okStatus();
}

PointSet subset(const PointSet& points, const std::vector<char>& keep) {
  PointSet kept;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    kept.positions.push_back(points.positions[i]);
    kept.normals.push_back(points.normals[i]);
  }
  return kept;
}

// A grid subsample of about maxPoints points: one per cell, the cell side
// grown from the spacing until the count fits (a surface's point count falls
// with the square of the cell side).
Result<PointSet> densityAwareSubsample(const PointSet& points, std::uint64_t maxPoints, int spacingNeighbours) {
  const Result<double> spacing = cgal_adapter::averageSpacing(points.positions, spacingNeighbours);
  if (!spacing) return spacing.error();
  double cell = *spacing * std::sqrt(static_cast<double>(points.size()) / static_cast<double>(maxPoints));
  PointSet kept;
  for (int attempt = 0; attempt < 6; ++attempt) {
    const Result<std::vector<char>> keep = cgal_adapter::gridSubsampleMask(points.positions, cell);
    if (!keep) return keep.error();
    kept = subset(points, *keep);
    if (kept.size() <= maxPoints) break;
    cell *= std::sqrt(static_cast<double>(kept.size()) / static_cast<double>(maxPoints)) * 1.02;
  }
  return kept;
}

Vec3f triangleCentroid(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
}

double triangleArea(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return 0.5 * (p[t[1]] - p[t[0]]).cast<double>().cross((p[t[2]] - p[t[0]]).cast<double>()).norm();
}

double circumradius(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  const double a = (p[t[1]] - p[t[0]]).norm(), b = (p[t[2]] - p[t[1]]).norm(), c = (p[t[0]] - p[t[2]]).norm();
  const double area = triangleArea(mesh, t);
  return area > 0.0 ? a * b * c / (4.0 * area) : std::numeric_limits<double>::infinity();
}

struct Removal {
  std::uint64_t triangles = 0;
  double area = 0.0;
};

// Removes the triangles for which `drop` holds, returning their count and area.
template <class Predicate>
Removal removeTriangles(Scan& mesh, Predicate drop) {
  Removal removed;
  std::vector<Triangle> kept;
  kept.reserve(mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (drop(i)) {
      ++removed.triangles;
      removed.area += triangleArea(mesh, mesh.triangles[i]);
    } else {
      kept.push_back(mesh.triangles[i]);
    }
  }
  mesh.triangles = std::move(kept);
  return removed;
}

// Poisson closes every hole with invented surface: drop triangles whose
// centroid is far from every input point.
Result<Removal> trimFarFromSamples(Scan& mesh, const std::vector<Vec3f>& samples, double maxDistance) {
  std::vector<Vec3f> centroids;
  for (const Triangle& t : mesh.triangles) centroids.push_back(triangleCentroid(mesh, t));
  const auto distances = flann_adapter::nearestDistances(samples, centroids);
  if (!distances) return distances.error();
  return removeTriangles(mesh, [&](std::size_t i) { return (*distances)[i] > maxDistance; });
}

// Advancing front and scale space bridge holes with large triangles.
Removal dropBridgingTriangles(Scan& mesh, double maxCircumradius) {
  return removeTriangles(mesh, [&](std::size_t i) { return circumradius(mesh, mesh.triangles[i]) > maxCircumradius; });
}

struct ComponentFigures {
  std::uint64_t dropped = 0;
  double droppedArea = 0.0;
};

// Scan debris: components below `minFraction` of the total area.
ComponentFigures dropSmallComponents(Scan& mesh, double minFraction) {
  const TriangleComponents components = triangleComponents(mesh);
  const std::uint32_t count = components.count;
  const std::vector<std::uint32_t>& component = components.ofTriangle;
  std::vector<double> area(count, 0.0);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) area[component[i]] += triangleArea(mesh, mesh.triangles[i]);
  const double total = std::accumulate(area.begin(), area.end(), 0.0);
  std::vector<char> small(count, 0);
  ComponentFigures figures;
  for (std::uint32_t c = 0; c < count; ++c)
    if (area[c] < minFraction * total) {
      small[c] = 1;
      ++figures.dropped;
    }
  figures.droppedArea = removeTriangles(mesh, [&](std::size_t i) { return small[component[i]] != 0; }).area;
  return figures;
}

// Turns each component so that its triangles agree, by area-weighted vote,
// with the normals of their nearest input points. Returns how many flipped.
Result<std::uint64_t> orientLikeSamples(Scan& mesh, const PointSet& samples) {
  const TriangleComponents components = triangleComponents(mesh);
  const std::uint32_t count = components.count;
  const std::vector<std::uint32_t>& component = components.ofTriangle;
  std::vector<Vec3f> centroids;
  for (const Triangle& t : mesh.triangles) centroids.push_back(triangleCentroid(mesh, t));
  const auto found = flann_adapter::nearestIndices(samples.positions, centroids);
  if (!found) return found.error();
  const std::vector<std::uint32_t>& nearest = *found;
  const auto& p = mesh.points.positions;
  std::vector<double> vote(count, 0.0);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Triangle& t = mesh.triangles[i];
    const Eigen::Vector3d areaNormal = (p[t[1]] - p[t[0]]).cast<double>().cross((p[t[2]] - p[t[0]]).cast<double>());
    vote[component[i]] += areaNormal.dot(samples.normals[nearest[i]].cast<double>());
  }
  std::uint64_t flipped = 0;
  for (double v : vote) flipped += v < 0.0 ? 1 : 0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (vote[component[i]] < 0.0) std::swap(mesh.triangles[i][1], mesh.triangles[i][2]);
  return flipped;
}

std::vector<Vec3f> evenlyStrided(const std::vector<Vec3f>& points, std::size_t maxCount) {
  const std::size_t stride = std::max<std::size_t>(1, (points.size() + maxCount - 1) / maxCount);
  std::vector<Vec3f> picked;
  for (std::size_t i = 0; i < points.size(); i += stride) picked.push_back(points[i]);
  return picked;
}

// Mean and 95th percentile of the input points' distances to M.
Status measurePointDistances(const PointSet& input, const Scan& mesh, ReconstructReport& report) {
  auto measured = cgal_adapter::pointToMeshDistances(evenlyStrided(input.positions, kMaxDistanceSamples), mesh);
  if (!measured) return measured.error();
  std::vector<float>& distances = *measured;
  if (distances.empty() || report.quality.diagonal <= 0.0) return okStatus();
  const double sum = std::accumulate(distances.begin(), distances.end(), 0.0);
  const auto p95 = distances.begin() + static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(distances.size() - 1));
  std::nth_element(distances.begin(), p95, distances.end());
  report.pointToMeshMean = sum / static_cast<double>(distances.size()) / report.quality.diagonal;
  report.pointToMeshP95 = *p95 / report.quality.diagonal;
  return okStatus();
}

ReconstructionMethod chooseMethod(ReconstructionMethod requested, double imbalance) {
  if (requested != ReconstructionMethod::Auto) return requested;
  return imbalance < kClosedImbalance ? ReconstructionMethod::Poisson : ReconstructionMethod::AdvancingFront;
}

Result<Scan> runMethod(ReconstructionMethod method, const PointSet& points, double spacing,
                       const ReconstructOptions& options) {
  switch (method) {
    case ReconstructionMethod::Auto:
      break;
    case ReconstructionMethod::Poisson:
      return cgal_adapter::poissonReconstruct(points, spacing, options.poissonSpacing > 0 ? options.poissonSpacing : 0.375,
                                      options.poissonRadius, options.seed);
    case ReconstructionMethod::AdvancingFront:
      return cgal_adapter::advancingFrontReconstruct(points.positions);
    case ReconstructionMethod::ScaleSpace:
      return cgal_adapter::scaleSpaceReconstruct(points.positions, spacing, options.scaleSpaceScale > 0 ? options.scaleSpaceScale : 4.0);
  }
  return internalError("no reconstruction method chosen ({})", methodName(method));
}

}  // namespace

double normalImbalance(const PointSet& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Vec3f& n : points.normals) sum += n.cast<double>().normalized();
  return points.size() > 0 ? sum.norm() / static_cast<double>(points.size()) : 0.0;
}

std::string methodName(ReconstructionMethod method) {
  switch (method) {
    case ReconstructionMethod::Auto: return "auto";
    case ReconstructionMethod::Poisson: return "poisson";
    case ReconstructionMethod::AdvancingFront: return "advancing-front";
    case ReconstructionMethod::ScaleSpace: return "scale-space";
  }
  return "unknown";
}

// Rough shares of a reconstruction's time, for progress only.
constexpr double kMethodStart = 0.1, kMethodEnd = 0.8, kCleanEnd = 0.9;

Result<Reconstruction> reconstructSurface(const PointSet& input, const Checked<ReconstructOptions>& checkedOptions,
                                          const ProgressCallback& onProgress) {
  const ReconstructOptions& options = *checkedOptions;
  APO_RETURN_IF_ERROR(validatePoints(input));
  Stopwatch watch;
  Reconstruction result;
  ReconstructReport& report = result.report;
  report.pointsIn = input.size();

  // The imbalance of all points decides the method, whose default bounds the
  // subsample.
  report.normalImbalance = normalImbalance(input);
  const ReconstructionMethod method = chooseMethod(options.method, report.normalImbalance);
  const std::uint64_t maxPoints = options.maxPoints.value_or(defaultMaxPoints(method));
  PointSet subsampled;
  const bool subsample = maxPoints != 0 && input.size() > maxPoints;
  if (subsample) {
    auto kept = densityAwareSubsample(input, maxPoints, options.spacingNeighbours);
    if (!kept) return kept.error();
    subsampled = std::move(kept).value();
    spdlog::info("reconstruct: {} points subsampled to {} (--max-points {})", input.size(), subsampled.size(), maxPoints);
  }
  const PointSet& points = subsample ? subsampled : input;
  report.pointsUsed = points.size();
  const Result<double> spacing = cgal_adapter::averageSpacing(points.positions, options.spacingNeighbours);
  if (!spacing) return spacing.error();
  report.averageSpacing = *spacing;
  reportProgress(onProgress, kMethodStart);

  report.method = methodName(method);
  if (options.method == ReconstructionMethod::Auto)
    spdlog::info("reconstruct: mean normal length {:.3f} ({} {}): {}", report.normalImbalance,
                 report.normalImbalance < kClosedImbalance ? "below" : "at or above", kClosedImbalance,
                 report.normalImbalance < kClosedImbalance ? "closed object" : "open scan", report.method);
  auto mesh = runMethod(method, points, report.averageSpacing, options);
  if (!mesh) return mesh.error();
  Scan& M = result.mesh;
  M = std::move(mesh).value();
  spdlog::info("reconstruct: {} produced {} triangles", report.method, M.triangles.size());
  reportProgress(onProgress, kMethodEnd);

  Removal removed;
  if (method == ReconstructionMethod::Poisson) {
    const Result<Removal> trimmed = trimFarFromSamples(M, points.positions, options.trim * report.averageSpacing);
    if (!trimmed) return trimmed.error();
    removed = *trimmed;
  } else {
    removed = dropBridgingTriangles(M, options.radiusRatioBound * report.averageSpacing);
  }
  report.trimmedTriangles = removed.triangles;
  report.trimmedArea = removed.area;
  dropDegenerateTriangles(M);
  const ComponentFigures debris = dropSmallComponents(M, options.minComponent);
  report.droppedComponents = debris.dropped;
  report.droppedArea = debris.droppedArea;
  dropUnreferencedVertices(M);
  if (!M.isMesh()) return badInput("{} reconstruction left no surface after trimming", report.method);

  const Result<std::uint64_t> oriented = orientLikeSamples(M, points);
  if (!oriented) return oriented.error();
  const std::uint64_t flipped = *oriented;
  if (flipped > 0) spdlog::info("reconstruct: {} components turned to agree with the point normals", flipped);
  M.points.normals = areaWeightedVertexNormals(M);
  reportProgress(onProgress, kCleanEnd);
  report.quality = measureMesh(M);
  APO_RETURN_IF_ERROR(measurePointDistances(input, M, report));
  report.seconds = watch.seconds();
  reportProgress(onProgress, 1.0);
  return result;
}

Result<Reconstruction> reconstructScan(const Scan& scan, const Checked<ReconstructOptions>& options,
                                       const ProgressCallback& onProgress) {
  if (!scan.isMesh()) {
    auto reconstruction = reconstructSurface(scan.points, options, onProgress);
    if (reconstruction) reconstruction->mesh.origin = scan.origin;  // M stays in the scan's frame
    return reconstruction;
  }
  Reconstruction adopted;
  adopted.mesh = scan;
  addVertexNormalsIfMissing(adopted.mesh);
  adopted.report.method = "input-mesh";
  adopted.report.pointsIn = adopted.report.pointsUsed = scan.points.size();
  adopted.report.quality = measureMesh(adopted.mesh);
  return adopted;
}

}  // namespace apo
