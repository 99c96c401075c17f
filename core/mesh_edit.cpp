#include "core/mesh_edit.h"

#include <algorithm>
#include <cstdint>

namespace apo {
namespace {

template <class T>
void compact(std::vector<T>& values, const std::vector<char>& keep) {
  if (values.empty()) return;
  std::size_t out = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (keep[i]) values[out++] = values[i];
  values.resize(out);
}

// Rewrites triangle indices through `newIndex` and drops triangles that use
// a vertex mapped to kRemoved.
constexpr std::uint32_t kRemoved = ~0u;
void remapTriangles(std::vector<Triangle>& triangles, const std::vector<std::uint32_t>& newIndex) {
  std::size_t out = 0;
  for (const Triangle& t : triangles) {
    const Triangle mapped = {newIndex[t[0]], newIndex[t[1]], newIndex[t[2]]};
    if (mapped[0] != kRemoved && mapped[1] != kRemoved && mapped[2] != kRemoved) triangles[out++] = mapped;
  }
  triangles.resize(out);
}

}  // namespace

std::size_t keepPoints(Scan& scan, const std::vector<char>& keep) {
  PointSet& points = scan.points;
  std::vector<std::uint32_t> newIndex(points.size(), kRemoved);
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (keep[i]) newIndex[i] = next++;
  const std::size_t removed = points.size() - next;
  if (removed == 0) return 0;
  compact(points.positions, keep);
  compact(points.normals, keep);
  compact(points.colors, keep);
  compact(points.intensities, keep);
  compact(points.classifications, keep);
  compact(points.returnNumbers, keep);
  compact(points.returnCounts, keep);
  compact(points.stations, keep);
  compact(points.rows, keep);
  compact(points.columns, keep);
  remapTriangles(scan.triangles, newIndex);
  scan.gridWidth = 0;  // rows with points taken out are no longer a grid
  return removed;
}

std::size_t dropDegenerateTriangles(Scan& mesh) {
  const auto& p = mesh.points.positions;
  const std::size_t before = mesh.triangles.size();
  std::erase_if(mesh.triangles, [&](const Triangle& t) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
    return (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).squaredNorm() == 0.0f;
  });
  return before - mesh.triangles.size();
}

std::size_t dropUnreferencedVertices(Scan& mesh) {
  std::vector<char> used(mesh.points.size(), 0);
  for (const Triangle& t : mesh.triangles)
    for (auto v : t) used[v] = 1;
  return keepPoints(mesh, used);
}

}  // namespace apo
