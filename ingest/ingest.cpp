// The ingest pipeline: read, validate, clean, normals; and its report.
#include "ingest/ingest.h"

#include "adapters/embree/embree_ray_caster.h"
#include "adapters/pcl/pcl_points.h"
#include "core/file_io.h"
#include "core/mesh_edit.h"
#include "core/timing.h"
#include "ingest/cleaning.h"
#include "ingest/face_orientation.h"
#include "ingest/large_scan.h"
#include "ingest/mesh_input.h"
#include "ingest/normals.h"
#include "ingest/range_grid.h"

#include <algorithm>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cmath>

namespace apo {
namespace fs = std::filesystem;

namespace {

// Points needed to fit a plane with neighbours to spare.
constexpr std::size_t kMinPointsForNormals = 4;
// A position within this share of the origin's distance from the file's
// zero is at that zero (float's precision in the local frame is far finer).
constexpr double kSameAsZero = 1e-6;
// A cloud whose height is under this share of its smaller horizontal side
// is 2.5-D: an aerial tile.
constexpr float kAerialHeightShare = 0.2f;
// A structured scan's grid with more cells than this per point is mostly
// empty: its row and column indices are not a range image's.
constexpr std::uint64_t kMaxCellsPerPoint = 16;

}  // namespace

std::string meshInputName(MeshInput input) {
  switch (input) {
    case MeshInput::Auto: return "auto";
    case MeshInput::Surface: return "surface";
    case MeshInput::Scans: return "scans";
  }
  return "auto";
}

std::string orientationMethodName(OrientationMethod method) {
  return method == OrientationMethod::CgalMst ? "mst" : "propagation";
}

// Fewer voxel centroids than this would be no scan worth reconstructing;
// more than this, no working set worth bounding (and beyond 32-bit indices).
constexpr std::uint64_t kMinScanPoints = 1000;
constexpr std::uint64_t kMaxScanPoints = 1'000'000'000;

template <>
Result<Checked<IngestOptions>> check(const IngestOptions& options) {
  if (options.outlierNeighbours < 1) return usageError("--outlier-k must be at least 1, got {}", options.outlierNeighbours);
  if (!(options.outlierStdDevs > 0.0)) return usageError("--outlier-std must be positive, got {}", options.outlierStdDevs);
  if (!(options.voxelSize >= 0.0) || !std::isfinite(options.voxelSize))
    return usageError("--voxel must be a finite size >= 0, got {}", options.voxelSize);
  if (options.sensorPosition && !options.sensorPosition->allFinite())
    return usageError("--sensor must be three finite numbers");
  if (options.normalNeighbours < 0 || options.normalNeighbours == 1 || options.normalNeighbours == 2)
    return usageError("--normal-k must be 0 (automatic) or at least 3, got {}", options.normalNeighbours);
  if (options.maxScanPoints != 0 && (options.maxScanPoints < kMinScanPoints || options.maxScanPoints > kMaxScanPoints))
    return usageError("--max-scan-points must be 0 (read whole) or from {} to {}, got {}", kMinScanPoints,
                      kMaxScanPoints, options.maxScanPoints);
  return Checked<IngestOptions>(options);
}

namespace {

void recordStep(IngestReport& report, const char* name, std::size_t removed, double seconds) {
  report.steps.push_back({name, removed, seconds});
  if (removed > 0) spdlog::info("ingest: {} removed {}", name, removed);
}

// Runs one cleaning step, timing it and recording what it removed.
template <class Step>
void runStep(IngestReport& report, const char* name, Step&& step) {
  Stopwatch watch;
  const std::size_t removed = step();
  recordStep(report, name, removed, watch.seconds());
}

// The same for a step that calls a library, which may fail.
template <class Step>
Status runFallibleStep(IngestReport& report, const char* name, Step&& step) {
  Stopwatch watch;
  const Result<std::size_t> removed = step();
  if (!removed) return removed.error();
  recordStep(report, name, *removed, watch.seconds());
  return okStatus();
}

void cleanMesh(Scan& scan, const IngestOptions& options, IngestReport& report) {
  if (options.mergeDuplicates) runStep(report, "merge_duplicate_vertices", [&] { return cleaning::mergeDuplicatePoints(scan); });
  runStep(report, "drop_degenerate_triangles", [&] { return dropDegenerateTriangles(scan); });
  runStep(report, "drop_duplicate_triangles", [&] { return cleaning::dropDuplicateTriangles(scan); });
  runStep(report, "drop_unreferenced_vertices", [&] { return dropUnreferencedVertices(scan); });
}

// Pieces wound inward turned outward; the file's normals, if any, then follow
// the faces (they were written for the winding that was wrong, or disagree).
Status orientMeshFaces(Scan& scan, IngestReport& report) {
  Stopwatch watch;
  const auto oriented = faces::orientFacesOutward(scan, makeEmbreeMeshCaster);
  if (!oriented) return oriented.error();
  const faces::FaceOrientation& found = *oriented;
  report.faceOrientation = {true,           found.components,   found.flippedComponents, found.flippedTriangles,
                            found.byVolume, found.byVisibility, found.byNeighbours,      found.undecided};
  report.steps.push_back({"orient_faces_outward", 0, watch.seconds()});
  if (found.flippedTriangles > 0) {
    spdlog::warn("ingest: {} of {} mesh pieces ({} triangles) were wound inward and have been flipped",
                 found.flippedComponents, found.components, found.flippedTriangles);
    scan.points.normals.clear();
  }
  return okStatus();
}

// An organised cloud (a depth frame) becomes one view's mesh: its grid
// triangulated as range software does, cut at depth jumps and grazing
// cells, each triangle facing the sensor; pixels without a return are then
// dropped with the other non-finite points. Left as points when no two
// neighbouring pixels have returns.
void triangulateOrganizedGrid(Scan& scan, const IngestOptions& options, IngestReport& report) {
  IngestReport::GridMesh& grid = report.gridMesh;
  grid.width = scan.gridWidth;
  grid.height = scan.points.size() / scan.gridWidth;
  // A depth frame's points are in its camera's frame: without a viewpoint
  // (or with PCD's default one) the camera is at the origin.
  const bool viewpoint = scan.viewpoint && !scan.viewpoint->isFormatDefault;
  grid.sensorSource = options.sensorPosition ? "--sensor" : viewpoint ? "viewpoint" : "origin";
  grid.sensor = options.sensorPosition ? *options.sensorPosition : viewpoint ? scan.viewpoint->origin : Vec3f::Zero();
  std::vector<std::uint32_t> index(scan.points.size(), range_grid::kNoReturn);
  for (std::uint32_t i = 0; i < index.size(); ++i) {
    if (scan.points.positions[i].allFinite()) index[i] = i;
    else ++grid.missing;
  }
  const range_grid::GridSpacing spacing = range_grid::measureSpacing(scan.points.positions, grid.width, grid.sensor);
  grid.angularStep = spacing.angularStep;
  grid.maxEdgeInSpacings = spacing.maxEdgeInSpacings;
  if (grid.angularStep <= 0.0) {
    spdlog::warn("ingest: organised {} x {} cloud with no two neighbouring returns: read as points", grid.width, grid.height);
    return;
  }
  const range_grid::GridTriangles made =
      range_grid::triangulate(index, grid.width, grid.height, grid.sensor, spacing.angularStep, spacing.maxEdgeInSpacings, scan);
  grid.made = made.triangles > 0;
  grid.candidates = made.candidates;
  grid.triangles = made.triangles;
  grid.refused = made.refused;
  spdlog::info("ingest: organised {} x {} cloud ({} pixels without a return) triangulated on its grid from the {} "
               "at ({}, {}, {}): {} triangles, {} refused across depth jumps (edges over {:.1f} ray spacings) or grazing",
               grid.width, grid.height, grid.missing, grid.sensorSource, grid.sensor.x(), grid.sensor.y(),
               grid.sensor.z(), made.triangles, made.refused, grid.maxEdgeInSpacings);
}

// Where the points were seen from, when the file says so believably
// (docs/ingest.md, "Sensor positions"): --sensor as given; a multi-scan
// file's scan positions; a file's viewpoint unless it is at the zero of
// georeferenced coordinates or lower than the top of an aerial tile. Each
// is then checked against the points (normals::SensorAgreement). `refused` says why a declared position is not used.
struct SensorChoice {
  std::optional<Sensors> sensors;
  std::string source;   // "--sensor", "scan_positions", "viewpoint", "pcd_default_viewpoint" or "" (none declared)
  std::string refused;  // empty when used
};

// A file's coordinates' zero, for points far from it: a position written as
// 0 0 0 because none was known.
bool atGeoreferencedZero(const Vec3f& local, const std::array<double, 3>& origin) {
  if (origin == std::array<double, 3>{0.0, 0.0, 0.0}) return false;
  const Eigen::Vector3d world = local.cast<double>() + Eigen::Vector3d(origin[0], origin[1], origin[2]);
  return world.norm() <= kSameAsZero * Eigen::Vector3d(origin[0], origin[1], origin[2]).norm();
}

// A 2.5-D cloud (an aerial tile: its height under a fifth of its smaller
// horizontal side) is seen from above: a position lower than its top is not
// an aircraft's (nor a tripod's beside it).
bool belowAerialTile(const Vec3f& position, const Aabb& box) {
  const Vec3f extent = box.extent();
  return extent.z() < kAerialHeightShare * std::min(extent.x(), extent.y()) && position.z() < box.max.z();
}

std::string implausiblePosition(const Vec3f& position, const Scan& scan, const Aabb& box) {
  if (!position.allFinite()) return "not a finite position";
  if (atGeoreferencedZero(position, scan.origin)) return "the zero of the file's georeferenced coordinates";
  if (belowAerialTile(position, box)) return "lower than the top of a 2.5-D (aerial) tile";
  return {};
}

SensorChoice chooseSensors(const Scan& scan, const IngestOptions& options) {
  SensorChoice choice;
  if (options.sensorPosition) {
    choice.source = "--sensor";
    choice.sensors = Sensors::single(*options.sensorPosition);
    return choice;
  }
  const Aabb box = boundingBox(scan.points.positions);
  if (!scan.stations.empty() && scan.points.hasStations()) {
    choice.source = "scan_positions";
    Sensors sensors{{}, scan.points.stations};
    for (const ScanStation& station : scan.stations) {
      const std::string why = implausiblePosition(station.position, scan, box);
      if (!why.empty()) {
        choice.refused = fmt::format("scan '{}' at ({}, {}, {}): {}", station.name, station.position.x(),
                                     station.position.y(), station.position.z(), why);
        return choice;
      }
      sensors.positions.push_back(station.position);
    }
    choice.sensors = std::move(sensors);
    return choice;
  }
  if (!scan.viewpoint) return choice;
  // PCL writes its default whatever the sensor: no evidence on its own,
  // used only where the points confirm it (rule 2).
  choice.source = scan.viewpoint->isFormatDefault ? "pcd_default_viewpoint" : "viewpoint";
  choice.refused = implausiblePosition(scan.viewpoint->origin, scan, box);
  if (choice.refused.empty()) choice.sensors = Sensors::single(scan.viewpoint->origin);
  return choice;
}

void recordAgreement(const normals::SensorAgreement& agreement, IngestReport::SensorDecision& decision) {
  decision.checked = true;
  decision.compared = agreement.compared;
  decision.disagreeing = agreement.disagreeing;
  decision.sampledForSight = agreement.sight.sampled;
  decision.hidden = agreement.sight.hidden;
  decision.kept = agreement.sensorsKept;
  if (agreement.share() <= normals::kMaxSensorDisagreement) return;
  if (agreement.sensorsKept)
    spdlog::warn("ingest: normals turned towards the {} disagree with their propagation on {:.1f}% of the points, but "
                 "{:.1f}% of them are hidden from it: the sensor's orientation is kept (the propagation errs)",
                 decision.source, 100.0 * agreement.share(), 100.0 * agreement.sight.share());
  else
    spdlog::warn("ingest: normals turned towards the {} disagree with their propagation on {:.1f}% of the points and "
                 "{:.1f}% of them are hidden from it: it is not where they were seen from; propagation kept",
                 decision.source, 100.0 * agreement.share(), 100.0 * agreement.sight.share());
}

Sensors stationSensors(const Scan& scan) {
  Sensors sensors{{}, scan.points.stations};
  for (const ScanStation& station : scan.stations) sensors.positions.push_back(station.position);
  return sensors;
}

// The points of each station, by index.
std::vector<std::vector<std::uint32_t>> pointsByStation(const Scan& scan) {
  std::vector<std::vector<std::uint32_t>> members(scan.stations.size());
  for (std::uint32_t i = 0; i < scan.points.size(); ++i) members[scan.points.stations[i]].push_back(i);
  return members;
}

// One structured scan's row/column grid triangulated from its position, as
// an organised cloud's is; a cell given twice keeps its first point.
IngestReport::StationGrid triangulateStationGrid(Scan& scan, std::size_t station,
                                                 const std::vector<std::uint32_t>& members) {
  const ScanStation& where = scan.stations[station];
  IngestReport::StationGrid grid{where.name, where.rowCount, where.columnCount};
  const std::size_t width = where.columnCount, height = where.rowCount;
  std::vector<std::uint32_t> index(width * height, range_grid::kNoReturn);
  std::vector<Vec3f> cells(width * height, Vec3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (std::uint32_t i : members) {
    const std::size_t cell = std::size_t{scan.points.rows[i]} * width + scan.points.columns[i];
    if (index[cell] != range_grid::kNoReturn) {
      ++grid.repeatedCells;
      continue;
    }
    index[cell] = i;
    cells[cell] = scan.points.positions[i];
  }
  const range_grid::GridSpacing spacing = range_grid::measureSpacing(cells, width, where.position);
  if (spacing.angularStep <= 0.0f) return grid;
  const range_grid::GridTriangles made = range_grid::triangulate(index, width, height, where.position,
                                                                 spacing.angularStep, spacing.maxEdgeInSpacings, scan);
  grid.triangles = made.triangles;
  grid.refused = made.refused;
  return grid;
}

// Structured scans (a multi-scan file's row/column grids, every scan with
// one) triangulated each from its own position, cut at depth jumps; their
// normals then face their own scanner. Left as points when a scan has no
// grid, a grid is far sparser than its points (over kMaxCellsPerPoint
// cells each), or the positions are not believable.
void triangulateStationGrids(Scan& scan, const IngestOptions& options, IngestReport& report) {
  if (scan.stations.empty() || !scan.points.hasStations()) return;
  if (!scan.points.hasGridIndices()) {
    // Voxel centroids (a scan above --max-scan-points) have no grid cells.
    if (scan.stations.front().rowCount > 0)
      spdlog::info("ingest: the scans' row/column indices were not kept (read into voxel centroids): scans read as points");
    return;
  }
  for (const ScanStation& station : scan.stations) {
    const std::uint64_t cells = std::uint64_t{station.rowCount} * station.columnCount;
    if (cells == 0 || cells > kMaxCellsPerPoint * std::max<std::uint64_t>(station.pointCount, 1)) {
      spdlog::info("ingest: scan '{}' has no usable row/column grid ({} x {} for {} points): scans read as points",
                   station.name, station.rowCount, station.columnCount, station.pointCount);
      return;
    }
  }
  const SensorChoice sensor = chooseSensors(scan, options);
  if (!sensor.sensors || sensor.source != "scan_positions") {
    spdlog::warn("ingest: structured scans read as points: {}", sensor.refused.empty() ? "--sensor given" : sensor.refused);
    return;
  }
  const auto members = pointsByStation(scan);
  for (std::size_t station = 0; station < scan.stations.size(); ++station)
    report.stationGrids.push_back(triangulateStationGrid(scan, station, members[station]));
  IngestReport::GridMesh& summary = report.gridMesh;
  summary.made = scan.isMesh();
  summary.sensorSource = "scan_positions";
  for (const IngestReport::StationGrid& grid : report.stationGrids) {
    summary.triangles += grid.triangles;
    summary.refused += grid.refused;
  }
  spdlog::info("ingest: {} structured scans triangulated on their grids from their positions: {} triangles, {} refused "
               "across depth jumps or grazing",
               scan.stations.size(), summary.triangles, summary.refused);
}

IngestOptions scansUnlessSurface(const IngestOptions& options) {
  IngestOptions scans = options;
  if (scans.meshInput == MeshInput::Auto) scans.meshInput = MeshInput::Scans;
  return scans;
}

// Scans of a sheet with no thickness, seen from both sides, made to face one
// way (mesh_input.h, SheetAgreement): their points would cancel in M.
void turnCoincidentSheets(Scan& scan, const mesh_input::SheetAgreement& sheets,
                          IngestReport::MeshInputDecision& decision) {
  decision.coincidentPairs = sheets.coincidentPairs;
  decision.opposedPairs = sheets.opposedPairs;
  decision.conflicts = sheets.conflicts;
  decision.turnedPieces = sheets.turnedPieces;
  decision.turnedPoints = sheets.turnedVertices;
  for (std::size_t i = 0; i < sheets.turnVertex.size(); ++i)
    if (sheets.turnVertex[i]) scan.points.normals[i] = -scan.points.normals[i];
  if (sheets.turnedPieces > 0)
    spdlog::warn("ingest: {} scans lie on other scans facing the opposite way (a sheet with no thickness seen from "
                 "both sides): their {} points were turned to face one way",
                 sheets.turnedPieces, sheets.turnedVertices);
}

// One surface, or overlapping range scans whose points become the scan
// (with the normals of their faces, already turned outward).
Status decideMeshInput(Scan& scan, const IngestOptions& options, IngestReport& report) {
  const auto evidence = mesh_input::judge(scan);
  if (!evidence) return evidence.error();
  const bool scans = options.meshInput == MeshInput::Scans ||
                     (options.meshInput == MeshInput::Auto && evidence->looksLikeScans);
  report.meshInput = {true,
                      meshInputName(options.meshInput),
                      scans ? "scans" : "surface",
                      evidence->pieces,
                      evidence->boundaryEdgeFraction,
                      evidence->overlapFraction,
                      evidence->medianEdgeLength};
  if (scans) {
    spdlog::warn("ingest: the mesh is {} overlapping pieces ({:.0f}% of its vertices lie within {} edge lengths of "
                 "another piece): read as a set of range scans, its points are reconstructed into M "
                 "(--mesh-input surface keeps it as M)",
                 evidence->pieces, 100.0 * evidence->overlapFraction, mesh_input::kOverlapEdgeLengths);
    turnCoincidentSheets(scan, evidence->sheets, report.meshInput);
    scan.triangles.clear();
  }
  return okStatus();
}

void meshNormals(Scan& scan, IngestReport& report) {
  const bool usable = scan.points.hasNormals() && cleaning::normaliseNormals(scan.points) == 0;
  if (usable) {
    report.normalsSource = "read";
    report.normalOrientation = "file";
    return;
  }
  scan.points.normals = areaWeightedVertexNormals(scan);
  report.normalsSource = "computed_from_faces";
  report.normalOrientation = "faces";
}

// A depth frame's faces join single pixels, whose depth noise they carry;
// its vertex normals are fitted over neighbourhoods of k pixels instead (k
// chosen as for point clouds), facing the sensor.
Status gridMeshNormals(Scan& scan, const IngestOptions& options, IngestReport& report) {
  Stopwatch watch;
  const Sensors sensors = report.stationGrids.empty()
                                      ? Sensors::single(report.gridMesh.sensor)
                                      : stationSensors(scan);
  auto fitted = normals::estimateOrientedNormals(scan.points.positions, sensors, options.normalNeighbours);
  if (!fitted) return fitted.error();
  scan.points.normals = std::move(fitted->normals);
  // A vertex whose neighbourhood fits no plane keeps its faces' normal.
  const auto unfitted = [](const Vec3f& n) { return !n.allFinite(); };
  if (std::any_of(scan.points.normals.begin(), scan.points.normals.end(), unfitted)) {
    const std::vector<Vec3f> fromFaces = areaWeightedVertexNormals(scan);
    for (std::size_t i = 0; i < scan.points.size(); ++i)
      if (unfitted(scan.points.normals[i])) scan.points.normals[i] = fromFaces[i];
  }
  report.normalSeconds = watch.seconds();
  report.normalsSource = "estimated";
  report.normalOrientation =
      fitted->orientation == "viewpoint" && !report.stationGrids.empty() ? "scan_positions" : fitted->orientation;
  report.normalNeighbours = fitted->neighbours;
  report.sensor.source = report.gridMesh.sensorSource;
  if (fitted->agreement) recordAgreement(*fitted->agreement, report.sensor);
  return okStatus();
}

Status cleanPointCloud(Scan& scan, const IngestOptions& options, IngestReport& report, const fs::path& path) {
  if (options.mergeDuplicates) runStep(report, "merge_duplicate_points", [&] { return cleaning::mergeDuplicatePoints(scan); });
  if (options.removeOutliers) {
    if (scan.points.size() <= static_cast<std::size_t>(options.outlierNeighbours))
      return badInput("{}: {} points are too few for outlier removal with k = {}", path.string(), scan.points.size(),
                      options.outlierNeighbours);
    APO_RETURN_IF_ERROR(runFallibleStep(report, "remove_statistical_outliers", [&]() -> Result<std::size_t> {
      const auto keep =
          pcl_adapter::statisticalOutlierKeepMask(scan.points.positions, options.outlierNeighbours, options.outlierStdDevs);
      if (!keep) return keep.error();
      return keepPoints(scan, *keep);
    }));
  }
  if (options.voxelSize > 0.0)
    runStep(report, "voxel_downsample", [&] {
      return keepPoints(scan, cleaning::voxelRepresentativeMask(scan.points.positions, options.voxelSize));
    });
  return okStatus();
}

// "drop_points_without_normal removed the last 8": which step emptied the scan.
std::string lastRemoval(const IngestReport& report) {
  for (auto step = report.steps.rbegin(); step != report.steps.rend(); ++step)
    if (step->removed > 0) return fmt::format("{} removed the last {}", step->name, step->removed);
  return "no step removed any";
}

Status pointCloudNormals(Scan& scan, const IngestOptions& options, IngestReport& report, const fs::path& path) {
  const bool haveUsable = scan.points.hasNormals() && cleaning::normaliseNormals(scan.points) == 0;
  if (haveUsable && !options.forceNormalEstimation) {
    report.normalsSource = "read";
    report.normalOrientation = "file";
    return okStatus();
  }
  if (!options.estimateNormals) {
    if (scan.points.hasNormals())
      return badInput("{}: some normals are zero or not finite and normal estimation is off", path.string());
    report.normalsSource = "none";
    return okStatus();
  }
  if (scan.points.size() < kMinPointsForNormals)
    return badInput("{}: {} points are too few to estimate normals (need at least {}; {})", path.string(),
                    scan.points.size(), kMinPointsForNormals, lastRemoval(report));

  if (options.sensorPosition) {
    scan.viewpoint = Viewpoint{};
    scan.viewpoint->origin = *options.sensorPosition;
  }
  const SensorChoice sensor = chooseSensors(scan, options);
  report.sensor.source = sensor.source;
  report.sensor.refused = sensor.refused;
  if (!sensor.refused.empty())
    spdlog::warn("ingest: {}: not used as the sensor position ({}): normals are oriented by {}", sensor.source,
                 sensor.refused, orientationMethodName(options.orientation));
  Stopwatch watch;
  auto oriented = normals::estimateOrientedNormals(scan.points.positions, sensor.sensors, options.normalNeighbours,
                                                   options.orientation);
  if (!oriented) return oriented.error();
  normals::OrientedNormals& estimated = *oriented;
  scan.points.normals = std::move(estimated.normals);
  report.normalSeconds = watch.seconds();
  report.normalsSource = "estimated";
  report.normalOrientation =
      estimated.orientation == "viewpoint" && sensor.source == "scan_positions" ? "scan_positions" : estimated.orientation;
  report.normalNeighbours = estimated.neighbours;
  spdlog::info("ingest: normals estimated with k = {}, oriented by {} in {:.2f} s", estimated.neighbours,
               estimated.orientation, report.normalSeconds);
  if (estimated.islands > 1)
    spdlog::info("ingest: the scan is in {} separate pieces; each was oriented by its own spanning tree", estimated.islands);
  if (estimated.unoriented > 0)
    spdlog::warn("ingest: {} points in small separate pieces were oriented like their nearest oriented point",
                 estimated.unoriented);
  report.orientationIslands = estimated.islands;
  report.orientationLeftovers = estimated.unoriented;
  if (estimated.agreement) recordAgreement(*estimated.agreement, report.sensor);

  runStep(report, "drop_points_without_normal", [&] {
    std::vector<char> keep(scan.points.size());
    for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = scan.points.normals[i].allFinite();
    return keepPoints(scan, keep);
  });
  return okStatus();
}

nlohmann::ordered_json vectorJson(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

// How the sensor's normals compared with propagation's, and its sight.
nlohmann::ordered_json agreementJson(const IngestReport::SensorDecision& sensor) {
  return {{"compared", sensor.compared},
          {"disagreeing", sensor.disagreeing},
          {"max_disagreeing_share", normals::kMaxSensorDisagreement},
          {"sight_sampled", sensor.sampledForSight},
          {"sight_hidden", sensor.hidden},
          {"max_hidden_share", normals::kMaxHiddenFromSensor},
          {"sensor_kept", sensor.kept}};
}

// Each scan position of a multi-scan file, with its grid when triangulated.
nlohmann::ordered_json stationsJson(const IngestReport& report) {
  auto stations = nlohmann::ordered_json::array();
  for (std::size_t s = 0; s < report.stations.size(); ++s) {
    const ScanStation& station = report.stations[s];
    const auto& q = station.rotationWxyz;
    nlohmann::ordered_json entry{{"name", station.name},
                                 {"position", vectorJson(station.position)},
                                 {"rotation_wxyz", {q[0], q[1], q[2], q[3]}},
                                 {"pose_given", station.hasPose},
                                 {"points", station.pointCount},
                                 {"rows", station.rowCount},
                                 {"columns", station.columnCount},
                                 {"grid", nullptr}};
    if (s < report.stationGrids.size()) {
      const IngestReport::StationGrid& grid = report.stationGrids[s];
      entry["grid"] = {{"triangles", grid.triangles}, {"refused_triangles", grid.refused}, {"repeated_cells", grid.repeatedCells}};
    }
    stations.push_back(std::move(entry));
  }
  return stations;
}

// The scan as read, or, for a point file above --max-scan-points that can be
// read a run at a time, its voxel centroids (large_scan.h).
Result<Scan> readLargeOrWhole(const fs::path& path, ScanFormat format, const IngestOptions& options,
                              IngestReport& report, const ProgressCallback& readFraction) {
  if (options.maxScanPoints == 0) return readScan(path, format);
  auto file = large_scan::openPointRuns(path, format, options.maxScanPoints);
  if (!file) return file.error();
  if (!*file || (*file)->count <= options.maxScanPoints) return readScan(path, format);
  const std::uint64_t total = (*file)->count;
  spdlog::info("ingest: {} holds {} points, above --max-scan-points {}: read a run at a time into voxel centroids",
               path.string(), total, options.maxScanPoints);
  Stopwatch watch;
  double lastLine = 0.0;
  auto progress = [&](std::uint64_t read, std::uint64_t all) {
    if (readFraction) readFraction(static_cast<double>(read) / static_cast<double>(all));
    const double seconds = watch.seconds();
    if (read < all && seconds - lastLine < 5.0) return;
    lastLine = seconds;
    spdlog::info("ingest: read {} of {} points ({:.0f}%), about {:.0f} s left", read, all, 100.0 * read / all,
                 seconds * (all - read) / std::max<std::uint64_t>(read, 1));
  };
  auto subsample = large_scan::voxelSubsample(**file, options.maxScanPoints, large_scan::kRunPoints, progress);
  if (!subsample) return subsample.error();
  IngestReport::LargeScan& large = report.largeScan;
  large.subsampled = true;
  large.pointsInFile = subsample->pointsRead;
  large.nonFinite = subsample->nonFinite;
  large.kept = subsample->scan.points.size();
  large.limit = options.maxScanPoints;
  large.voxelSize = subsample->voxelSize;
  large.runs = subsample->runs;
  large.coarsenings = subsample->coarsenings;
  Scan scan = std::move(subsample->scan);
  scan.readNotes.push_back(fmt::format(
      "{} points read in {} runs into {} voxel centroids (voxel {:g}; --max-scan-points {}); {} with a non-finite "
      "coordinate dropped; normals, colours and intensities averaged per voxel{}; other attributes not kept",
      large.pointsInFile, large.runs, large.kept, large.voxelSize, large.limit, large.nonFinite,
      scan.points.hasStations()
          ? ", each voxel given the scan position of one of its points (the first, or where two voxels merged that "
            "of the larger)"
          : ""));
  return scan;
}

}  // namespace

Result<IngestResult> ingestScan(const fs::path& path, const Checked<IngestOptions>& checkedOptions,
                                const ProgressCallback& readFraction) {
  const IngestOptions& options = *checkedOptions;
  Stopwatch total;
  IngestResult result;
  IngestReport& report = result.report;
  Scan& scan = result.scan;
  report.inputPath = path.string();

  auto format = formatFromExtension(path);
  if (!format) return format.error();
  report.format = formatName(*format);

  Stopwatch readWatch;
  auto read = readLargeOrWhole(path, *format, options, report, readFraction);
  if (!read) return read.error();
  scan = std::move(read).value();
  report.readSeconds = readWatch.seconds();

  auto sha = sha256OfFile(path);
  if (!sha) return sha.error();
  report.inputSha256 = *sha;

  report.isMesh = scan.isMesh();
  report.origin = scan.origin;
  report.readNotes = scan.readNotes;
  for (const std::string& note : scan.readNotes) spdlog::info("ingest: {}: {}", path.string(), note);
  report.pointsIn = report.largeScan.subsampled ? report.largeScan.pointsInFile : scan.points.size();
  report.trianglesIn = scan.triangles.size();
  spdlog::info("ingest: read {} points, {} triangles from {} ({}) in {:.2f} s", report.pointsIn, report.trianglesIn,
               path.string(), report.format, report.readSeconds);
  if (scan.points.size() == 0) return badInput("{}: contains no points", path.string());

  if (!scan.isMesh() && scan.gridWidth > 0 && options.triangulateGrid) {
    triangulateOrganizedGrid(scan, options, report);
    report.isMesh = scan.isMesh();
  } else if (!scan.isMesh() && scan.points.hasGridIndices() && options.triangulateGrid) {
    triangulateStationGrids(scan, options, report);
    report.isMesh = scan.isMesh();
  }
  runStep(report, "drop_non_finite", [&] { return cleaning::dropNonFinitePoints(scan); });
  if (scan.points.size() == 0)
    return badInput("{}: all {} points have non-finite coordinates", path.string(), report.pointsIn);

  if (report.isMesh) {
    cleanMesh(scan, options, report);
    if (!scan.isMesh())
      return badInput("{}: no valid triangle remains after cleaning ({} read)", path.string(), report.trianglesIn);
    // A depth frame's triangles already face its sensor, and one view is one surface.
    if (options.orientFaces && !report.gridMesh.made) APO_RETURN_IF_ERROR(orientMeshFaces(scan, report));
    if (report.gridMesh.made) APO_RETURN_IF_ERROR(gridMeshNormals(scan, options, report));
    else meshNormals(scan, report);
    // Several scans' grids overlap: their points are reconstructed into M.
    if (!report.gridMesh.made) APO_RETURN_IF_ERROR(decideMeshInput(scan, options, report));
    else if (scan.stations.size() > 1) APO_RETURN_IF_ERROR(decideMeshInput(scan, scansUnlessSurface(options), report));
  } else {
    APO_RETURN_IF_ERROR(cleanPointCloud(scan, options, report, path));
    APO_RETURN_IF_ERROR(pointCloudNormals(scan, options, report, path));
    if (scan.points.size() == 0) return badInput("{}: no point remains after cleaning ({})", path.string(), lastRemoval(report));
  }

  report.pointsOut = scan.points.size();
  report.trianglesOut = scan.triangles.size();
  report.boundingBox = boundingBox(scan.points.positions);
  report.hasViewpoint = scan.viewpoint.has_value();
  if (scan.viewpoint) report.viewpoint = *scan.viewpoint;
  report.stations = scan.stations;
  report.totalSeconds = total.seconds();
  return result;
}

std::string ingestReportJson(const IngestReport& report) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["input"] = {{"path", report.inputPath}, {"sha256", report.inputSha256}, {"format", report.format}};
  json["kind"] = report.isMesh ? "mesh" : "point_cloud";
  json["counts"] = {{"points_in", report.pointsIn},
                    {"points_out", report.pointsOut},
                    {"triangles_in", report.trianglesIn},
                    {"triangles_out", report.trianglesOut}};
  auto steps = nlohmann::ordered_json::array();
  for (const CleaningStep& step : report.steps)
    steps.push_back({{"name", step.name}, {"removed", step.removed}, {"seconds", step.seconds}});
  json["cleaning"] = steps;
  json["bounding_box"] = {{"min", vectorJson(report.boundingBox.min)},
                          {"max", vectorJson(report.boundingBox.max)},
                          {"diagonal", report.boundingBox.diagonal()}};
  json["normals"] = {{"source", report.normalsSource},
                     {"orientation", report.normalOrientation},
                     {"neighbours", report.normalNeighbours},
                     {"mst_islands", report.orientationIslands},
                     {"oriented_by_nearest", report.orientationLeftovers}};
  const auto& sensor = report.sensor;
  json["sensor"] = sensor.source.empty()
                       ? nlohmann::ordered_json(nullptr)
                       : nlohmann::ordered_json{
                             {"source", sensor.source},
                             {"refused", sensor.refused.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(sensor.refused)},
                             {"agreement", !sensor.checked ? nlohmann::ordered_json(nullptr) : agreementJson(sensor)}};
  json["scan_positions"] = stationsJson(report);
  const auto& large = report.largeScan;
  json["large_scan"] = !large.subsampled ? nlohmann::ordered_json(nullptr)
                                         : nlohmann::ordered_json{{"points_in_file", large.pointsInFile},
                                                                  {"non_finite", large.nonFinite},
                                                                  {"voxel_centroids", large.kept},
                                                                  {"max_scan_points", large.limit},
                                                                  {"voxel_size", large.voxelSize},
                                                                  {"runs", large.runs},
                                                                  {"coarsenings", large.coarsenings}};
  if (report.hasViewpoint) {
    const auto& q = report.viewpoint.orientationWxyz;
    json["viewpoint"] = {{"origin", vectorJson(report.viewpoint.origin)}, {"orientation_wxyz", {q[0], q[1], q[2], q[3]}}};
  } else {
    json["viewpoint"] = nullptr;
  }
  // The local frame: file coordinates = origin + the coordinates of every
  // output (docs/ingest.md, "Georeferenced coordinates").
  json["origin"] = {report.origin[0], report.origin[1], report.origin[2]};
  const auto& mi = report.meshInput;
  json["mesh_input"] = !mi.checked ? nlohmann::ordered_json(nullptr)
                                   : nlohmann::ordered_json{{"requested", mi.requested},
                                                            {"decision", mi.decision},
                                                            {"pieces", mi.pieces},
                                                            {"boundary_edge_fraction", mi.boundaryEdgeFraction},
                                                            {"overlap_fraction", mi.overlapFraction},
                                                            {"median_edge_length", mi.medianEdgeLength},
                                                            {"coincident_sheets",
                                                             {{"pairs", mi.coincidentPairs},
                                                              {"opposed_pairs", mi.opposedPairs},
                                                              {"conflicts", mi.conflicts},
                                                              {"turned_pieces", mi.turnedPieces},
                                                              {"turned_points", mi.turnedPoints}}}};
  const auto& g = report.gridMesh;
  json["grid_mesh"] = !g.made ? nlohmann::ordered_json(nullptr)
                              : nlohmann::ordered_json{{"width", g.width},
                                                       {"height", g.height},
                                                       {"pixels_without_return", g.missing},
                                                       {"triangles", g.triangles},
                                                       {"refused_triangles", g.refused},
                                                       {"angular_step", g.angularStep},
                                                       {"max_edge_in_spacings", g.maxEdgeInSpacings},
                                                       {"sensor", vectorJson(g.sensor)},
                                                       {"sensor_from", g.sensorSource}};
  json["read_notes"] = report.readNotes;
  const auto& f = report.faceOrientation;
  json["face_orientation"] = !f.checked ? nlohmann::ordered_json(nullptr)
                                        : nlohmann::ordered_json{{"pieces", f.components},
                                                                 {"flipped_pieces", f.flippedComponents},
                                                                 {"flipped_triangles", f.flippedTriangles},
                                                                 {"decided_by_volume", f.byVolume},
                                                                 {"decided_by_visibility", f.byVisibility},
                                                                 {"decided_by_neighbours", f.byNeighbours},
                                                                 {"undecided", f.undecided}};
  json["seconds"] = {{"read", report.readSeconds}, {"normals", report.normalSeconds}, {"total", report.totalSeconds}};
  return json.dump(2) + "\n";
}

Status writeIngestOutputs(const fs::path& outDir, const IngestResult& result) {
  APO_RETURN_IF_ERROR(writePly(outDir / "scan.ply", result.scan));
  return writeFileAtomically(outDir / "ingest.json", ingestReportJson(result.report));
}

}  // namespace apo
