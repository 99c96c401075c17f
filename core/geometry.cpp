#include "core/geometry.h"

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

double surfaceArea(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  double area = 0.0;
  for (const Triangle& t : mesh.triangles)
    area += 0.5 * (p[t[1]] - p[t[0]]).cast<double>().cross((p[t[2]] - p[t[0]]).cast<double>()).norm();
  return area;
}

}  // namespace apo
