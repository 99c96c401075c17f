// Inside bake: the adaptive octree of paper section 3.1 and the geometry it
// rests on. Everything here works in unit-cube coordinates.
#pragma once

#include "bake/bake.h"

#include <cstdint>
#include <vector>

namespace apo::octree {

// A cell of the octree: the cube of side `width` around `centre`.
struct Cell {
  Vec3f centre = Vec3f::Constant(0.5f);
  float width = 1.0f;
  int depth = 0;

  Vec3f lower() const { return centre - Vec3f::Constant(0.5f * width); }
  Vec3f upper() const { return centre + Vec3f::Constant(0.5f * width); }
  Cell child(int c) const { return {childCentre(centre, width, c), 0.5f * width, depth + 1}; }
};

// Exact triangle / closed box overlap by the separating axis theorem
// (Akenine-Moller 2001): 3 box axes, the triangle normal, 9 edge crossings.
bool triangleOverlapsBox(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell);

// The part of triangle abc inside the cell (Sutherland-Hodgman against the
// six faces): a convex polygon of up to 9 corners, empty when they miss.
std::vector<Vec3f> clipTriangleToCell(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell);
double polygonArea(const std::vector<Vec3f>& polygon);

// M as the L2,1 metric and the overlap tests see it, in unit-cube
// coordinates: triangles (or points when `triangles` is empty), each with its
// unit normal and its weight, its area over M's mean primitive area.
struct DetailPrimitives {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  std::vector<Vec3f> normals;
  std::vector<float> weights;

  std::size_t size() const { return normals.size(); }
};

// m in unit-cube coordinates.
struct CoarseMesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
};

struct BuildSettings {
  int coarseDepth = 5, maxDepth = 13;
  double error = 0.05;
};

// The octree (normals and weights still zero) and, for each node, the
// triangles of m in it (leaves only; internal nodes have empty ranges):
// leafTriangles[leafTriangleBegin[n] .. leafTriangleBegin[n + 1]).
struct BuiltOctree {
  Octree octree;
  std::vector<std::uint64_t> leafTriangleBegin;
  std::vector<std::uint32_t> leafTriangles;
};

// L2,1 of a set of primitives: sum of w_i |n_i - n_mean|^2, n_mean the unit
// weighted mean normal (paper 3.1 with Cohen-Steiner's area weights).
double normalVariation(const DetailPrimitives& detail, const std::vector<std::uint32_t>& primitives);

// Complete to settings.coarseDepth around m, then refined while the L2,1 of
// a leaf exceeds settings.error, down to settings.maxDepth; only children
// that intersect m are kept. Parallel over the coarse cells; the result does
// not depend on the thread count.
BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings);

}  // namespace apo::octree
