// Inside bake: the normal field sampling of paper section 3.2, on the octree
// built by octree_build.h, through the ray-caster and closest-point seams.
#pragma once

#include "bake/octree_build.h"

#include <cstdint>

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

}  // namespace apo::sampling
