// The bake with its production seams (target apo_bake_seams): Embree for the
// rays on M and on m, FLANN for M's closest point. Apart from the rest of
// pipeline/ so that whatever needs a real bake (the render and bake tests,
// the benchmarks) links Embree and FLANN but not CGAL or PCL.
#pragma once

#include "bake/bake.h"
#include "core/closest_point.h"

#include <filesystem>
#include <functional>
#include <memory>

namespace apo {

// bakeWith over seams built for `detail` and `coarse`: an Embree triangle BVH
// of M (a mesh, given its area-weighted vertex normals when it has none) or
// Embree discs of its points' spacing (points, which need normals: BadInput
// otherwise), a FLANN closest-point search built on the first miss, and an
// Embree BVH of m. Fails as bakeWith does.
Result<Bake> bakeApo(const Scan& detail, const Scan& coarse, const Checked<BakeOptions>& options,
                     const ProgressCallback& onProgress = {});

// M's points, `count` of them, given a box at a time by `pointsIn`, with the
// production seams of the bake in bricks: FLANN for their areas and closest
// point, Embree for their discs.
BrickedPoints brickedPoints(std::uint64_t count, std::function<Result<PointSet>(const Aabb& box)> pointsIn);
// A journal of the bake in bricks kept as files in `folder`, one per entry
// (written to a temporary name and renamed, so a killed bake leaves whole
// entries only): what a bake run again resumes from.
BrickJournal brickJournalIn(const std::filesystem::path& folder);
// M's points held in memory (they need normals), served a box at a time
// by brickedPoints's seams: the bake in bricks of a scan that fits.
BrickedPoints pointsInMemory(const Scan& M);
// bakeInBricks over those seams and an Embree BVH of m (options.brickDepth > 0).
Result<Bake> bakeApoInBricks(const BrickedPoints& detail, const Scan& coarse, const Checked<BakeOptions>& options,
                             const ProgressCallback& onProgress = {});

// m's own interpolated normal (its file's vertex normals, else area-weighted
// ones, as the bake and the renderer take them) at the closest point of m to
// each point: what a leaf of a version 3 APO that shows m's normal answers
// there (`apo lookup --coarse`). The exact closest point (Embree).
Result<std::vector<Vec3f>> coarseNormalsAt(const Scan& coarse, const std::vector<Vec3f>& points);

// A mesh's exact closest point (Embree's point query) with its interpolated
// vertex normal there (the file's normals, else area-weighted ones): M as a
// normal field for `apo export --source detail`, the truth of
// ../shared/tools/normal_eval.py. BadInput when `mesh` has no triangles. The
// finder keeps the mesh: pass it by std::move when done with it.
Result<std::unique_ptr<ClosestPointFinder>> meshClosestPoint(Scan mesh);

}  // namespace apo
