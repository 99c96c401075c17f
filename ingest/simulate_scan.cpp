// Virtual range scanner: known shapes in, realistic scans out.
#include "ingest/ingest.h"
#include "ingest/range_grid.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace apo {
namespace {

// A scanner at `origin` looking at `target`, its field wide enough to see a
// sphere of `radius` around the target: its axes and half-width (the
// tangent of half its field).
struct ViewFrame {
  Vec3f origin, forward, right, up;
  float halfWidth = 0.0f;
};

ViewFrame frameOf(const Vec3f& origin, const Vec3f& target, float radius) {
  ViewFrame frame;
  frame.origin = origin;
  frame.forward = (target - origin).normalized();
  const Vec3f helper = std::abs(frame.forward.z()) < 0.9f ? Vec3f::UnitZ() : Vec3f::UnitX();
  frame.right = frame.forward.cross(helper).normalized();
  frame.up = frame.right.cross(frame.forward);
  frame.halfWidth = radius / std::sqrt(std::max(1e-12f, (target - origin).squaredNorm() - radius * radius));
  return frame;
}

// A square grid of rays, row by row.
std::vector<Ray> viewRays(const ViewFrame& frame, int raysPerSide) {
  std::vector<Ray> rays;
  rays.reserve(static_cast<std::size_t>(raysPerSide) * raysPerSide);
  for (int row = 0; row < raysPerSide; ++row)
    for (int column = 0; column < raysPerSide; ++column) {
      const float sx = (2.0f * (column + 0.5f) / raysPerSide - 1.0f) * frame.halfWidth;
      const float sy = (2.0f * (row + 0.5f) / raysPerSide - 1.0f) * frame.halfWidth;
      rays.push_back({frame.origin, (frame.forward + sx * frame.right + sy * frame.up).normalized()});
    }
  return rays;
}

// The scanner's pose after the view's misregistration: its position, and
// its axes (right, up, backward: a right-handed camera frame) as a rotation.
ScanStation stationOf(const ViewFrame& frame, const Eigen::Affine3f& motion, std::size_t view, int raysPerSide) {
  Eigen::Matrix3f axes;
  axes << frame.right, frame.up, -frame.forward;
  const Eigen::Quaterniond rotation(Eigen::Matrix3f(motion.linear() * axes).cast<double>());
  ScanStation station;
  station.name = "view " + std::to_string(view);
  station.position = motion * frame.origin;
  station.rotationWxyz = {rotation.w(), rotation.x(), rotation.y(), rotation.z()};
  station.hasPose = true;
  station.rowCount = station.columnCount = static_cast<std::uint32_t>(raysPerSide);
  return station;
}

// A small rigid motion about `centre`: rotation of `angle` radians about a
// random axis, translation of length `offset` in a random direction.
Eigen::Affine3f misregistration(std::mt19937_64& random, const Vec3f& centre, float angle, float offset) {
  std::normal_distribution<float> gaussian(0.0f, 1.0f);
  Vec3f axis(gaussian(random), gaussian(random), gaussian(random));
  Vec3f shift(gaussian(random), gaussian(random), gaussian(random));
  if (axis.norm() == 0.0f) axis = Vec3f::UnitZ();
  if (shift.norm() == 0.0f) shift = Vec3f::UnitX();
  return Eigen::Translation3f(centre + offset * shift.normalized()) * Eigen::AngleAxisf(angle, axis.normalized()) *
         Eigen::Translation3f(-centre);
}

}  // namespace

template <>
Result<Checked<SimulateScanOptions>> check(const SimulateScanOptions& options) {
  if (options.views < 1 || options.views > 10000) return usageError("--views must be in [1, 10000], got {}", options.views);
  if (options.raysPerSide < 1 || options.raysPerSide > 8192)
    return usageError("--rays must be in [1, 8192], got {}", options.raysPerSide);
  if (!(options.rangeNoise >= 0.0) || !(options.misregistration >= 0.0))
    return usageError("--noise and --misregistration must be >= 0");
  return Checked<SimulateScanOptions>(options);
}

Result<SimulatedScan> simulateScan(const Scan& mesh, const RayCaster& caster,
                                   const Checked<SimulateScanOptions>& checkedOptions) {
  const SimulateScanOptions& options = *checkedOptions;
  if (!mesh.isMesh()) return badInput("simulate-scan needs a triangle mesh, got {} points and no triangles", mesh.points.size());

  const Aabb box = boundingBox(mesh.points.positions);
  const Vec3f centre = 0.5f * (box.min + box.max);
  // Frame the mesh's bounding sphere about the box centre, tighter than the
  // box's own so that most rays hit.
  float radius = 0.0f;
  for (const Vec3f& p : mesh.points.positions) radius = std::max(radius, (p - centre).norm());
  const float noiseSigma = static_cast<float>(options.rangeNoise) * box.diagonal();
  const float misregistrationSize = static_cast<float>(options.misregistration);

  std::mt19937_64 random(options.seed);
  std::normal_distribution<float> gaussian(0.0f, 1.0f);
  SimulatedScan result;
  std::vector<RayHit> hits;
  for (const Vec3f& direction : fibonacciDirections(options.views)) {
    const ViewFrame frame = frameOf(centre + 2.0f * radius * direction, centre, radius);
    const auto rays = viewRays(frame, options.raysPerSide);
    caster.intersect(rays, hits);
    const Eigen::Affine3f motion =
        misregistration(random, centre, misregistrationSize, misregistrationSize * box.diagonal());
    const auto view = static_cast<std::uint16_t>(result.scan.stations.size());
    ScanStation station = stationOf(frame, motion, view, options.raysPerSide);
    PointSet& points = result.scan.points;
    std::vector<std::uint32_t> gridIndex(rays.size(), range_grid::kNoReturn);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      if (!hits[i].hit()) continue;
      gridIndex[i] = static_cast<std::uint32_t>(points.positions.size());
      const float range = hits[i].t + noiseSigma * gaussian(random);
      points.positions.push_back(motion * Vec3f(rays[i].origin + range * rays[i].direction));
      points.stations.push_back(view);
      points.rows.push_back(static_cast<std::uint32_t>(i / options.raysPerSide));
      points.columns.push_back(static_cast<std::uint32_t>(i % options.raysPerSide));
      if (options.withNormals) {
        Vec3f normal = hits[i].geometricNormal.normalized();
        if (normal.dot(rays[i].direction) > 0) normal = -normal;  // the side the scanner saw
        points.normals.push_back(motion.linear() * normal);
      }
      ++station.pointCount;
    }
    if (options.asMesh) {
      const float angularStep = 2.0f * frame.halfWidth / static_cast<float>(options.raysPerSide);
      range_grid::triangulate(gridIndex, static_cast<std::size_t>(options.raysPerSide),
                              static_cast<std::size_t>(options.raysPerSide), station.position, angularStep,
                              range_grid::kMaxEdgeInSpacings, result.scan);
    }
    result.viewOrigins.push_back(frame.origin);
    result.pointsPerView.push_back(static_cast<std::uint32_t>(station.pointCount));
    result.scan.stations.push_back(std::move(station));
  }
  return result;
}

}  // namespace apo
