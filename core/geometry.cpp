#include "core/geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

namespace apo {

Aabb boundingBox(const std::vector<Vec3f>& positions) {
  Aabb box;
  for (const Vec3f& p : positions) box.extend(p);
  return box;
}

std::vector<Vec3f> areaWeightedVertexNormals(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  std::vector<Vec3f> normals(p.size(), Vec3f::Zero());
  for (const Triangle& t : mesh.triangles) {
    // The cross product's length is twice the area: area weighting for free.
    const Vec3f areaNormal = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    for (auto v : t) normals[v] += areaNormal;
  }
  for (Vec3f& n : normals) {
    const float length = n.norm();
    n = length > 0.0f ? Vec3f(n / length) : Vec3f::UnitZ();
  }
  return normals;
}

void addVertexNormalsIfMissing(Scan& mesh) {
  if (mesh.isMesh() && mesh.points.normals.size() != mesh.points.size())
    mesh.points.normals = areaWeightedVertexNormals(mesh);
}

std::vector<Vec3f> vertexNormalsAsDrawn(const Scan& mesh) {
  return mesh.points.normals.size() == mesh.points.size() ? mesh.points.normals : areaWeightedVertexNormals(mesh);
}

double surfaceArea(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  double area = 0.0;
  for (const Triangle& t : mesh.triangles)
    area += 0.5 * (p[t[1]] - p[t[0]]).cast<double>().cross((p[t[2]] - p[t[0]]).cast<double>()).norm();
  return area;
}

namespace {

Vec3f centreOf(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
}

}  // namespace

double faceOrderSpread(const Scan& mesh) {
  constexpr std::size_t kMostPairs = 4096;
  const std::size_t pairs = mesh.triangles.size() < 2 ? 0 : std::min(kMostPairs, mesh.triangles.size() - 1);
  if (pairs == 0) return 0.0;
  const auto& p = mesh.points.positions;
  std::vector<double> steps;
  double edges = 0.0;
  for (std::size_t k = 0; k < pairs; ++k) {
    const std::size_t i = k * (mesh.triangles.size() - 1) / pairs;
    const Triangle& t = mesh.triangles[i];
    steps.push_back((centreOf(mesh, mesh.triangles[i + 1]) - centreOf(mesh, t)).cast<double>().norm());
    for (int c = 0; c < 3; ++c) edges += (p[t[(c + 1) % 3]] - p[t[c]]).cast<double>().norm();
  }
  const double meanEdge = edges / static_cast<double>(3 * pairs);
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(pairs / 2), steps.end());
  const double median = steps[pairs / 2];
  return meanEdge > 0.0 && std::isfinite(median) ? median / meanEdge : 0.0;
}

std::vector<Triangle> trianglesInMortonOrder(const Scan& mesh) {
  const Aabb box = boundingBox(mesh.points.positions);
  const Vec3f extent = box.extent();
  // A centre's cell on one axis of a 1024-cell grid over the box (NaN and
  // a flat axis go to cell 0).
  const auto cellOn = [&](const Vec3f& centre, int axis) {
    const float at = extent[axis] > 0.0f ? (centre[axis] - box.min[axis]) / extent[axis] * 1024.0f : 0.0f;
    return at > 0.0f ? static_cast<std::uint32_t>(std::min(at, 1023.0f)) : 0u;
  };
  // (code, position in the list): sorted, ties keep the list's order.
  std::vector<std::uint64_t> keyed(mesh.triangles.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) {
    const Vec3f centre = centreOf(mesh, mesh.triangles[i]);
    keyed[i] = mortonCode(cellOn(centre, 0), cellOn(centre, 1), cellOn(centre, 2)) << 32 | i;
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<Triangle> sorted;
  sorted.reserve(keyed.size());
  for (const std::uint64_t k : keyed) sorted.push_back(mesh.triangles[k & 0xFFFFFFFFu]);
  return sorted;
}

MeshPieces meshPieces(const Scan& mesh) {
  std::vector<std::uint32_t> parent(mesh.points.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const Triangle& t : mesh.triangles)
    for (int corner = 1; corner < 3; ++corner) {
      const std::uint32_t a = root(t[0]), b = root(t[corner]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  MeshPieces pieces;
  std::vector<std::uint32_t> label(mesh.points.size(), MeshPieces::kNoPiece);
  pieces.ofTriangle.resize(mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    std::uint32_t& id = label[root(mesh.triangles[i][0])];
    if (id == MeshPieces::kNoPiece) id = pieces.count++;
    pieces.ofTriangle[i] = id;
  }
  pieces.ofVertex.assign(mesh.points.size(), MeshPieces::kNoPiece);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (std::uint32_t v : mesh.triangles[i]) pieces.ofVertex[v] = pieces.ofTriangle[i];
  return pieces;
}

std::vector<Vec3f> fibonacciDirections(int count) {
  std::vector<Vec3f> directions;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double radius = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double angle = golden * i;
    directions.emplace_back(static_cast<float>(radius * std::cos(angle)), static_cast<float>(radius * std::sin(angle)),
                            static_cast<float>(z));
  }
  return directions;
}

}  // namespace apo
