// Plain geometry types shared by every stage. No behaviour beyond trivial
// accessors: algorithms live in the stages and take these by reference.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace apo {

using Vec3f = Eigen::Vector3f;

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

// Points and their optional per-point attributes. Each attribute vector is
// either empty (attribute absent) or exactly positions.size() long.
struct PointSet {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;      // unit length when present
  std::vector<Rgb8> colors;
  std::vector<float> intensities;  // PLY confidence/intensity, PCD intensity, LAS intensity
  // Lidar attributes (LAS): the ASPRS class, and the return's number among
  // its pulse's returns (1-based) with that count.
  std::vector<std::uint8_t> classifications;
  std::vector<std::uint8_t> returnNumbers, returnCounts;
  // Multi-scan files (E57): the index into Scan::stations of the scan each
  // point came from, and, for structured scans, its row and column in that
  // scan's grid.
  std::vector<std::uint16_t> stations;
  std::vector<std::uint32_t> rows, columns;

  std::size_t size() const { return positions.size(); }
  bool hasNormals() const { return !normals.empty(); }
  bool hasColors() const { return !colors.empty(); }
  bool hasIntensities() const { return !intensities.empty(); }
  bool hasClassifications() const { return !classifications.empty(); }
  bool hasReturns() const { return !returnNumbers.empty(); }
  bool hasStations() const { return !stations.empty(); }
  bool hasGridIndices() const { return !rows.empty(); }
};

// Indices into PointSet::positions, counter-clockwise seen from outside.
using Triangle = std::array<std::uint32_t, 3>;

// Sensor pose recorded by the file (PCD VIEWPOINT): origin and orientation
// quaternion (w, x, y, z). Used to orient estimated normals towards the sensor.
struct Viewpoint {
  Vec3f origin = Vec3f::Zero();
  std::array<float, 4> orientationWxyz = {1, 0, 0, 0};
  // The format's default (PCD's 0 0 0 1 0 0 0, which PCL writes whatever
  // the sensor): no evidence of where the sensor stood.
  bool isFormatDefault = false;
};

// One scan position of a multi-scan file (an E57 data3D): where the scanner
// stood, in the scan's local frame (Scan::origin), and how it was turned.
// Its points are already moved by this pose into the common frame.
struct ScanStation {
  std::string name;                           // the file's name or guid for it
  Vec3f position = Vec3f::Zero();
  std::array<double, 4> rotationWxyz = {1, 0, 0, 0};
  bool hasPose = false;                       // false: the file gave none (identity)
  // Structured scans: the size of the row/column grid (0 when unstructured).
  std::uint32_t rowCount = 0, columnCount = 0;
  std::uint64_t pointCount = 0;               // points read for it (valid ones)
};

// What ingest reads and every later stage starts from: a point cloud when
// `triangles` is empty, a triangle mesh over `points` otherwise.
struct Scan {
  PointSet points;
  std::vector<Triangle> triangles;
  std::optional<Viewpoint> viewpoint;
  // The local frame: the file's coordinates are origin + position. Readers
  // move coordinates far from zero (georeferenced lidar, in UTM metres) near
  // it, in double precision, so that float positions keep the scan's
  // detail; zero for everything else. Every stage keeps it.
  std::array<double, 3> origin = {0.0, 0.0, 0.0};
  // Organised clouds (a depth frame, PCD HEIGHT > 1): the points are rows of
  // this many, one per pixel, missing returns kept in place as NaN; 0 for
  // everything else. Ingest triangulates the grid (docs/ingest.md).
  std::uint32_t gridWidth = 0;
  // Multi-scan files: each scan's position; points name theirs in
  // PointSet::stations. Empty for everything else.
  std::vector<ScanStation> stations;
  // What the reader skipped or turned into something else, in words
  // ("element 'edge' (120 items) skipped"), for ingest.json.
  std::vector<std::string> readNotes;

  bool isMesh() const { return !triangles.empty(); }
  bool isGeoreferenced() const { return origin != std::array<double, 3>{0.0, 0.0, 0.0}; }
};

struct Aabb {
  Vec3f min = Vec3f::Constant(std::numeric_limits<float>::infinity());
  Vec3f max = Vec3f::Constant(-std::numeric_limits<float>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Vec3f& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  Vec3f extent() const { return max - min; }
  float diagonal() const { return empty() ? 0.0f : extent().norm(); }
};

Aabb boundingBox(const std::vector<Vec3f>& positions);

// Unit vertex normals of a mesh, each the area-weighted sum of its triangles'
// normals; vertices in no triangle (or only degenerate ones) get +z.
std::vector<Vec3f> areaWeightedVertexNormals(const Scan& mesh);

// Gives a mesh area-weighted vertex normals, in place, unless it has one
// per vertex; points are left as they are (their normals come from
// `apo ingest`).
void addVertexNormalsIfMissing(Scan& mesh);

// A mesh's vertex normals as the renderer, the bake and the export take them:
// the file's own (one per vertex), else areaWeightedVertexNormals.
std::vector<Vec3f> vertexNormalsAsDrawn(const Scan& mesh);

// Total area of a mesh's triangles.
double surfaceArea(const Scan& mesh);

// The Morton code of grid cell (x, y, z), 16 bits at most per coordinate:
// their bits interleaved, x's highest. Inline: the bake's octree build
// codes millions of pieces with it.
inline std::uint64_t mortonCode(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  const auto spread = [](std::uint32_t coordinate) {  // to every third bit
    std::uint64_t v = coordinate & 0xFFFF;
    v = (v | v << 16) & 0x0000FF0000FF;
    v = (v | v << 8) & 0x00F00F00F00F;
    v = (v | v << 4) & 0x0C30C30C30C3;
    v = (v | v << 2) & 0x249249249249;
    return v;
  };
  return spread(x) << 2 | spread(y) << 1 | spread(z);
}

// How far apart consecutive triangles of the list lie: the median, over up
// to 4,096 pairs spread along it, of the distance between the centres of
// triangles i and i + 1, in units of those triangles' mean edge length (0
// for fewer than two triangles or no edge length). About 1 for a mesh
// written in scan, subdivision or reconstruction order; hundreds when its
// triangles are shuffled.
double faceOrderSpread(const Scan& mesh);

// The mesh's triangles sorted by the Morton code of their centres (10 bits
// per axis of the bounding box), ties in the list's order: neighbours in
// the list are then neighbours in space.
std::vector<Triangle> trianglesInMortonOrder(const Scan& mesh);

// The pieces of a mesh: triangles connected through shared vertices,
// numbered in the order of their first triangle. Vertices in no triangle
// belong to no piece (kNoPiece).
struct MeshPieces {
  static constexpr std::uint32_t kNoPiece = ~0u;
  std::vector<std::uint32_t> ofTriangle, ofVertex;
  std::uint32_t count = 0;
};
MeshPieces meshPieces(const Scan& mesh);

// `count` unit directions spread evenly over the sphere (Fibonacci lattice),
// the same on every call.
std::vector<Vec3f> fibonacciDirections(int count);

}  // namespace apo
