// ingest: reads a scan (point cloud or dense mesh) from PLY, PCD, XYZ/XYZN/PTS/CSV,
// OFF, OBJ, STL or LAS, validates it, cleans it, and gives point clouds oriented
// normals. Every failure on untrusted input is a BadInput Error whose message
// names the file, the position in it (line or byte offset) and the problem.
#pragma once

#include "core/checked.h"
#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"
#include "core/timing.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace apo {

enum class ScanFormat { Ply, Pcd, Xyz, Off, Obj, Stl, Las, E57 };

// Name used in reports: "ply", "pcd", "xyz", "off", "obj", "stl", "las", "e57".
std::string formatName(ScanFormat format);

// The format a path's extension names (case-insensitive: .ply .pcd .xyz .xyzn
// .pts .pwn .csv .asc .off .obj .stl .las .laz .e57); a BadInput error for anything else.
Result<ScanFormat> formatFromExtension(const std::filesystem::path& path);
// Whether formatFromExtension accepts the path.
bool hasScanExtension(const std::filesystem::path& path);
// The extensions readScan accepts, lower case with the dot, space-separated
// (".ply .pcd ..."), for messages and help.
std::string scanExtensionList();

// Reads a scan as stored: non-finite coordinates are kept (cleaning counts and
// drops them), polygons are fan-triangulated, normals are normalised only by
// cleaning. Colors become Rgb8, PLY confidence/intensity and PCD intensity
// become intensities.
Result<Scan> readScan(const std::filesystem::path& path);
Result<Scan> readScan(const std::filesystem::path& path, ScanFormat format);

// Writes a binary little-endian PLY (float x y z [nx ny nz] [uchar red green
// blue] [float intensity], uchar/int vertex_indices faces), atomically.
// Positions are in the scan's local frame with its origin in a comment, or,
// with `worldCoordinates` (--keep-georeference), origin + position in double.
Status writePly(const std::filesystem::path& path, const Scan& scan, bool worldCoordinates = false);
// Writes an ASCII PLY with the same properties (for tests and inspection).
Status writePlyAscii(const std::filesystem::path& path, const Scan& scan);
// Writes an E57 file of the scan (readers.h, encodeE57), atomically.
Status writeE57(const std::filesystem::path& path, const Scan& scan);
// Writes a LAS 1.2 file of the scan's points, LAZ when `compressed`
// (readers.h, encodeLas), atomically. A BadInput error for a scan LAS
// cannot hold: no points, over 2^32 - 1, or a non-finite coordinate.
Status writeLas(const std::filesystem::path& path, const Scan& scan, bool compressed);

// How normals are oriented without a viewpoint: propagation over the k-NN
// graph (Hoppe's rule on our own graph: a 1M-point scan in seconds), or
// CGAL's MST orientation (the same rule; about 40 s and 4.5 GiB for that
// scan), kept for comparison (docs/benchmarks.md).
enum class OrientationMethod { Propagation, CgalMst };
std::string orientationMethodName(OrientationMethod method);  // "propagation", "mst"

// What a mesh input is: decided from the data (auto), one surface (adopted
// as M), or a set of overlapping range scans (its vertices, with the faces'
// normals, reconstructed like a point cloud).
enum class MeshInput { Auto, Surface, Scans };
std::string meshInputName(MeshInput input);  // "auto", "surface", "scans"

struct IngestOptions {
  bool mergeDuplicates = true;      // exact duplicate points / vertices merged
  bool removeOutliers = false;      // PCL StatisticalOutlierRemoval
  int outlierNeighbours = 16;       // k of the outlier statistics
  double outlierStdDevs = 2.0;      // keep points within mean + this * stddev
  double voxelSize = 0.0;           // > 0: PCL VoxelGrid downsampling (point clouds)
  bool estimateNormals = true;      // for point clouds that have none
  int normalNeighbours = 0;         // 0: chosen from the data (see docs/ingest.md)
  bool forceNormalEstimation = false;  // re-estimate even if the file has normals
  std::optional<Vec3f> sensorPosition; // overrides the file's viewpoint for orientation
  OrientationMethod orientation = OrientationMethod::Propagation;
  // Mesh pieces wound inward are flipped (docs/ingest.md); false: kept as read.
  bool orientFaces = true;
  MeshInput meshInput = MeshInput::Auto;
  // Organised clouds (depth frames) are triangulated on their grid
  // (docs/ingest.md); false: read as loose points.
  bool triangulateGrid = true;
  // A point file of more points than this (binary PLY of vertices alone,
  // LAS, LAZ) is read a run at a time into at most this many voxel
  // centroids, in memory bounded by them (docs/ingest.md, "Large scans");
  // 0: always read whole.
  std::uint64_t maxScanPoints = kDefaultMaxScanPoints;
  static constexpr std::uint64_t kDefaultMaxScanPoints = 10'000'000;
};

// Usage error naming the option when one is out of range.
template <>
Result<Checked<IngestOptions>> check(const IngestOptions& options);

