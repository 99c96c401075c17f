// A run's options: defaults, validation and their JSON for the manifest,
// keyed by the names `apo run` and a --config file give them (negated flags
// as their --no- form).
#include "pipeline/pipeline.h"

namespace apo {
namespace {

using Json = nlohmann::ordered_json;

Json vectorOrNull(const std::optional<Vec3f>& v) {
  if (!v) return nullptr;
  return Json::array({v->x(), v->y(), v->z()});
}

Json ingestJson(const IngestOptions& o) {
  return {{"no-merge-duplicates", !o.mergeDuplicates}, {"remove-outliers", o.removeOutliers},
          {"outlier-k", o.outlierNeighbours},         {"outlier-std", o.outlierStdDevs},
          {"voxel", o.voxelSize},                     {"no-normals", !o.estimateNormals},
          {"normal-k", o.normalNeighbours},           {"force-normals", o.forceNormalEstimation},
          {"sensor", vectorOrNull(o.sensorPosition)}, {"orient", orientationMethodName(o.orientation)},
          {"keep-winding", !o.orientFaces}, {"no-grid-mesh", !o.triangulateGrid}, {"mesh-input", meshInputName(o.meshInput)},
          {"max-scan-points", o.maxScanPoints}};
}

Json reconstructJson(const ReconstructOptions& o) {
  return {{"method", methodName(o.method)},
          {"max-points", o.maxPoints ? Json(*o.maxPoints) : Json(nullptr)},
          {"trim", o.trim},
          {"radius-ratio", o.radiusRatioBound},
          {"min-component", o.minComponent},
          {"spacing-k", o.spacingNeighbours},
          {"poisson-distance", o.poissonSpacing},
          {"poisson-radius", o.poissonRadius},
          {"scale", o.scaleSpaceScale},
          {"seed", o.seed}};
}

Json simplifyJson(const SimplifyOptions& o) {
  return {{"faces", o.targetFaces}, {"ratio", o.ratio}, {"policy", o.policy == SimplifyPolicy::LindstromTurk ? "lt" : "gh"},
          {"no-quick-pass", !o.quickFirstPass}};
}

Json bakeJson(const BakeOptions& o) {
  return {{"coarse-depth", o.coarseDepth},   {"max-depth", o.maxDepth},
          {"budget", o.budget},              {"error", o.error},
          {"max-distance", o.maxDistance},
          {"samples", o.samples},            {"complete-depth", o.completeDepth},
          {"normal-encoding", normalEncodingName(o.encoding)}, {"one-sided", !o.twoSidedLeaves},
          {"layout", textureLayoutName(o.layout)}, {"n3-size", o.n3Size},
          {"brick-depth", o.brickDepth}};
}

Json renderJson(const RenderOptions& o) {
  return {{"size", o.size}, {"views", o.views}, {"no-mipmap", !o.mipmapping}, {"no-filter", !o.filtering},
          {"frames", o.timedFrames}, {"no-point-lod", !o.pointLod}, {"lod-threshold", o.lodThreshold}};
}

Json exportJson(const ExportOptions& o) {
  return {{"no-export", !o.enabled}, {"map-size", o.mapSize}, {"gutter", o.gutter}, {"draco", o.draco}, {"no-color", !o.color}, {"patch-size", o.detailSizing ? "detail" : "uniform"}};
}

}  // namespace

std::string detailSourceName(DetailSource source) {
  switch (source) {
    case DetailSource::Auto: return "auto";
    case DetailSource::Mesh: return "mesh";
    case DetailSource::Points: return "points";
  }
  return "auto";
}

template <>
Result<Checked<RunOptions>> check(const RunOptions& options) {
  if (auto part = check(options.ingest); !part) return part.error();
  if (auto part = check(options.reconstruct); !part) return part.error();
  if (auto part = check(options.simplify); !part) return part.error();
  if (auto part = check(options.bake); !part) return part.error();
  if (auto part = check(options.render); !part) return part.error();
  if (auto part = check(options.exporting); !part) return part.error();
  return Checked<RunOptions>(options);
}

nlohmann::ordered_json optionsJson(const RunOptions& options) {
  return {{"detail-source", detailSourceName(options.detailSource)},
          {"keep-georeference", options.keepGeoreference},
          {"all-points", options.allPoints},
          {"point-normals", options.pointNormals == PointNormals::Fitted ? "fitted" : "centroids"},
          {"ingest", ingestJson(options.ingest)},
          {"reconstruct", reconstructJson(options.reconstruct)},
          {"simplify", simplifyJson(options.simplify)},
          {"bake", bakeJson(options.bake)},
          {"render", renderJson(options.render)},
          {"export", exportJson(options.exporting)},
          {"report", {{"no-viewer", !options.viewer}}}};
}

}  // namespace apo
