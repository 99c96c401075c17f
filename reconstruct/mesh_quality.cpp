// Mesh figures counted on the triangles as a soup (sorted sides and
// union-find), so that non-manifold input is measured, not refused; and an
// even sampling of a surface, for the distance measures.
#include "reconstruct/mesh_quality.h"

#include "core/mesh_edges.h"
#include "reconstruct/reconstruct.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

namespace apo {
namespace {

// Corner k of triangle t is 3t + k; a side's corners are its two ends.
std::uint32_t cornerId(std::uint32_t triangle, std::uint32_t corner) { return 3 * triangle + corner; }
std::uint32_t startCorner(const TriangleSide& s) { return cornerId(s.triangle, s.corner); }
std::uint32_t endCorner(const TriangleSide& s) { return cornerId(s.triangle, (s.corner + 1) % 3); }

// Corners at the same vertex are in one fan when their triangles are linked
// through edges at that vertex. A manifold vertex has one fan; a bow-tie
// vertex has two.
DisjointSets cornerFans(const std::vector<Triangle>& triangles, const std::vector<TriangleSide>& sides) {
  DisjointSets fans(3 * triangles.size());
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first + 1; i < last; ++i) {
      const TriangleSide &a = sides[first], &b = sides[i];
      // Each end of b matches the end of a that holds the same vertex.
      const bool sameDirection = triangles[a.triangle][a.corner] == triangles[b.triangle][b.corner];
      fans.unite(startCorner(a), sameDirection ? startCorner(b) : endCorner(b));
      fans.unite(endCorner(a), sameDirection ? endCorner(b) : startCorner(b));
    }
  });
  return fans;
}

std::uint64_t countNonManifoldVertices(const std::vector<Triangle>& triangles, DisjointSets& fans) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> vertexFans;  // (vertex, fan root)
  vertexFans.reserve(3 * triangles.size());
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t c = 0; c < 3; ++c) vertexFans.emplace_back(triangles[t][c], fans.find(cornerId(t, c)));
  std::sort(vertexFans.begin(), vertexFans.end());
  vertexFans.erase(std::unique(vertexFans.begin(), vertexFans.end()), vertexFans.end());
  std::uint64_t count = 0;
  for (std::size_t i = 1; i < vertexFans.size(); ++i)
    if (vertexFans[i].first == vertexFans[i - 1].first && (i == 1 || vertexFans[i - 2].first != vertexFans[i].first))
      ++count;  // the second fan of a vertex
  return count;
}

// A boundary loop is a chain of boundary sides; consecutive sides meet at a
// vertex within one fan, so chaining through fans (not bare vertices) keeps
// two loops that touch at a pinched vertex apart.
std::uint64_t countBoundaryLoops(DisjointSets fans, const std::vector<TriangleSide>& sides) {
  std::vector<std::uint32_t> boundaryCorners;
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    if (last - first != 1) return;
    fans.unite(startCorner(sides[first]), endCorner(sides[first]));
    boundaryCorners.push_back(startCorner(sides[first]));
  });
  std::vector<std::uint32_t> loops;
  for (const std::uint32_t corner : boundaryCorners) loops.push_back(fans.find(corner));
  std::sort(loops.begin(), loops.end());
  return static_cast<std::uint64_t>(std::unique(loops.begin(), loops.end()) - loops.begin());
}

std::uint64_t countUsedVertices(const Scan& mesh) {
  std::vector<char> used(mesh.points.size(), 0);
  for (const Triangle& t : mesh.triangles)
    for (const std::uint32_t v : t) {
      APO_CHECK_OP(v, <, used.size());
      used[v] = 1;
    }
  return static_cast<std::uint64_t>(std::count(used.begin(), used.end(), 1));
}

