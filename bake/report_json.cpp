// bake.json (format_version 2, docs/bake.md).
#include "bake/bake.h"

#include <nlohmann/json.hpp>

namespace apo {

std::string bakeReportJson(const BakeReport& r) {
  nlohmann::ordered_json json;
  json["format_version"] = 2;
  json["detail"] = {{"kind", r.detailKind},
                    {"primitives", r.detailPrimitives},
                    {"face_order_spread", r.detailFaceOrderSpread},
                    {"faces_reordered", r.detailFacesReordered}};
  json["coarse_triangles"] = r.coarseTriangles;
  json["nodes"] = {{"per_depth", r.nodesPerDepth}, {"leaves", r.leaves}, {"internal", r.internalNodes}};
  const RefinementReport& f = r.refinement;
  json["refinement"] = {{"budget_bytes", f.budgetBytes},
                        {"error_threshold", f.errorThreshold},
                        {"stopped_by", f.stoppedBy},
                        {"l21", f.l21},
                        {"rms_degrees", f.rmsDegrees},
                        {"leaves_showing_m", f.leavesShowingCoarse},
                        {"two_sided_leaves", f.twoSidedLeaves},
                        {"internal_nodes_showing_m", f.internalNodesShowingCoarse},
                        {"leaves_at_max_depth", f.leavesAtMaxDepth},
                        {"sum_depth", f.sumDepth}};
  json["sampling"] = {{"rays", r.rays}, {"samples_hit", r.hits}, {"samples_fallback", r.fallbacks}};
  json["texture"] = {{"width", r.textureWidth}, {"height", r.textureHeight}, {"bytes", r.textureBytes}};
  if (r.n3tree) {
    const N3TreeReport& t = *r.n3tree;
    json["n3tree"] = {{"n", t.n},         {"levels", t.levels}, {"grids", t.grids}, {"pool_cells", t.poolCells},
                      {"two_sided_leaves", t.twoSidedLeaves}, {"bytes", t.bytes}, {"seconds", t.seconds}};
  }
  if (r.bricks) {
    const BrickReport& b = *r.bricks;
    json["bricks"] = {{"depth", b.depth},
                      {"bricks", b.bricks},
                      {"refinement_runs", b.refinementRuns},
                      {"recorded_cells", b.recordedCells},
                      {"largest_brick_points", b.largestBrickPoints},
                      {"points_loaded", b.pointsLoaded},
                      {"margin", b.marginWorld},
                      {"discs_wider_than_reach", b.discsWiderThanReach},
                      {"journal", {{"entries_reused", b.journalEntriesReused}, {"entries_written", b.journalEntriesWritten}}},
                      {"seconds", {{"areas", b.areaSeconds}, {"refinement", b.refineSeconds}, {"sampling", b.sampleSeconds}}}};
  }
  json["seconds"] = {{"setup", r.seconds.setup},
                     {"build", r.seconds.build},
                     {"sample", r.seconds.sample},
                     {"encode", r.seconds.encode},
                     {"total", r.totalSeconds}};
  json["peak_memory_bytes"] = r.peakMemoryBytes;
  return json.dump(2) + "\n";
}

}  // namespace apo
