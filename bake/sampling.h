// Inside bake: the normal field sampling of paper section 3.2, on the octree
// built by octree_build.h, through the ray-caster and closest-point seams.
#pragma once

#include "bake/octree_build.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace apo::sampling {

struct SamplingSettings {
  int samples = 4;           // ray origins per (leaf, triangle of m)
  double maxDistance = 0.0;  // world units; a cell's reach is at least its diagonal
  // An internal node shows m's own normal (OctreeNode::coarseNormal) where
  // m's normals are closer to the samples below it than its mean normal is.
  bool internalNodesMayShowCoarse = false;
};

struct SampleCounts {
  std::uint64_t rays = 0, hits = 0, fallbacks = 0;
  std::uint64_t unanswered = 0;  // samples whose closest-point fallback failed (they count for nothing)
};

// The samples below a node, as the choice between its mean normal and m's
// needs them: over samples of weight w, M normal n and m normal r,
// W = sum w, S = sum w n and R = sum w n.r. Against M's unit normals the
// mean S/|S| leaves sum w |n - S/|S||^2 = 2 (W - |S|), m's normals
// sum w |n - r|^2 = 2 (W - R): m is the closer where R > |S|.
// C = sum w r tells whether m itself turns back under the node.
struct SampleMoments {
  double weight = 0.0, alongCoarse = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), coarseSum = Eigen::Vector3d::Zero();

  SampleMoments& operator+=(const SampleMoments& other) {
    weight += other.weight;
    alongCoarse += other.alongCoarse;
    sum += other.sum;
    coarseSum += other.coarseSum;
    return *this;
  }
  bool coarseIsCloser() const { return weight > 0.0 && alongCoarse > sum.norm(); }
  // m's own normals below the node spread so far that their mean is
  // shorter than kBothSidesLength: both sides of a thin part (or a fold)
  // under one node.
  bool coversBothSides() const { return coarseSum.norm() < kBothSidesLength * weight; }
  // M's normals below the node spread so far that their mean is shorter
  // than kTurnLength: M turns under the node (a rounded edge, a crease).
  bool detailTurns() const { return sum.norm() < kTurnLength * weight; }

  // Only there does an internal node show m (where m is also the closer).
  // Its mean is also what the filter blends for a neighbour whose walk
  // stops at it, and where m merely beats the mean (a smooth curve under a
  // coarse node) the mean blends better: the bumpy sphere of the tests lost
  // 20% of its filtered accuracy (0.200 degrees against 0.166) when every
  // node where m was closer showed m, 17% when such neighbours were left
  // out of the blend instead. A cap of a sphere 70 degrees wide still has a
  // mean of length 0.9.
  static constexpr double kBothSidesLength = 0.8;
  // About 11 degrees root mean square from the mean. Measured (docs/bake.md,
  // "Internal nodes"): blade.off rendered mip-mapped 0.402 -> 0.155 degrees
  // (m alone 0.199), the bumpy sphere unchanged (0.1654), bunny00 filtered
  // 0.197 -> 0.196; at 0.8 and 0.9 the blade did not move.
  static constexpr double kTurnLength = 0.98;
};

// m in both frames: unit-cube positions for the cells, world positions and
// unit vertex normals for the rays.
struct CoarseFrames {
  const octree::CoarseMesh* unit = nullptr;
  const std::vector<Vec3f>* worldPositions = nullptr;
  const std::vector<Vec3f>* vertexNormals = nullptr;
};

// Fills every leaf's normal (the area-weighted mean of M's normals hit by
// rays from m's triangles in the cell) and weight (m's area in the cell),
// then every internal node's, bottom-up, as the weighted mean of its
// children (or m's normal, with internalNodesMayShowCoarse). Parallel over leaves; the result does not depend on the thread
// count. `onChunkDone(done, total)`, when given, is called from the worker
// threads as chunks of leaves finish.
SampleCounts sampleNormalField(octree::BuiltOctree& built, const CoarseFrames& coarse, const DetailSurface& detail,
                               const SamplingSettings& settings,
                               const std::function<void(std::size_t, std::size_t)>& onChunkDone = {});

// sampleNormalField in two halves, for a tree sampled part by part (the
// bake in bricks): the given leaves' normals and weights, and their
// samples' moments into `moments` (one per node)...
SampleCounts sampleLeaves(octree::BuiltOctree& built, std::span<const std::uint32_t> leaves, const CoarseFrames& coarse,
                          const DetailSurface& detail, const SamplingSettings& settings,
                          std::vector<SampleMoments>& moments,
                          const std::function<void(std::size_t, std::size_t)>& onChunkDone = {});
// ...then every internal node's from its children's, bottom-up, once all
// the leaves are done.
void averageInternalNodes(Octree& octree, std::vector<SampleMoments>& moments, bool mayShowCoarse);

}  // namespace apo::sampling
