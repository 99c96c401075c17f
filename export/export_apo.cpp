// The export stage: m and a normal field (the APO's, or M's) to a GLB, with
// its figures.
#include "export/export.h"

#include "core/image_io.h"
#include "core/timing.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <optional>

namespace apo {

template <>
Result<Checked<ExportOptions>> check(const ExportOptions& options) {
  if (options.mapSize < 16 || options.mapSize > 16384)
    return usageError("--map-size must be 16 to 16384 texels (got {})", options.mapSize);
  if (options.gutter < 1 || options.gutter > 8) return usageError("--gutter must be 1 to 8 texels (got {})", options.gutter);
  return Checked<ExportOptions>(options);
}

namespace {

std::string extrasJson(const ExportReport& report, const std::array<double, 3>& origin) {
  nlohmann::ordered_json extras;
  extras["apo"] = {{"layout", "patches"},
                   {"source", report.source},
                   {"map", {report.mapWidth, report.mapHeight}},
                   {"gutter", report.gutter},
                   {"texels_per_unit", report.texelsPerUnit},
                   {"patch_size", report.detailSizing ? "detail" : "uniform"},
                   {"used_share", report.usedShare},
                   {"base_color", report.colorPngBytes > 0 ? "the scan's colours" : "none"}};
  extras["georeference"] = {{"origin", origin}, {"meaning", "scan file coordinates = origin + glTF coordinates"}};
  return extras.dump();
}

}  // namespace

NormalField apoNormalField(const ApoTexture& apo) {
  return [&apo](const Vec3f& point, const Vec3f& coarseNormal) {
    const Lookup found = lookupTextureFiltered(apo, apo.transform.toUnit(point), coarseNormal);
    return found.found ? found.normal : Vec3f::Zero();
  };
}

Result<ExportedAsset> exportGlb(const Scan& coarse, const NormalField& field, const std::string& source,
                                const Checked<ExportOptions>& checkedOptions, const std::array<double, 3>& origin,
                                const std::string& generator, const ColorField* color) {
  const ExportOptions& options = *checkedOptions;
  if (!coarse.isMesh()) return badInput("m has no triangles to export");
  const Stopwatch stopwatch;
  const std::vector<float> scales = options.detailSizing ? detailPatchScales(coarse, field) : std::vector<float>{};
  auto atlas = packTrianglePatches(coarse, options.mapSize, options.mapSize, options.gutter, scales);
  if (!atlas) return atlas.error();
  const GltfMesh mesh = patchMesh(coarse, *atlas);
  const NormalMap map = bakeTangentNormalMap(mesh, *atlas, field);
  auto png = encodePng8(map.width, map.height, 3, map.rgb);
  if (!png) return png.error();
  GlbImages images{std::move(*png), {}};
  if (color != nullptr) {
    auto colors = bakeColorMap(mesh, *atlas, *color);
    if (!colors) return colors.error();
    auto colorPng = encodePng8(colors->width, colors->height, 3, colors->rgb);
    if (!colorPng) return colorPng.error();
    images.colorPng = std::move(*colorPng);
  }
  ExportedAsset asset;
  ExportReport& r = asset.report;
  r.source = source;
  r.mapWidth = map.width;
  r.mapHeight = map.height;
  r.gutter = atlas->gutter;
  r.texelsPerUnit = atlas->texelsPerUnit;
  r.detailSizing = options.detailSizing;
  r.smallestScale = *std::min_element(atlas->scales.begin(), atlas->scales.end());
  r.largestScale = *std::max_element(atlas->scales.begin(), atlas->scales.end());
  r.usedShare = atlas->usedShare;
  r.triangles = coarse.triangles.size();
  r.texelsFilled = map.texelsFilled;
  r.texelsWithoutAnswer = map.texelsWithoutAnswer;
  r.pngBytes = images.normalPng.size();
  r.colorPngBytes = images.colorPng.size();
  r.draco = options.draco;
  std::optional<DracoPrimitive> compressed;
  if (options.draco) {
    auto made = dracoCompress(mesh);
    if (!made) return made.error();
    compressed = std::move(*made);
  }
  asset.glb = glbBytes(mesh, images, generator, extrasJson(r, origin), compressed ? &*compressed : nullptr);
  r.glbBytes = asset.glb.size();
  r.seconds = stopwatch.seconds();
  return asset;
}

std::string exportReportJson(const ExportReport& r) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["layout"] = "patches";
  json["source"] = r.source;
  json["map"] = {{"width", r.mapWidth}, {"height", r.mapHeight}, {"gutter", r.gutter}, {"png_bytes", r.pngBytes}};
  // The scan's colours as the material's base colour map (docs/export.md).
  json["base_color"] = r.colorPngBytes > 0 ? nlohmann::ordered_json{{"source", "scan colours"}, {"png_bytes", r.colorPngBytes}}
                                           : nlohmann::ordered_json(nullptr);
  json["texels_per_unit"] = r.texelsPerUnit;
  // Each patch's density is texels_per_unit times its scale (docs/export.md, "The patches").
  json["patch_size"] = {{"rule", r.detailSizing ? "detail" : "uniform"},
                        {"smallest_scale", r.smallestScale},
                        {"largest_scale", r.largestScale}};
  json["used_share"] = r.usedShare;
  json["triangles"] = r.triangles;
  json["texels_filled"] = r.texelsFilled;
  json["texels_without_answer"] = r.texelsWithoutAnswer;
  json["draco"] = r.draco;
  json["glb_bytes"] = r.glbBytes;
  json["seconds"] = r.seconds;
  return json.dump();
}

}  // namespace apo
