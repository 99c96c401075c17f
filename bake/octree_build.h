// Inside bake: the adaptive octree of paper section 3.1, its shared types and
// buildOctree. The build is three units, each with its header:
// cell_clip.h (M's and m's triangles against cells), l21_metric.h (the L2,1
// metric's sums and leaf errors) and refinement.h (the global refinement
// under a texel budget); octree_build.cpp wires them. Everything here works
// in unit-cube coordinates.
#pragma once

#include "bake/bake.h"

#include <array>
#include <cstdint>
#include <string>
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

// A triangle of M as the L2,1 metric reads it, in one record: the build
// reads every triangle once per level it descends, and corners, normals and
// m's normals gathered from four arrays cost a cache miss each.
struct DetailTriangle {
  // Left unset (not `= default`, which would zero it): ofMesh writes every
  // record on all cores, and so faults the memory in on all cores, where
  // the vector's zeroing took one (130 MB for the 1.2M-triangle bunny).
  DetailTriangle() {}  // NOLINT(modernize-use-equals-default)
  std::array<Vec3f, 3> corners;        // unit-cube coordinates, moved onto m
  std::array<Vec3f, 3> normals;        // M's normals at the corners
  std::array<Vec3f, 3> coarseNormals;  // m's normals where the corners project (DetailPrimitives::coarseKnown)
};

// M as the L2,1 metric sees it, in unit-cube coordinates and moved onto m.
// Triangles carry the interpolated normal field of M; the metric integrates
// over the part of each triangle inside a cell, in units of M's mean
// triangle area (`areaScale` = 1 / that area). Points carry one normal and a
// weight each (their area over the mean area) and sit where they project
// onto m. With `coarseKnown`, each also carries m's interpolated normal
// where it projects onto m along its normal (zero where that line misses
// m): the metric integrates M's field against m's over each piece (both
// linear on a triangle), so a cell knows how far m alone is.
struct DetailPrimitives {
  std::vector<DetailTriangle> triangles;
  double areaScale = 1.0;      // triangles
  std::vector<Vec3f> positions;  // points
  std::vector<Vec3f> normals;    // per point
  std::vector<float> weights;    // per point
  std::vector<Vec3f> coarseNormals;  // per point
  bool coarseKnown = false;

  // M as a mesh: per position its normal and (when not empty) m's; per
  // triangle (when not empty) the shift that moves it onto m.
  static DetailPrimitives ofMesh(const std::vector<Vec3f>& positions, const std::vector<Triangle>& triangles,
                                 const std::vector<Vec3f>& cornerNormals, double areaScale,
                                 const std::vector<Vec3f>& shifts = {}, const std::vector<Vec3f>& coarseNormals = {});

  std::size_t size() const { return triangles.empty() ? positions.size() : triangles.size(); }
};

// m in unit-cube coordinates.
struct CoarseMesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
};

// How the refinement stops (docs/bake.md, "Refinement"): a leaf splits next
// when its split lowers the total L2,1 most per texel added, until the texels reach `budgetTexels`
// or no split helps (every leaf within kNegligibleDegrees of M or at the
// maximum depth). With `error`, a leaf whose L2,1 is at most that never
// splits (the paper's rule; with no budget, its tree exactly).
struct BuildSettings {
  int coarseDepth = 5, maxDepth = 13;
  double error = 0.0;                // > 0: the paper's threshold, a leaf whose L2,1 is at most this stays a leaf
  std::uint64_t budgetTexels = 0;    // > 0: the texels the encoded texture may use (grid included)
  int completeDepth = 5;             // the encoding's completion depth: nodes above it take no texel
  // Leaves where m's own normals are closer to M than the leaf's one normal
  // show m's (OctreeNode::coarseNormal), and their error is m's.
  bool deferToCoarse = false;
  // Leaves below the completion depth may show one normal per side of m
  // (OctreeNode::twoSided) where that leaves far less error; needs m's
  // normals (DetailPrimitives::coarseKnown).
  bool twoSidedLeaves = false;
  // M's triangles are clipped once into the cells of this depth, whose sums
  // the cells above add up (clipped level by level below it); -1: the
  // deepest level whose cells are twice as wide as M's triangles
  // (sumDepthFor); at most coarseDepth: level by level from the coarse depth.
  int sumDepth = -1;
};

// A leaf whose normals deviate from their mean by less than this (root mean
// square) is as good as M for any renderer: oct24 stores a normal within
// 0.04 degrees, and a split would spend texels on nothing visible.
inline constexpr double kNegligibleDegrees = 0.1;

// What stopped the refinement and where it left the error.
struct RefinementOutcome {
  std::string stoppedBy;             // "budget", "error" (the threshold), "converged" (no split helps)
  std::uint64_t texels = 0;          // the texture's used texels, grid included
  double error = 0.0;                // sum over leaves of their L2,1 (units of M's mean area)
  double area = 0.0;                 // M's area in the leaves, same units
  std::uint64_t leavesShowingCoarse = 0;  // leaves that show m's own normal (deferToCoarse)
  std::uint64_t twoSidedLeaves = 0;       // leaves that show one normal per side of m
  std::uint64_t leavesAtMaxDepth = 0;
  int sumDepth = 0;                       // where M's triangles were summed (sumDepthFor), 0: level by level
  // Root mean square deviation of M's normals from their leaf's mean, in degrees.
  double rmsDegrees() const;
};

// The octree (normals and weights still zero) and, for each node, the
// triangles of m in it (leaves only; internal nodes have empty ranges):
// leafTriangles[leafTriangleBegin[n] .. leafTriangleBegin[n + 1]).
struct BuiltOctree {
  Octree octree;
  std::vector<std::uint64_t> leafTriangleBegin;
  std::vector<std::uint32_t> leafTriangles;
  RefinementOutcome refinement;
};

// What a build records of the metric's errors or reads back instead
// (l21_metric.h).
struct ErrorExchange;

// Complete to settings.coarseDepth around m, then refined globally as
// BuildSettings says, down to settings.maxDepth; only children that
// intersect m are kept. Splits are chosen in rounds and evaluated in
// parallel; the result does not depend on the thread count. When the coarse
// levels alone exceed the budget, the tree stops there with
// refinement.texels above settings.budgetTexels.
BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings);
BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings,
                        const ErrorExchange& exchange);

}  // namespace apo::octree
