// Helpers of the CGAL adapter tests: realistic scans of shapes with analytic
// surfaces, and topology and orientation figures computed here from scratch
// (not by the code under test).
#pragma once

#include "core/geometry.h"
#include "ingest/ingest.h"
#include "pipeline/pipeline.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <utility>
#include <vector>

namespace apo::test {

constexpr float kTorusMajor = 1.0f, kTorusMinor = 0.35f;

inline Scan sphereTruth() { return makeIcosphere(5); }  // faceting error about 0.01%
inline Scan torusTruth() { return makeTorus(kTorusMajor, kTorusMinor, 160, 64); }

inline float distanceToUnitSphere(const Vec3f& p) { return std::abs(p.norm() - 1.0f); }
inline float distanceToTestTorus(const Vec3f& p) { return distanceToTorus(p, kTorusMajor, kTorusMinor); }

// Unit outward normal of the analytic surfaces at (near) p.
inline Vec3f sphereOutward(const Vec3f& p) { return p.normalized(); }
inline Vec3f torusOutward(const Vec3f& p) {
  return (p - kTorusMajor * Vec3f(p.x(), p.y(), 0.0f).normalized()).normalized();
}

// A noisy, slightly misregistered scan with the true surface normals, about
// views x raysPerSide^2 x (fraction of rays that hit) points.
inline PointSet scannedPoints(const Scan& mesh, int views, int raysPerSide) {
  SimulateScanOptions scanner;
  scanner.views = views;
  scanner.raysPerSide = raysPerSide;
  scanner.rangeNoise = 0.0005;
  scanner.misregistration = 0.0001;
  scanner.withNormals = true;
  auto simulated = simulateRangeScan(mesh, test::checked(scanner));
  EXPECT_TRUE(simulated.ok()) << simulated.error().message;
  return simulated.ok() ? simulated->scan.points : PointSet{};
}

struct Topology {
  std::uint64_t vertices = 0;  // referenced by a triangle
  std::uint64_t edges = 0, triangles = 0;
  std::uint64_t boundaryEdges = 0;     // in one triangle
  std::uint64_t nonManifoldEdges = 0;  // in more than two
  std::uint64_t components = 0;        // of triangles sharing edges
  std::uint64_t inconsistentEdges = 0; // run the same way by both triangles
  std::int64_t euler() const {
    return static_cast<std::int64_t>(vertices) - static_cast<std::int64_t>(edges) + static_cast<std::int64_t>(triangles);
  }
};

// Component of each triangle (edge-connected), numbered from 0.
inline std::vector<std::uint32_t> triangleComponentsOf(const Scan& mesh, std::uint32_t& count) {
  std::vector<std::uint32_t> parent(mesh.triangles.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> firstOfEdge;
  for (std::uint32_t i = 0; i < mesh.triangles.size(); ++i)
    for (int j = 0; j < 3; ++j) {
      const auto edge = std::minmax(mesh.triangles[i][j], mesh.triangles[i][(j + 1) % 3]);
      const auto [it, inserted] = firstOfEdge.try_emplace(edge, i);
      if (!inserted) parent[find(i)] = find(it->second);
    }
  std::map<std::uint32_t, std::uint32_t> number;
  std::vector<std::uint32_t> component(mesh.triangles.size());
  for (std::uint32_t i = 0; i < mesh.triangles.size(); ++i)
    component[i] = number.try_emplace(find(i), static_cast<std::uint32_t>(number.size())).first->second;
  count = static_cast<std::uint32_t>(number.size());
  return component;
}

inline Topology topologyOf(const Scan& mesh) {
  Topology topology;
  topology.triangles = mesh.triangles.size();
  std::vector<char> used(mesh.points.size(), 0);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<int, int>> edgeUses;  // (forward, backward)
  for (const Triangle& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) {
      used[t[j]] = 1;
      const std::uint32_t a = t[j], b = t[(j + 1) % 3];
      auto& uses = edgeUses[std::minmax(a, b)];
      (a < b ? uses.first : uses.second) += 1;
    }
  topology.vertices = static_cast<std::uint64_t>(std::count(used.begin(), used.end(), 1));
  topology.edges = edgeUses.size();
  for (const auto& [edge, uses] : edgeUses) {
    const int count = uses.first + uses.second;
    topology.boundaryEdges += count == 1 ? 1 : 0;
    topology.nonManifoldEdges += count > 2 ? 1 : 0;
    topology.inconsistentEdges += count == 2 && uses.first != 1 ? 1 : 0;
  }
  std::uint32_t components = 0;
  triangleComponentsOf(mesh, components);
  topology.components = components;
  return topology;
}

// The component with the most triangles (same vertex array).
inline Scan largestComponent(const Scan& mesh) {
  std::uint32_t count = 0;
  const auto component = triangleComponentsOf(mesh, count);
  std::vector<std::size_t> size(count, 0);
  for (std::uint32_t c : component) ++size[c];
  const auto largest = static_cast<std::uint32_t>(std::max_element(size.begin(), size.end()) - size.begin());
  Scan kept;
  kept.points = mesh.points;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (component[i] == largest) kept.triangles.push_back(mesh.triangles[i]);
  return kept;
}

// Mean distance of the vertices used by triangles to an analytic surface.
inline double meanVertexDistance(const Scan& mesh, const std::function<float(const Vec3f&)>& distance) {
  std::vector<char> used(mesh.points.size(), 0);
  for (const Triangle& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < used.size(); ++i)
    if (used[i]) {
      sum += distance(mesh.points.positions[i]);
      ++count;
    }
  return count > 0 ? sum / static_cast<double>(count) : 0.0;
}

// Share of the area whose triangle normals point along the analytic outward
// normal (1: all outwards, 0: all inwards).
inline double outwardAreaFraction(const Scan& mesh, const std::function<Vec3f(const Vec3f&)>& outward) {
  const auto& p = mesh.points.positions;
  double outwardArea = 0.0, total = 0.0;
  for (const Triangle& t : mesh.triangles) {
    const Vec3f areaNormal = 0.5f * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    const float area = areaNormal.norm();
    total += area;
    if (areaNormal.dot(outward((p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f)) > 0.0f) outwardArea += area;
  }
  return total > 0.0 ? outwardArea / total : 0.0;
}

// Triangles of `a` that `b` lacks, ignoring orientation.
inline std::size_t trianglesMissingFrom(const Scan& a, const Scan& b) {
  const auto unoriented = [](Triangle t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  std::set<Triangle> inB;
  for (const Triangle& t : b.triangles) inB.insert(unoriented(t));
  std::size_t missing = 0;
  for (const Triangle& t : a.triangles) missing += inB.count(unoriented(t)) == 0 ? 1 : 0;
  return missing;
}

// An analytic shape, scanned by the virtual scanner for the method tests.
struct ScannedShape {
  const char* name;
  Scan (*truth)();
  float (*distance)(const Vec3f&);
  Vec3f (*outward)(const Vec3f&);
  int raysPerSide;  // per view, 10 views
  std::int64_t euler;
};

inline ScannedShape scannedSphere(int raysPerSide) {
  return {"sphere", sphereTruth, distanceToUnitSphere, sphereOutward, raysPerSide, 2};
}
inline ScannedShape scannedTorus(int raysPerSide) {
  return {"torus", torusTruth, distanceToTestTorus, torusOutward, raysPerSide, 0};
}

// What the advancing-front meshers (advancing front, scale space) must give
// on a scan of `shape`: a main component carrying nearly every triangle and
// point, within 0.5% of the diagonal of the analytic surface, manifold,
// closed but for a few small holes (then the shape's Euler characteristic),
// and consistently oriented in one direction or the other.
inline void expectAccurateManifoldMesh(const Scan& mesh, const PointSet& points, const ScannedShape& shape) {
  const Scan main = largestComponent(mesh);
  const Topology all = topologyOf(mesh), topology = topologyOf(main);
  EXPECT_GT(static_cast<double>(topology.triangles), 0.99 * static_cast<double>(all.triangles));
  EXPECT_GT(static_cast<double>(topology.vertices), 0.99 * static_cast<double>(points.size()));

  const double diagonal = boundingBox(shape.truth().points.positions).diagonal();
  EXPECT_LT(meanVertexDistance(main, shape.distance) / diagonal, 0.005);
  EXPECT_EQ(topology.nonManifoldEdges, 0u);
  EXPECT_EQ(topology.inconsistentEdges, 0u);
  // Each small hole CGAL may leave raises V - E + F by one.
  EXPECT_LE(topology.boundaryEdges, 0.002 * static_cast<double>(topology.edges));
  if (topology.boundaryEdges == 0) {
    EXPECT_EQ(topology.euler(), shape.euler);
  }
  const double outward = outwardAreaFraction(main, shape.outward);
  EXPECT_TRUE(outward > 0.999 || outward < 0.001) << outward;
}

}  // namespace apo::test
