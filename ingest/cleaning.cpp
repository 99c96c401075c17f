#include "ingest/cleaning.h"

#include "core/mesh_edit.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace apo::cleaning {

std::size_t dropNonFinitePoints(Scan& scan) {
  std::vector<char> keep(scan.points.size());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = scan.points.positions[i].allFinite();
  return keepPoints(scan, keep);
}

std::size_t mergeDuplicatePoints(Scan& scan) {
  const auto& positions = scan.points.positions;
  // Sort indices by position (then index, so the earliest point of a run of
  // equal positions comes first and the result does not depend on the sort).
  std::vector<std::uint32_t> order(positions.size());
  std::iota(order.begin(), order.end(), 0u);
  auto lessPosition = [&](std::uint32_t a, std::uint32_t b) {
    const Vec3f& p = positions[a];
    const Vec3f& q = positions[b];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    if (p.z() != q.z()) return p.z() < q.z();
    return a < b;
  };
  std::sort(order.begin(), order.end(), lessPosition);

  std::vector<std::uint32_t> representative(positions.size());
  std::vector<char> keep(positions.size(), 1);
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i + 1;
    while (j < order.size() && positions[order[j]] == positions[order[i]]) ++j;
    for (std::size_t r = i; r < j; ++r) {
      representative[order[r]] = order[i];
      if (r > i) keep[order[r]] = 0;
    }
    i = j;
  }
  for (Triangle& t : scan.triangles)
    for (auto& v : t) v = representative[v];
  return keepPoints(scan, keep);
}

std::size_t dropDuplicateTriangles(Scan& scan) {
  auto& triangles = scan.triangles;
  // Each triangle's corners sorted, then its index, in one record: the sort
  // reads contiguous records, where sorting indices through a comparator
  // fetched and sorted two random triangles per comparison (0.9 s for 1.2M
  // triangles, now 0.15-0.19; docs/benchmarks.md).
  struct Keyed {
    Triangle corners;
    std::uint32_t index;
    auto operator<=>(const Keyed&) const = default;  // corners, then index
  };
  std::vector<Keyed> keyed(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    keyed[i] = {triangles[i], static_cast<std::uint32_t>(i)};
    std::sort(keyed[i].corners.begin(), keyed[i].corners.end());
  }
  std::sort(keyed.begin(), keyed.end());
  // The first of each set of equal triangles, in the input's order, is kept.
  std::vector<char> keep(triangles.size(), 1);
  for (std::size_t i = 1; i < keyed.size(); ++i)
    if (keyed[i].corners == keyed[i - 1].corners) keep[keyed[i].index] = 0;
  const std::size_t before = triangles.size();
  std::size_t out = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (keep[i]) triangles[out++] = triangles[i];
  triangles.resize(out);
  return before - out;
}

std::size_t normaliseNormals(PointSet& points) {
  std::size_t invalid = 0;
  for (Vec3f& n : points.normals) {
    const float length = n.norm();
    if (!std::isfinite(length) || length == 0.0f) {
      ++invalid;
      continue;
    }
    n /= length;
  }
  return invalid;
}

}  // namespace apo::cleaning

namespace apo::cleaning {

std::vector<char> voxelRepresentativeMask(const std::vector<Vec3f>& positions, double voxelSize) {
  const Aabb box = boundingBox(positions);
  using VoxelKey = std::array<std::int64_t, 3>;
  auto voxelOf = [&](const Vec3f& p) {
    const Eigen::Vector3d cell = ((p - box.min).cast<double>() / voxelSize).array().floor();
    return VoxelKey{static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
                    static_cast<std::int64_t>(cell.z())};
  };
  std::vector<VoxelKey> keys(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) keys[i] = voxelOf(positions[i]);
  std::vector<std::uint32_t> order(positions.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return keys[a] != keys[b] ? keys[a] < keys[b] : a < b;
  });

  std::vector<char> keep(positions.size(), 0);
  for (std::size_t begin = 0; begin < order.size();) {
    std::size_t end = begin + 1;
    while (end < order.size() && keys[order[end]] == keys[order[begin]]) ++end;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (std::size_t r = begin; r < end; ++r) centroid += positions[order[r]].cast<double>();
    centroid /= static_cast<double>(end - begin);
    std::uint32_t closest = order[begin];
    double closestDistance = (positions[closest].cast<double>() - centroid).squaredNorm();
    for (std::size_t r = begin + 1; r < end; ++r) {
      const double distance = (positions[order[r]].cast<double>() - centroid).squaredNorm();
      if (distance < closestDistance) {
        closest = order[r];
        closestDistance = distance;
      }
    }
    keep[closest] = 1;
    begin = end;
  }
  return keep;
}

}  // namespace apo::cleaning
