// reconstruct.json and simplify.json (format_version 1, docs/reconstruct.md).
#include "reconstruct/reconstruct.h"

#include <nlohmann/json.hpp>

namespace apo {
namespace {

nlohmann::ordered_json qualityJson(const MeshQuality& q) {
  return {{"vertices", q.vertices},
          {"triangles", q.triangles},
          {"non_manifold_edges", q.nonManifoldEdges},
          {"non_manifold_vertices", q.nonManifoldVertices},
          {"boundary_loops", q.boundaryLoops},
          {"components", q.components},
          {"euler_characteristic", q.eulerCharacteristic},
          {"area", q.area},
          {"bbox_diagonal", q.diagonal}};
}

}  // namespace

std::string reconstructReportJson(const ReconstructReport& r) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["method"] = r.method;
  json["normal_imbalance"] = r.normalImbalance;
  json["points"] = {{"in", r.pointsIn}, {"used", r.pointsUsed}, {"subsampled", r.pointsUsed < r.pointsIn}};
  json["average_spacing"] = r.averageSpacing;
  json["trimmed"] = {{"triangles", r.trimmedTriangles}, {"area", r.trimmedArea}};
  json["dropped_components"] = {{"count", r.droppedComponents}, {"area", r.droppedArea}};
  json["mesh"] = qualityJson(r.quality);
  json["points_to_mesh"] = {{"mean", r.pointToMeshMean}, {"p95", r.pointToMeshP95}, {"unit", "bbox_diagonal"}};
  json["seconds"] = r.seconds;
  return json.dump(2) + "\n";
}

std::string simplifyReportJson(const SimplifyReport& r) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["policy"] = r.policy;
  json["faces"] = {{"in", r.facesIn}, {"target", r.targetFaces}, {"out", r.facesOut}};
  json["quick_first_pass"] = r.quickPassFaces == 0 ? nlohmann::ordered_json(nullptr)
                                                    : nlohmann::ordered_json{{"library", "meshoptimizer"},
                                                                             {"faces_out", r.quickPassFaces},
                                                                             {"error", r.quickPassError},
                                                                             {"pockets_removed", r.quickPassPockets},
                                                                             {"unit", "bbox_extent"}};
  json["filled_holes"] = r.filledHoles;
  json["borders_collapsed"] = r.bordersCollapsed;
  json["distance_to_input"] = {{"hausdorff", r.hausdorff}, {"mean", r.meanDistance}, {"unit", "bbox_diagonal"}};
  json["mesh"] = qualityJson(r.quality);
  json["seconds"] = r.seconds;
  return json.dump(2) + "\n";
}

}  // namespace apo
