#include "pipeline/pipeline.h"

#include "adapters/embree/embree_ray_caster.h"

namespace apo {

Result<SimulatedScan> simulateRangeScan(const Scan& mesh, const Checked<SimulateScanOptions>& options) {
  auto caster = makeEmbreeMeshCaster(mesh);
  if (!caster) return caster.error();
  return simulateScan(mesh, **caster, options);
}

}  // namespace apo