std::vector<std::uint32_t> componentsOverSides(std::size_t triangleCount, const std::vector<TriangleSide>& sides,
                                               std::uint32_t& componentCount) {
  DisjointSets sets(triangleCount);
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first + 1; i < last; ++i) sets.unite(sides[first].triangle, sides[i].triangle);
  });
  constexpr auto unnumbered = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> numberOfRoot(triangleCount, unnumbered), component(triangleCount);
  componentCount = 0;
  for (std::uint32_t t = 0; t < triangleCount; ++t) {
    std::uint32_t& number = numberOfRoot[sets.find(t)];
    if (number == unnumbered) number = componentCount++;
    component[t] = number;
  }
  return component;
}

// Uniform in [0, 1) from the top 53 bits: std::uniform_real_distribution's
// algorithm is up to the standard library, this is not.
double unitUniform(std::mt19937_64& random) { return static_cast<double>(random() >> 11) * 0x1.0p-53; }

// Uniform point of the triangle (square-root warp of two uniforms).
Vec3f pointInTriangle(const Vec3f& a, const Vec3f& b, const Vec3f& c, std::mt19937_64& random) {
  const double s = std::sqrt(unitUniform(random)), t = unitUniform(random);
  const Eigen::Vector3d p =
      (1.0 - s) * a.cast<double>() + s * (1.0 - t) * b.cast<double>() + s * t * c.cast<double>();
  return p.cast<float>();
}

}  // namespace

MeshQuality measureMesh(const Scan& mesh) {
  MeshQuality quality;
  quality.vertices = mesh.points.size();
  quality.triangles = mesh.triangles.size();
  const std::vector<TriangleSide> sides = sortedSides(mesh.triangles);
  std::uint64_t edges = 0;
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    ++edges;
    if (last - first > 2) ++quality.nonManifoldEdges;
  });
  DisjointSets fans = cornerFans(mesh.triangles, sides);
  quality.nonManifoldVertices = countNonManifoldVertices(mesh.triangles, fans);
  quality.boundaryLoops = countBoundaryLoops(fans, sides);
  std::uint32_t components = 0;
  componentsOverSides(mesh.triangles.size(), sides, components);
  quality.components = components;
  // Isolated points are not part of the surface, so they do not count in V.
  quality.eulerCharacteristic = static_cast<std::int64_t>(countUsedVertices(mesh)) - static_cast<std::int64_t>(edges) +
                                static_cast<std::int64_t>(mesh.triangles.size());
  quality.area = surfaceArea(mesh);
  quality.diagonal = boundingBox(mesh.points.positions).diagonal();
  return quality;
}

TriangleComponents triangleComponents(const Scan& mesh) {
  TriangleComponents components;
  components.ofTriangle = componentsOverSides(mesh.triangles.size(), sortedSides(mesh.triangles), components.count);
  return components;
}

std::vector<Vec3f> sampleSurface(const Scan& mesh, std::size_t count) {
  const auto& p = mesh.points.positions;
  std::vector<double> cumulativeArea;
  cumulativeArea.reserve(mesh.triangles.size());
  double total = 0.0;
  for (const Triangle& t : mesh.triangles) {
    total += 0.5 * (p[t[1]] - p[t[0]]).cast<double>().cross((p[t[2]] - p[t[0]]).cast<double>()).norm();
    cumulativeArea.push_back(total);
  }
  std::vector<Vec3f> samples;
  if (!(total > 0.0) || count == 0) return samples;
  samples.reserve(count);
  // Triangle i gets round(count * cumulative area up to i) minus what the
  // ones before it got: counts in proportion to area, summing to `count`,
  // and small triangles are not all rounded away to nothing.
  std::mt19937_64 random(0x5eed5eedULL);
  std::size_t given = 0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto due = static_cast<std::size_t>(std::llround(static_cast<double>(count) * cumulativeArea[i] / total));
    const Triangle& t = mesh.triangles[i];
    for (; given < due; ++given) samples.push_back(pointInTriangle(p[t[0]], p[t[1]], p[t[2]], random));
  }
  return samples;
}

}  // namespace apo
