// Internal to reconstruct: the doors to CGAL and FLANN, one .cpp each (CGAL's
// headers cost tens of seconds per translation unit on 2 cores). Plain data
// in and out; every CGAL exception is caught here and returned as an Error.
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "reconstruct/reconstruct.h"

#include <cstdint>
#include <vector>

namespace apo::cgal {

// --- cgal_points.cpp: point set processing --------------------------------

// CGAL compute_average_spacing: the sum of the distances to the k nearest
// neighbours over k + 1 (CGAL counts the point itself, at distance 0).
// Poisson's default distance bound (0.375 spacings) is expressed in it.
double averageSpacing(const std::vector<Vec3f>& points, int k);

// CGAL grid_simplify_point_set: keep[i] = 1 for one point per occupied cell
// of side `cellSize`. Deterministic.
std::vector<char> gridSubsampleMask(const std::vector<Vec3f>& points, double cellSize);

// --- cgal_poisson.cpp -----------------------------------------------------

// CGAL poisson_surface_reconstruction_delaunay over points with oriented
// normals; `distanceSpacings` is the surface mesher's distance bound in
// average spacings (CGAL's default 0.375), `radiusSpacings` the bound on the
// mesher's Delaunay-ball radius (CGAL's default 30, far too coarse for a
// detail mesh), `seed` seeds CGAL's default random
// generator so that the output repeats. The mesh is oriented outwards.
Result<Scan> poissonReconstruct(const PointSet& points, double averageSpacing, double distanceSpacings,
                                double radiusSpacings, std::uint32_t seed);

// --- cgal_advancing_front.cpp ----------------------------------------------

// CGAL advancing_front_surface_reconstruction (normals unused). Triangles
// are consistently oriented per component, in an arbitrary direction.
Result<Scan> advancingFrontReconstruct(const std::vector<Vec3f>& points);

// --- cgal_scale_space.cpp --------------------------------------------------

// CGAL Scale_space_surface_reconstruction_3 with a weighted-PCA smoother of
// `scaleSpacings` average spacings (iterations fixed at 4) and the
// advancing-front mesher; vertices are the input points (not smoothed).
Result<Scan> scaleSpaceReconstruct(const std::vector<Vec3f>& points, double averageSpacing, double scaleSpacings);

// --- cgal_simplify.cpp -----------------------------------------------------

// Surface_mesh_simplification edge collapse until at most `targetFaces`
// faces remain, borders constrained. Non-manifold input is repaired first
// (polygon soup orientation splits non-manifold vertices); `repairedVertices`
// counts the vertices added. Small holes (a few spacings wide, see
// kMaxFilledHoleEdges) are triangulated first, counted in `filledHoles`.
// When the borders alone hold more faces than the
// target, a second pass collapses border edges too (Lindstrom-Turk, whose
// boundary term keeps their shape); `bordersCollapsed` says so. Deterministic.
struct EdgeCollapseResult {
  Scan mesh;
  std::uint64_t repairedVertices = 0;
  std::uint64_t filledHoles = 0;
  bool bordersCollapsed = false;
};
// `onCollapsed` hears the fraction of the faces to remove that are gone.
Result<EdgeCollapseResult> edgeCollapse(const Scan& mesh, std::uint64_t targetFaces, SimplifyPolicy policy,
                                        const ProgressCallback& onCollapsed = {});

// --- cgal_measures.cpp -----------------------------------------------------

// Component index of each triangle (triangles sharing an edge are connected).
std::vector<std::uint32_t> triangleComponents(const Scan& mesh, std::uint32_t& componentCount);

// Unsigned distances from each point to the mesh (CGAL AABB tree).
std::vector<float> pointToMeshDistances(const std::vector<Vec3f>& points, const Scan& mesh);

// Deterministic sampling of a mesh's surface: about `count` points spread in
// proportion to area (fixed seed).
std::vector<Vec3f> sampleSurface(const Scan& mesh, std::size_t count);

}  // namespace apo::cgal

namespace apo::flann_adapter {

// --- flann_nearest.cpp -----------------------------------------------------

// Distance from each query to its nearest reference point (exact FLANN k-d
// tree, single tree, OpenMP batch search).
std::vector<float> nearestDistances(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

// Index of each query's nearest reference point.
std::vector<std::uint32_t> nearestIndices(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries);

}  // namespace apo::flann_adapter
