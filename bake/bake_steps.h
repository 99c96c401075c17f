// Inside bake: the steps of a bake that the one-piece bake (bake.cpp) and
// the bake in bricks (bricks.cpp) share.
#pragma once

#include "bake/octree_build.h"

#include <array>
#include <cstdint>
#include <vector>

namespace apo::bake_steps {

// BadInput when m has no triangles, a non-finite vertex or no extent.
Status validateCoarseMesh(const Scan& coarse);

// m and the options as every step reads them.
struct Frame {
  Aabb box;
  UnitCubeTransform transform;
  octree::CoarseMesh coarseUnit;
  std::vector<Vec3f> coarseNormals;  // m's, as drawn
  float reach = 0.0f;                // rays and projections reach this far (world units)
  int completeDepth = 0;
  std::uint64_t maxTexels = 0;       // 0: no budget
};
Frame frameOf(const Scan& coarse, const BakeOptions& options);
octree::BuildSettings buildSettingsOf(const BakeOptions& options, const Frame& frame);

// A sum of floats that does not depend on their order: the bake in bricks
// adds the points' areas brick by brick, and must find the mean the bake in
// one piece finds. Exact in each power of two; summed in one order.
class OrderFreeSum {
 public:
  void add(float value);
  void add(const OrderFreeSum& other);
  double value() const;

 private:
  static constexpr int kLowestExponent = -160;  // below float's least subnormal (2^-149) with its 24 bits
  std::array<std::int64_t, 300> bins_{};
  bool nonFinite_ = false;  // a non-finite value was added: the sum is NaN
};

// M's points for the error metric (octree_build.h): in unit-cube
// coordinates where each projects onto m along its normal, weighted by its
// area (`areas`; empty: equal) over `meanArea`.
octree::DetailPrimitives pointsForErrorMetric(const PointSet& points, const std::vector<float>& areas, double meanArea,
                                              const CoarseSurface& coarse, const Frame& frame);

// A Usage error when the budget is below the octree's complete levels.
Status checkBudgetMet(const octree::BuiltOctree& built, const BakeOptions& options);

// The rest of a bake once the octree is built and sampled: the encoding
// (and the N^3-tree), the octree's counts in the report.
Status encodeInto(Bake& bake, octree::BuiltOctree built, const Scan& coarse, const BakeOptions& options,
                  const Frame& frame);

RefinementReport refinementReport(const octree::RefinementOutcome& outcome, const BakeOptions& options);

}  // namespace apo::bake_steps
