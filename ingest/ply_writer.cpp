// PLY writer: the layout readPly reads back exactly, for scan.ply and tests.
//
//   ply
//   format ascii 1.0 | format binary_little_endian 1.0
//   comment written by apo
//   comment apo_origin X Y Z           (if the scan is in a local frame)
//   element vertex N
//   property float x, y, z             (double in world coordinates: PlyFrame::World)
//   property float nx, ny, nz          (if normals)
//   property uchar red, green, blue    (if colors)
//   property float intensity           (if intensities)
//   property uchar classification      (if classifications)
//   property uchar return_number, number_of_returns  (if returns)
//   element face M                     (if triangles)
//   property list uchar int vertex_indices
//   end_header
//
// ASCII floats are printed in their shortest round-tripping form, so a read
// back gives the same bits.
#include "core/error.h"
#include "ingest/readers.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <limits>
#include <string>

namespace apo::readers {
namespace {

void checkAttributeSizes(const PointSet& points) {
  const std::size_t n = points.size();
  APO_CHECK(points.normals.empty() || points.normals.size() == n);
  APO_CHECK(points.colors.empty() || points.colors.size() == n);
  APO_CHECK(points.intensities.empty() || points.intensities.size() == n);
  APO_CHECK(points.classifications.empty() || points.classifications.size() == n);
  APO_CHECK(points.returnNumbers.size() == points.returnCounts.size());
  APO_CHECK(points.returnNumbers.empty() || points.returnNumbers.size() == n);
  // Faces store indices as PLY "int".
  APO_CHECK_OP(n, <=, static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()));
}

bool writesWorld(const Scan& scan, PlyFrame frame) { return frame == PlyFrame::World && scan.isGeoreferenced(); }

Eigen::Vector3d worldPosition(const Scan& scan, const Vec3f& p) {
  return {scan.origin[0] + p.x(), scan.origin[1] + p.y(), scan.origin[2] + p.z()};
}

std::string header(const Scan& scan, PlyEncoding encoding, PlyFrame frame) {
  const PointSet& points = scan.points;
  std::string text = "ply\n";
  text += encoding == PlyEncoding::Ascii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
  text += "comment written by apo\n";
  // Shortest round-tripping doubles: the reader gets the same origin back.
  if (scan.isGeoreferenced() && !writesWorld(scan, frame))
    text += fmt::format("comment apo_origin {} {} {}\n", scan.origin[0], scan.origin[1], scan.origin[2]);
  text += fmt::format("element vertex {}\n", points.size());
  text += writesWorld(scan, frame) ? "property double x\nproperty double y\nproperty double z\n"
                                   : "property float x\nproperty float y\nproperty float z\n";
  if (points.hasNormals()) text += "property float nx\nproperty float ny\nproperty float nz\n";
  if (points.hasColors()) text += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (points.hasIntensities()) text += "property float intensity\n";
  if (points.hasClassifications()) text += "property uchar classification\n";
  if (points.hasReturns()) text += "property uchar return_number\nproperty uchar number_of_returns\n";
  if (scan.isMesh()) {
    text += fmt::format("element face {}\n", scan.triangles.size());
    text += "property list uchar int vertex_indices\n";
  }
  text += "end_header\n";
  return text;
}

void appendAsciiBody(const Scan& scan, PlyFrame frame, std::string& out) {
  const PointSet& points = scan.points;
  // fmt's own buffer appends in blocks; a back_inserter into the string would
  // push characters one at a time.
  fmt::memory_buffer text;
  auto sink = std::back_inserter(text);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points.positions[i];
    if (writesWorld(scan, frame)) {
      const Eigen::Vector3d w = worldPosition(scan, p);
      fmt::format_to(sink, "{} {} {}", w.x(), w.y(), w.z());
    } else {
      fmt::format_to(sink, "{} {} {}", p.x(), p.y(), p.z());
    }
    if (points.hasNormals()) {
      const Vec3f& n = points.normals[i];
      fmt::format_to(sink, " {} {} {}", n.x(), n.y(), n.z());
    }
    if (points.hasColors()) {
      const Rgb8& c = points.colors[i];
      fmt::format_to(sink, " {} {} {}", unsigned{c.r}, unsigned{c.g}, unsigned{c.b});
    }
    if (points.hasIntensities()) fmt::format_to(sink, " {}", points.intensities[i]);
    if (points.hasClassifications()) fmt::format_to(sink, " {}", unsigned{points.classifications[i]});
    if (points.hasReturns())
      fmt::format_to(sink, " {} {}", unsigned{points.returnNumbers[i]}, unsigned{points.returnCounts[i]});
    text.push_back('\n');
  }
  for (const Triangle& t : scan.triangles) fmt::format_to(sink, "3 {} {} {}\n", t[0], t[1], t[2]);
  out.append(text.data(), text.size());
}

template <class T>
void appendLittleEndian(std::string& out, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(raw, raw + sizeof(T));
  out.append(raw, sizeof(T));
}

void appendVec3(std::string& out, const Vec3f& v) {
  appendLittleEndian(out, v.x());
  appendLittleEndian(out, v.y());
  appendLittleEndian(out, v.z());
}

void appendBinaryBody(const Scan& scan, PlyFrame frame, std::string& out) {
  const PointSet& points = scan.points;
  const bool world = writesWorld(scan, frame);
  const std::size_t vertexBytes = (world ? 24 : 12) + (points.hasNormals() ? 12 : 0) + (points.hasColors() ? 3 : 0) +
                                  (points.hasIntensities() ? 4 : 0) + (points.hasClassifications() ? 1 : 0) +
                                  (points.hasReturns() ? 2 : 0);
  constexpr std::size_t kFaceBytes = 1 + 3 * 4;
  out.reserve(out.size() + points.size() * vertexBytes + scan.triangles.size() * kFaceBytes);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (world) {
      const Eigen::Vector3d w = worldPosition(scan, points.positions[i]);
      for (int axis = 0; axis < 3; ++axis) appendLittleEndian(out, w[axis]);
    } else {
      appendVec3(out, points.positions[i]);
    }
    if (points.hasNormals()) appendVec3(out, points.normals[i]);
    if (points.hasColors()) {
      const Rgb8& c = points.colors[i];
      out += static_cast<char>(c.r);
      out += static_cast<char>(c.g);
      out += static_cast<char>(c.b);
    }
    if (points.hasIntensities()) appendLittleEndian(out, points.intensities[i]);
    if (points.hasClassifications()) out += static_cast<char>(points.classifications[i]);
    if (points.hasReturns()) {
      out += static_cast<char>(points.returnNumbers[i]);
      out += static_cast<char>(points.returnCounts[i]);
    }
  }
  for (const Triangle& t : scan.triangles) {
    out += static_cast<char>(3);
    for (std::uint32_t index : t) appendLittleEndian(out, static_cast<std::int32_t>(index));
  }
}

}  // namespace

std::string encodePly(const Scan& scan, PlyEncoding encoding, PlyFrame frame) {
  checkAttributeSizes(scan.points);
  std::string out = header(scan, encoding, frame);
  if (encoding == PlyEncoding::Ascii)
    appendAsciiBody(scan, frame, out);
  else
    appendBinaryBody(scan, frame, out);
  return out;
}

}  // namespace apo::readers
