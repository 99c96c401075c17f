// Octrees built by hand for the encoding and .apo file tests, and a
// structural comparison that names the first difference.
#pragma once

#include "format/format.h"

#include <functional>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace apo::test {

using ChildPath = std::vector<int>;  // child indices from the root

inline Vec3f randomUnitVector(std::mt19937_64& random) {
  std::uniform_real_distribution<float> zDist(-1.0f, 1.0f), phiDist(0.0f, 2.0f * std::numbers::pi_v<float>);
  const float z = zDist(random), phi = phiDist(random), r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return Vec3f(r * std::cos(phi), r * std::sin(phi), z).normalized();
}

// The octree whose nodes are `paths` and all their prefixes (the root is the
// empty path). Node normals come from `normalOf(path)`. Nodes are stored
// depth-first (each brood contiguous, subtrees one after the other), unlike
// the breadth-first order of the encoding, so tests do not depend on it.
inline Octree octreeFromPaths(const std::vector<ChildPath>& paths,
                              const std::function<Vec3f(const ChildPath&)>& normalOf) {
  std::set<ChildPath> all{{}};
  for (const ChildPath& path : paths)
    for (std::size_t length = 1; length <= path.size(); ++length)
      all.insert(ChildPath(path.begin(), path.begin() + static_cast<std::ptrdiff_t>(length)));
  Octree octree;
  octree.nodes.push_back({});
  octree.nodes[0].normal = normalOf({});
  std::function<void(std::uint32_t, const ChildPath&)> fill = [&](std::uint32_t index, const ChildPath& path) {
    std::vector<ChildPath> children;
    for (int child = 0; child < 8; ++child) {
      ChildPath childPath = path;
      childPath.push_back(child);
      if (all.count(childPath)) children.push_back(childPath);
    }
    if (children.empty()) return;
    const auto first = static_cast<std::uint32_t>(octree.nodes.size());
    octree.nodes[index].firstChild = first;
    for (const ChildPath& childPath : children) {
      octree.nodes[index].childMask |= static_cast<std::uint8_t>(1u << childPath.back());
      OctreeNode node;
      node.normal = normalOf(childPath);
      node.depth = static_cast<std::uint8_t>(childPath.size());
      node.weight = 1.0;
      octree.nodes.push_back(node);
    }
    for (std::size_t i = 0; i < children.size(); ++i) fill(first + static_cast<std::uint32_t>(i), children[i]);
  };
  fill(0, {});
  return octree;
}

// A random octree stored breadth-first: every node above `internalAbove` is
// internal; below, a node is internal with probability `internalChance`
// until `maxDepth`. Child masks are uniform over the non-empty ones, normals
// uniform on the sphere.
inline Octree randomOctree(std::uint64_t seed, int internalAbove, int maxDepth, double internalChance) {
  std::mt19937_64 random(seed);
  std::uniform_int_distribution<int> maskDist(1, 255);
  std::bernoulli_distribution internal(internalChance);
  Octree octree;
  octree.nodes.push_back({});
  octree.nodes[0].normal = randomUnitVector(random);
  for (std::size_t k = 0; k < octree.nodes.size(); ++k) {
    const int depth = octree.nodes[k].depth;
    if (depth >= maxDepth || (depth >= internalAbove && !internal(random))) continue;
    const auto mask = static_cast<std::uint8_t>(maskDist(random));
    octree.nodes[k].childMask = mask;
    octree.nodes[k].firstChild = static_cast<std::uint32_t>(octree.nodes.size());
    for (int child = 0; child < 8; ++child) {
      if (!((mask >> child) & 1)) continue;
      OctreeNode node;
      node.normal = randomUnitVector(random);
      node.depth = static_cast<std::uint8_t>(depth + 1);
      node.weight = 1.0;
      octree.nodes.push_back(node);
    }
  }
  return octree;
}

// What decodeApo must give back for `octree`: normals quantised by the
// encoding, zero above the grid (not stored), weights zero (not stored).
inline Octree expectedDecoding(const Octree& octree, NormalEncoding encoding, int completeDepth) {
  Octree expected = octree;
  for (OctreeNode& node : expected.nodes) {
    node.normal =
        node.depth < completeDepth ? Vec3f::Zero() : decodeNormal(encodeNormal(node.normal, encoding), encoding);
    node.weight = 0.0;
  }
  return expected;
}

// The first difference between two octrees compared node by node from the
// root, by child index (so their storage orders may differ); empty if none.
inline std::string firstDifference(const Octree& a, const Octree& b, std::uint32_t ia = 0, std::uint32_t ib = 0,
                                   const std::string& path = "root") {
  const OctreeNode& na = a.nodes.at(ia);
  const OctreeNode& nb = b.nodes.at(ib);
  if (na.childMask != nb.childMask || na.depth != nb.depth || na.normal != nb.normal || na.weight != nb.weight)
    return path + ": mask/depth/normal/weight differ";
  std::uint32_t ca = na.firstChild, cb = nb.firstChild;
  for (int child = 0; child < 8; ++child) {
    if (!((na.childMask >> child) & 1)) continue;
    const std::string difference = firstDifference(a, b, ca++, cb++, path + "/" + std::to_string(child));
    if (!difference.empty()) return difference;
  }
  return "";
}

// Points that stress the walks: uniform, on dyadic planes (cell boundaries
// of every depth), at the cube's faces and corners, and outside it.
inline std::vector<Vec3f> lookupPoints(std::size_t count, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), wide(-0.2f, 1.2f);
  std::uniform_int_distribution<int> kindDist(0, 3), depthDist(0, 9);
  auto dyadic = [&] {
    const int depth = depthDist(random);
    return static_cast<float>(std::uniform_int_distribution<int>(0, 1 << depth)(random)) /
           static_cast<float>(1 << depth);
  };
  std::vector<Vec3f> points = {{0, 0, 0}, {1, 1, 1}, {0, 1, 0.5f}, {0.5f, 0.5f, 0.5f}, {-0.0f, 1, 1}};
  while (points.size() < count) {
    Vec3f p;
    for (int axis = 0; axis < 3; ++axis) {
      switch (kindDist(random)) {
        case 0: p[axis] = unit(random); break;
        case 1:
        case 2: p[axis] = dyadic(); break;
        default: p[axis] = wide(random); break;
      }
    }
    points.push_back(p);
  }
  return points;
}

}  // namespace apo::test
