// bake.json (format_version 1, docs/bake.md).
#include "bake/bake.h"

#include <nlohmann/json.hpp>

namespace apo {

std::string bakeReportJson(const BakeReport& r) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["detail"] = {{"kind", r.detailKind}, {"primitives", r.detailPrimitives}};
  json["coarse_triangles"] = r.coarseTriangles;
  json["nodes"] = {{"per_depth", r.nodesPerDepth}, {"leaves", r.leaves}, {"internal", r.internalNodes}};
  json["sampling"] = {{"rays", r.rays}, {"samples_hit", r.hits}, {"samples_fallback", r.fallbacks}};
  json["texture"] = {{"width", r.textureWidth}, {"height", r.textureHeight}, {"bytes", r.textureBytes}};
  json["seconds"] = {{"setup", r.seconds.setup},
                     {"build", r.seconds.build},
                     {"sample", r.seconds.sample},
                     {"encode", r.seconds.encode},
                     {"total", r.totalSeconds}};
  json["peak_memory_bytes"] = r.peakMemoryBytes;
  return json.dump(2) + "\n";
}

}  // namespace apo
