// Fidelity to the scan itself, beside the renders' figures against M: for a
// point scan M is a reconstruction, and can be far from the points it was
// made from (docs/render.md, "Against the scan"). The method is that of
// ../shared/tools/scan_eval.py, the independent judge.
#include "render/render.h"

#include "adapters/flann/flann_search.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace apo {
namespace {

constexpr std::size_t kTruthNeighbours = 8;
constexpr double kHoleFactor = 3.0;  // probes farther than this x the median nearest distance are over holes

struct Probe {
  Vec3f position, normal;  // on m, with m's interpolated vertex normal
};

// Points spread over m in proportion to area (a fixed seed: the same probes
// on every run), with m's interpolated normal.
std::vector<Probe> probesOn(const Scan& coarse, std::size_t count) {
  const auto& p = coarse.points.positions;
  const std::vector<Vec3f> n = vertexNormalsAsDrawn(coarse);
  std::vector<double> cumulative;
  double total = 0.0;
  for (const Triangle& t : coarse.triangles) {
    total += 0.5 * static_cast<double>((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm());
    cumulative.push_back(total);
  }
  std::vector<Probe> probes;
  if (!(total > 0.0)) return probes;
  std::mt19937_64 random(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  probes.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double at = unit(random) * total;
    const std::size_t face = std::min<std::size_t>(
        static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), at) - cumulative.begin()),
        cumulative.size() - 1);
    const Triangle& t = coarse.triangles[face];
    const float r1 = static_cast<float>(std::sqrt(unit(random))), r2 = static_cast<float>(unit(random));
    const float a = 1.0f - r1, b = r1 * (1.0f - r2), c = r1 * r2;
    probes.push_back({a * p[t[0]] + b * p[t[1]] + c * p[t[2]], (a * n[t[0]] + b * n[t[1]] + c * n[t[2]]).normalized()});
  }
  return probes;
}

float median(std::vector<float> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// M against the scan: each scan point's distance to M and the angle between
// its normal and M's at the closest point; every stride-th point, at most
// about `count` of them.
Status measureDense(const PointSet& all, const Scan& dense, std::size_t count, ScanFidelity& fidelity) {
  auto finder = makeFlannClosestPoint(dense);
  if (!finder) return finder.error();
  PointSet scan;
  const std::size_t stride = std::max<std::size_t>(1, all.size() / count);
  for (std::size_t i = 0; i < all.size(); i += stride) {
    scan.positions.push_back(all.positions[i]);
    scan.normals.push_back(all.normals[i]);
  }
  std::vector<float> distances(scan.size()), degrees(scan.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, scan.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const std::optional<SurfacePoint> closest = (*finder)->closest(scan.positions[i]);
      distances[i] = closest ? (closest->position - scan.positions[i]).norm() : std::numeric_limits<float>::quiet_NaN();
      degrees[i] = closest ? static_cast<float>(angleDegrees(closest->normal, scan.normals[i]))
                           : std::numeric_limits<float>::quiet_NaN();
    }
  });
  const auto unanswered = std::count_if(distances.begin(), distances.end(), [](float d) { return std::isnan(d); });
  if (unanswered > 0) return internalError("against the scan: no closest point of M for {} scan points", unanswered);
  const double diagonal = boundingBox(dense.points.positions).diagonal();
  const AngularStats spread = statsOfAngles(distances);  // the same order statistics, of distances
  fidelity.denseMeanDistance = spread.mean / diagonal;
  fidelity.denseP95Distance = spread.p95 / diagonal;
  fidelity.dense = statsOfAngles(std::move(degrees));
  return okStatus();
}

}  // namespace

Result<ScanProbes> probeAgainstScan(const PointSet& scan, const Scan& coarse, std::size_t count) {
  if (!scan.hasNormals() || scan.size() == 0) return badInput("against the scan: the scan has no normals");
  const std::vector<Probe> probes = probesOn(coarse, count);
  ScanProbes kept;
  kept.drawn = probes.size();
  if (probes.empty()) return kept;
  std::vector<Vec3f> positions;
  positions.reserve(probes.size());
  for (const Probe& probe : probes) positions.push_back(probe.position);
  const auto nearest = flann_adapter::nearestOf(scan.positions, positions, kTruthNeighbours);
  if (!nearest) return nearest.error();
  const std::size_t k = nearest->k;
  std::vector<float> nearestDistance(probes.size());
  for (std::size_t q = 0; q < probes.size(); ++q) nearestDistance[q] = std::sqrt(nearest->squaredDistances[q * k]);
  const float hole = static_cast<float>(kHoleFactor) * median(nearestDistance);
  for (std::size_t q = 0; q < probes.size(); ++q) {
    if (nearestDistance[q] > hole) continue;
    Vec3f truth = Vec3f::Zero();
    for (std::size_t j = 0; j < k; ++j) truth += scan.normals[nearest->indices[q * k + j]];
    kept.positions.push_back(probes[q].position);
    kept.coarseNormals.push_back(probes[q].normal);
    kept.truths.push_back(truth);
  }
  return kept;
}

