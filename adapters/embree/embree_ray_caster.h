// The Embree adapter (target apo_embree): Embree 3 BVHs behind core's
// RayCaster seam (core/ray_caster.h), for triangle meshes and for oriented
// discs around points. Every Embree error, reported through its device
// callback or by a failed allocation, comes back as an Internal error.
#pragma once

#include "core/closest_point.h"
#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"

#include <memory>
#include <vector>

namespace apo {

// Embree BVH over a triangle mesh (hit.primitive = the triangle, u v its
// barycentrics, geometricNormal (b-a) x (c-a)). BadInput for a point cloud.
// The caster copies its input. Each ray's hit depends on that ray alone
// (cast one at a time), as with the disc caster.
Result<std::unique_ptr<RayCaster>> makeEmbreeMeshCaster(const Scan& mesh);

// The same nearest hits from a BVH built by Morton codes: a third to a
// fifth of the CPU to build on a large mesh, its rays 10-25% slower
// (docs/benchmarks.md). For a large mesh few rays meet per triangle, as M
// in the bake. Its rays go as coherent streams, faster on M's triangles,
// whose hits may differ in their last bits with the rays cast beside them.
Result<std::unique_ptr<RayCaster>> makeQuickBuiltEmbreeMeshCaster(const Scan& mesh);

// Embree BVH over one oriented disc per point (centre = the point, plane
// normal = its normal, radius = radii[i], in world units). Discs are hit from
// either side; hit.primitive is the point index, hit.geometricNormal the
// point's normal (as given), u = v = 0. BadInput unless every point has a
// normal and radii holds one finite positive radius per point. The caster
// copies its input.
Result<std::unique_ptr<RayCaster>> makeEmbreeDiscCaster(const PointSet& points, const std::vector<float>& radii);

// The exact closest point of a triangle mesh (Embree's point query over the
// same BVH), its normal interpolated from the vertex normals (m's normal
// field, where the FLANN finder's nearest vertices may lie on the other side
// of a part thinner than m's triangles). BadInput for a point cloud or a
// mesh without a normal per vertex. The finder keeps the mesh's positions,
// normals and triangles: pass it by std::move where the caller is done with
// it (M in `apo export --source detail`: 1.2M triangles copied three times
// over before).
Result<std::unique_ptr<ClosestPointFinder>> makeEmbreeClosestPoint(Scan mesh);

}  // namespace apo
