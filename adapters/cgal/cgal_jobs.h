// The CGAL adapter (target apo_cgal): the jobs that ingest and reconstruct
// hand to CGAL, one .cpp each because CGAL's headers cost tens of seconds and
// up to 2.5 GB per translation unit on 2 cores. Plain data in and out, no
// CGAL type in this header; every CGAL exception is caught here and returned
// as an Error.
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "core/timing.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace apo::cgal_adapter {

// --- cgal_orientation.cpp: normal orientation ------------------------------

// CGAL::mst_orient_normals over a k-nearest-neighbour Riemannian graph:
// flips normals so that neighbours agree, seeded at the highest point (whose
// normal is turned to +z). Points outside the seed's connected component are
// left as they were; returns their indices, ascending. Internal error if
// CGAL fails (normals then as they were).
Result<std::vector<std::uint32_t>> orientNormalsMst(const std::vector<Vec3f>& positions, std::vector<Vec3f>& normals,
                                                    int k);

// --- cgal_points.cpp: point set processing --------------------------------

// CGAL compute_average_spacing: the sum of the distances to the k nearest
// neighbours over k + 1 (CGAL counts the point itself, at distance 0).
// Poisson's default distance bound (0.375 spacings) is expressed in it.
Result<double> averageSpacing(const std::vector<Vec3f>& points, int k);

// CGAL grid_simplify_point_set: keep[i] = 1 for one point per occupied cell
// of side `cellSize`. Deterministic.
Result<std::vector<char>> gridSubsampleMask(const std::vector<Vec3f>& points, double cellSize);

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
// Garland-Heckbert plane quadrics (the paper's) or Lindstrom-Turk.
enum class CollapseCost { GarlandHeckbert, LindstromTurk };
// `onCollapsed` hears the fraction of the faces to remove that are gone.
// `inheritedQuadrics` (Garland-Heckbert only; empty, or one per vertex of
// `mesh`): plane quadrics (4 x 4, CGAL's convention: unit-normal planes, each
// face's added to its three corners) of the surface an earlier pass took out
// around each vertex, in place of the planes of the vertex's own faces.
Result<EdgeCollapseResult> edgeCollapse(const Scan& mesh, std::uint64_t targetFaces, CollapseCost cost,
                                        const ProgressCallback& onCollapsed = {},
                                        const std::vector<Eigen::Matrix4d>& inheritedQuadrics = {});

// --- cgal_distances.cpp -----------------------------------------------------

// Unsigned distances from points to one triangle mesh (CGAL AABB tree),
// the tree built once by `make` (for about `queries` points at a time), so
// that it can be built on one core while another works; +infinity for every
// point when the mesh has no triangle. Queries run on every core.
class MeshDistance {
 public:
  static Result<MeshDistance> make(const Scan& mesh, std::size_t queries);
  Result<std::vector<float>> operator()(const std::vector<Vec3f>& points) const;

  MeshDistance(MeshDistance&&) noexcept;
  MeshDistance& operator=(MeshDistance&&) noexcept;
  ~MeshDistance();

 private:
  struct Tree;
  explicit MeshDistance(std::unique_ptr<Tree> tree);
  std::unique_ptr<Tree> tree_;
};

// The same, the tree made for these points.
Result<std::vector<float>> pointToMeshDistances(const std::vector<Vec3f>& points, const Scan& mesh);

}  // namespace apo::cgal_adapter