namespace {

// The APO's filtered lookup against the truth, per kept probe.
std::vector<float> apoDegreesAgainstScan(const ScanProbes& probes, const ApoTexture& apo) {
  std::vector<float> degrees(probes.positions.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, degrees.size(), 4096), [&](const auto& range) {
    for (std::size_t q = range.begin(); q < range.end(); ++q) {
      const Lookup looked =
          lookupTextureFiltered(apo, apo.transform.toUnit(probes.positions[q]), probes.coarseNormals[q].normalized());
      // No answer: the APO shows nothing there, as far from right as can be.
      degrees[q] = looked.found ? static_cast<float>(angleDegrees(looked.normal, probes.truths[q])) : 180.0f;
    }
  });
  return degrees;
}

std::vector<float> coarseDegreesAgainstScan(const ScanProbes& probes) {
  std::vector<float> degrees(probes.positions.size());
  for (std::size_t q = 0; q < degrees.size(); ++q)
    degrees[q] = static_cast<float>(angleDegrees(probes.coarseNormals[q], probes.truths[q]));
  return degrees;
}

// Which probes `camera` sees: m faces the eye there, and a ray from the
// probe to the eye meets no other part of m. The ray leaves the probe's own
// face by a small fraction of the way (the probe lies on m).
std::vector<bool> seenFrom(const ScanProbes& probes, const Camera& camera, const RayCaster& coarse) {
  constexpr float kLeaveSurface = 1e-4f;
  std::vector<bool> seen(probes.positions.size(), false);
  std::vector<Ray> rays;
  std::vector<std::size_t> cast;
  for (std::size_t q = 0; q < probes.positions.size(); ++q) {
    const Vec3f toEye = camera.eye - probes.positions[q];
    if (probes.coarseNormals[q].dot(toEye) <= 0.0f) continue;
    rays.push_back(Ray{probes.positions[q], toEye, kLeaveSurface, 1.0f});
    cast.push_back(q);
  }
  std::vector<RayHit> hits;
  coarse.intersect(rays, hits);
  for (std::size_t i = 0; i < cast.size(); ++i) seen[cast[i]] = !hits[i].hit();
  return seen;
}

std::vector<float> subset(const std::vector<float>& values, const std::vector<bool>& kept) {
  std::vector<float> out;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (kept[i]) out.push_back(values[i]);
  return out;
}

}  // namespace

AngularStats apoErrorAgainstScan(const ScanProbes& probes, const ApoTexture& apo) {
  return statsOfAngles(apoDegreesAgainstScan(probes, apo));
}

Result<ScanFidelity> measureAgainstScan(const ScanProbes& probes, const PointSet& scan, const Scan& dense,
                                        const ApoTexture& apo, const ScanViews& views) {
  ScanFidelity fidelity;
  fidelity.probes = probes.drawn;
  fidelity.kept = probes.positions.size();
  if (fidelity.kept == 0) return fidelity;
  const std::vector<float> coarseDegrees = coarseDegreesAgainstScan(probes);
  const std::vector<float> apoDegrees = apoDegreesAgainstScan(probes, apo);
  fidelity.coarse = statsOfAngles(coarseDegrees);
  fidelity.apo = statsOfAngles(apoDegrees);
  if (views.coarse != nullptr)
    for (const Camera& camera : views.cameras) {
      const std::vector<bool> seen = seenFrom(probes, camera, *views.coarse);
      fidelity.views.push_back({statsOfAngles(subset(coarseDegrees, seen)), statsOfAngles(subset(apoDegrees, seen))});
    }
  if (dense.isMesh()) APO_RETURN_IF_ERROR(measureDense(scan, dense, probes.drawn, fidelity));
  return fidelity;
}

}  // namespace apo