// What happened to the scan, step by step, for ingest.json.
struct CleaningStep {
  std::string name;          // "drop_non_finite", "merge_duplicates", ...
  std::uint64_t removed = 0; // points (or faces, for face steps) removed
  double seconds = 0.0;
};

struct IngestReport {
  std::string inputPath;
  std::string inputSha256;
  std::string format;
  bool isMesh = false;
  std::uint64_t pointsIn = 0, pointsOut = 0;
  std::uint64_t trianglesIn = 0, trianglesOut = 0;
  std::vector<CleaningStep> steps;
  Aabb boundingBox;
  std::string normalsSource;      // "read", "estimated", "computed_from_faces"
  std::string normalOrientation;  // "viewpoint", "propagation", "mst", "file", "faces"
  int normalNeighbours = 0;       // k used when estimated
  std::uint64_t orientationIslands = 0;    // MST passes, one per separate piece
  std::uint64_t orientationLeftovers = 0;  // points oriented by their nearest neighbour
  bool hasViewpoint = false;
  Viewpoint viewpoint;
  // Whose position oriented the normals, or why a declared one was not
  // used, and how it agreed with propagation (docs/ingest.md, "Sensor positions").
  struct SensorDecision {
    std::string source;   // "--sensor", "scan_positions", "viewpoint", "pcd_default_viewpoint",
                          // "origin" (depth frames); "" none declared
    std::string refused;  // why a declared position was not used; empty when it was
    bool checked = false;  // its normals compared with propagation's
    std::uint64_t compared = 0, disagreeing = 0;
    std::uint64_t sampledForSight = 0, hidden = 0;  // points tested for a clear line to the sensor, hidden ones
    bool kept = false;     // the sensor's orientation kept
  } sensor;
  // Meshes: pieces found wound inward and flipped (docs/ingest.md).
  struct FaceOrientation {
    bool checked = false;
    std::uint64_t components = 0, flippedComponents = 0, flippedTriangles = 0;
    std::uint64_t byVolume = 0, byVisibility = 0, byNeighbours = 0, undecided = 0;
  } faceOrientation;
  // Meshes: one surface or a set of scans, and the figures behind it.
  struct MeshInputDecision {
    bool checked = false;
    std::string requested, decision;  // "auto" / "surface" / "scans"; "surface" / "scans"
    std::uint64_t pieces = 0;
    double boundaryEdgeFraction = 0.0, overlapFraction = 0.0, medianEdgeLength = 0.0;
    // Scans only: coincident sheets facing opposite ways turned to agree.
    std::uint64_t coincidentPairs = 0, opposedPairs = 0, conflicts = 0, turnedPieces = 0, turnedPoints = 0;
  } meshInput;
  // Organised clouds: the grid triangulated from the sensor (docs/ingest.md).
  struct GridMesh {
    bool made = false;
    std::uint64_t width = 0, height = 0;
    std::uint64_t missing = 0;                  // pixels without a return (NaN)
    std::uint64_t candidates = 0, triangles = 0, refused = 0;  // range_grid::GridTriangles
    double angularStep = 0.0;                   // radians between neighbouring pixels, from the data
    double maxEdgeInSpacings = 0.0;             // the depth-jump test, from the data (range_grid::GridSpacing)
    Vec3f sensor = Vec3f::Zero();
    std::string sensorSource;                   // "--sensor", "viewpoint" (the file's) or "origin"
  } gridMesh;
  // Structured multi-scan files: each scan's grid (docs/ingest.md).
  struct StationGrid {
    std::string name;
    std::uint64_t rows = 0, columns = 0;
    std::uint64_t triangles = 0, refused = 0;
    std::uint64_t repeatedCells = 0;  // points on a cell already taken (left out of the grid)
  };
  std::vector<StationGrid> stationGrids;
  std::vector<ScanStation> stations;  // multi-scan files' scan positions, as read
  // Scans above --max-scan-points: read a run at a time into voxel centroids.
  struct LargeScan {
    bool subsampled = false;
    std::uint64_t pointsInFile = 0;    // the header's count, all read
    std::uint64_t nonFinite = 0;       // of them, with a non-finite coordinate
    std::uint64_t kept = 0;            // voxel centroids kept
    std::uint64_t limit = 0;           // --max-scan-points
    double voxelSize = 0.0;            // file units
    std::uint64_t runs = 0, coarsenings = 0;
  } largeScan;
  std::array<double, 3> origin = {0.0, 0.0, 0.0};  // Scan::origin: the local frame
  std::vector<std::string> readNotes;               // what the reader skipped or converted
  double readSeconds = 0.0;
  double normalSeconds = 0.0;
  double totalSeconds = 0.0;
};

struct IngestResult {
  Scan scan;
  IngestReport report;
};

// ---- Every point of a large scan, on disk (docs/ingest.md, "Every point") --

// What writing a store found.
struct PointStoreReport {
  std::uint64_t points = 0;               // finite points stored
  std::uint64_t nonFinite = 0;            // skipped
  int gridDepth = 0;                      // 2^depth cells a side
  std::uint64_t occupiedCells = 0;
  int neighbours = 0;                     // k of the normals
  std::uint64_t unfittedNormals = 0;      // no plane fitted: the nearest oriented point's normal
  std::uint64_t cutNeighbourhoods = 0;    // k nearest not provably all within the cell's band
  std::uint64_t bytes = 0;                // on disk
  bool reused = false;                    // found complete from an earlier run
  double seconds = 0.0;
};

// A scan's every point with a normal, sorted into the cells of a grid over
// its box, in files under one folder (format: docs/ingest.md, "Every
// point"). Read a box at a time; the points come in the store's order
// (cell by cell, each cell's in the file's order), the same for any box.
class PointStore {
 public:
  // Opens a complete store; BadInput when the folder holds none, an older
  // or damaged one (its files' sizes disagree with store.json).
  static Result<PointStore> open(const std::filesystem::path& folder);

  std::uint64_t size() const { return count_; }
  const std::filesystem::path& folder() const { return folder_; }
  const PointStoreReport& report() const { return report_; }
  // The points inside `box` (the scan's local frame, bounds included).
  Result<PointSet> pointsIn(const Aabb& box) const;

 private:
  friend Result<PointStore> writePointStore(const std::filesystem::path&, const Scan&, int, const std::filesystem::path&,
                                            const ProgressCallback&);
  std::filesystem::path folder_;
  std::uint64_t count_ = 0;
  Aabb grid_;       // the grid's cube
  int depth_ = 0;
  std::vector<std::uint64_t> cellBegin_;  // per cell (x-major), and the end
  PointStoreReport report_;
};

// Writes every finite point of the file at `scanPath` (one read a run at a
// time: a binary PLY of vertices alone, a LAS or a LAZ file) into a store in
// `folder`, in the local frame of `oriented`, with normals: PCA over k
// neighbours found within the point's cell and a band around it, turned to
// agree with the nearest point of `oriented` (the scan's voxel centroids as
// ingest oriented them); with k = 0, no plane: each point takes the nearest
// oriented point's normal (docs/ingest.md, "Every point"). A complete store of the same file and k already in
// the folder is reused. Two passes over the file, then one over the cells.
// BadInput when the file cannot be read so; Internal when a write fails (a
// full disk), the folder then left without store.json.
Result<PointStore> writePointStore(const std::filesystem::path& scanPath, const Scan& oriented, int k,
                                   const std::filesystem::path& folder, const ProgressCallback& progress = {});

// Reads, validates and cleans `path`, and estimates and orients normals when
// the scan is a point cloud without them. Fails with BadInput when the file is
// malformed or nothing remains after cleaning. `readFraction` hears the share
// of the file read, for scans read a run at a time (docs/ingest.md, "Large scans").
Result<IngestResult> ingestScan(const std::filesystem::path& path, const Checked<IngestOptions>& options,
                                const ProgressCallback& readFraction = {});

// ingest.json text (pretty-printed, stable key order) for a report.
std::string ingestReportJson(const IngestReport& report);

// Writes `scan.ply` and `ingest.json` into `outDir`, atomically.
Status writeIngestOutputs(const std::filesystem::path& outDir, const IngestResult& result);

}  // namespace apo

// ---------------------------------------------------------------------------
// Virtual range scanner (`apo simulate-scan`): makes scans of meshes with
// known ground truth for the tests of every stage.

namespace apo {

struct SimulateScanOptions {
  int views = 8;                   // scanner positions on a sphere around the mesh
  int raysPerSide = 200;           // each view casts raysPerSide^2 rays
  double rangeNoise = 0.0005;      // std-dev of range noise, fraction of the bbox diagonal
  double misregistration = 0.0002; // per-view rigid offset, fraction of the diagonal (and radians)
  std::uint64_t seed = 1;
  bool withNormals = false;        // also write the true surface normals of the hits
  // Each view's range grid triangulated, as scanner software writes a set of
  // range scans: one soup of overlapping sheets (no vertex shared between
  // views); cells across depth jumps and grazing cells are left out.
  bool asMesh = false;
};

// Usage error naming the option when one is out of range.
template <>
Result<Checked<SimulateScanOptions>> check(const SimulateScanOptions& options);

struct SimulatedScan {
  Scan scan;                       // points (and normals when asked)
  std::vector<Vec3f> viewOrigins;  // scanner positions, one per view
  std::vector<std::uint32_t> pointsPerView;
};

// Places `views` scanners on a Fibonacci sphere at twice the radius of the
// mesh's bounding sphere (about its box centre),
// casts a square grid of rays from each towards the mesh, keeps the hits,
// perturbs each range by Gaussian noise and each view by a small rigid motion.
// `caster` hits the mesh's triangles (makeEmbreeMeshCaster in production).
// Deterministic for given options.
Result<SimulatedScan> simulateScan(const Scan& mesh, const RayCaster& caster, const Checked<SimulateScanOptions>& options);

}  // namespace apo
