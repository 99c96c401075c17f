// The figures of render.json and the normal buffers as files.
#include "render/render.h"
#include "core/file_io.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace apo {
namespace {

PassFigures figuresOf(const PassImages& pass, const PassImages& reference, std::vector<float>* angles) {
  PassFigures figures;
  figures.angles = angularErrors(pass.normals, reference.normals, angles);
  figures.image = compareImages(pass.shaded, reference.shaded, pass.normals, reference.normals);
  return figures;
}

void append(std::vector<float>& all, const std::vector<float>& more) { all.insert(all.end(), more.begin(), more.end()); }

nlohmann::ordered_json anglesJson(const AngularStats& s) {
  return {{"pixels", s.pixels}, {"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}};
}

// JSON has no infinity: identical images get a null PSNR.
nlohmann::ordered_json imageJson(const ImageMetrics& m) {
  nlohmann::ordered_json json = {{"pixels", m.pixels}, {"mean_absolute_error", m.meanAbsoluteError}};
  json["psnr_db"] = std::isfinite(m.psnr) ? nlohmann::ordered_json(m.psnr) : nlohmann::ordered_json(nullptr);
  json["ssim"] = m.ssim;
  json["silhouette_mismatch"] = m.silhouetteMismatch;
  json["inside_pixels"] = m.insidePixels;
  json["mean_absolute_error_inside"] = m.meanAbsoluteErrorInside;
  return json;
}

nlohmann::ordered_json passJson(const PassFigures& f) {
  return {{"angular_error_degrees", anglesJson(f.angles)}, {"image", imageJson(f.image)}};
}

nlohmann::ordered_json fetchesJson(const FetchCounts& f) {
  return {{"fragments", f.fragments}, {"mean", f.mean}, {"max", f.max}};
}

template <class Cost>
nlohmann::ordered_json costJson(const Cost& c) {
  return {{"reference_frame_ms", c.referenceMilliseconds},
          {"baseline_frame_ms", c.baselineMilliseconds},
          {"apo_frame_ms", c.apoMilliseconds},
          {"apo_texel_fetches", fetchesJson(c.apoFetches)},
          {"reference_primitives", {{"sent", c.referenceSent}, {"drawn", c.referenceDrawn}}}};
}

}  // namespace

RenderCost totalCost(const std::vector<ViewImages>& views) {
  RenderCost total;
  double fetchSum = 0.0;
  for (const ViewImages& view : views) {
    total.referenceMilliseconds += view.cost.referenceMilliseconds;
    total.baselineMilliseconds += view.cost.baselineMilliseconds;
    total.apoMilliseconds += view.cost.apoMilliseconds;
    total.referenceSent = view.cost.referenceSent;
    total.referenceDrawn += static_cast<double>(view.cost.referenceDrawn);
    total.apoFetches.fragments += view.cost.apoFetches.fragments;
    total.apoFetches.max = std::max(total.apoFetches.max, view.cost.apoFetches.max);
    fetchSum += view.cost.apoFetches.mean * static_cast<double>(view.cost.apoFetches.fragments);
  }
  if (!views.empty()) {
    const auto count = static_cast<double>(views.size());
    total.referenceMilliseconds /= count;
    total.baselineMilliseconds /= count;
    total.apoMilliseconds /= count;
    total.referenceDrawn /= count;
  }
  if (total.apoFetches.fragments > 0) total.apoFetches.mean = fetchSum / static_cast<double>(total.apoFetches.fragments);
  return total;
}

RenderFigures measureViews(const std::vector<ViewImages>& views) {
  RenderFigures figures;
  figures.cost = totalCost(views);
  std::vector<float> allApo, allBaseline;
  for (const ViewImages& view : views) {
    if (view.reference.normals.data.empty()) {
      figures.views.push_back({{}, {}, view.cost});
      continue;
    }
    std::vector<float> apo, baseline;
    figures.views.push_back({figuresOf(view.apo, view.reference, &apo), figuresOf(view.baseline, view.reference, &baseline), view.cost});
    append(allApo, apo);
    append(allBaseline, baseline);
    figures.apoAngles.push_back(std::move(apo));
  }
  figures.apo = statsOfAngles(std::move(allApo));
  figures.baseline = statsOfAngles(std::move(allBaseline));
  std::vector<ImageMetrics> apoImages, baselineImages;
  for (const ViewFigures& view : figures.views) {
    if (view.apo.image.pixels == 0) continue;
    apoImages.push_back(view.apo.image);
    baselineImages.push_back(view.baseline.image);
  }
  if (!apoImages.empty()) {
    figures.apoImage = poolImageMetrics(apoImages);
    figures.baselineImage = poolImageMetrics(baselineImages);
  }
  return figures;
}

std::string scanFidelityJson(const ScanFidelity& f) {
  const auto statistics = [](const AngularStats& s) {
    return nlohmann::ordered_json{{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}};
  };
  nlohmann::ordered_json json;
  json["probes"] = f.probes;
  json["probes_kept"] = f.kept;
  json["m"] = statistics(f.coarse);
  json["apo_filtered"] = statistics(f.apo);
  json["M"] = f.dense.pixels == 0 ? nlohmann::ordered_json(nullptr)
                                  : nlohmann::ordered_json{{"scan_points", f.dense.pixels},
                                                           {"normal_degrees", statistics(f.dense)},
                                                           {"mean_distance", f.denseMeanDistance},
                                                           {"p95_distance", f.denseP95Distance},
                                                           {"distance_unit", "bbox_diagonal"}};
  nlohmann::ordered_json views = nlohmann::ordered_json::array();
  for (const ViewAgainstScan& view : f.views)
    views.push_back({{"probes_seen", view.apo.pixels}, {"m", statistics(view.coarse)}, {"apo_filtered", statistics(view.apo)}});
  json["views"] = std::move(views);
  return json.dump();
}

std::string renderReportJson(const RenderFigures& figures, const RenderOptions& options, const std::vector<Camera>& cameras) {
  nlohmann::ordered_json json;
  json["format_version"] = 1;
  json["options"] = {{"size", options.size}, {"views", options.views}, {"mipmapping", options.mipmapping},
                     {"filtering", options.filtering}, {"timed_frames", options.timedFrames}};
  json["layout"] = {{"name", figures.layout}, {"n", figures.layout == "apo" ? nlohmann::ordered_json() : nlohmann::ordered_json(figures.n3Size)}};
  json["overall"] = {{"apo", anglesJson(figures.apo)},
                     {"baseline", anglesJson(figures.baseline)},
                     {"baseline_over_apo", figures.apo.mean > 0.0 ? figures.baseline.mean / figures.apo.mean : 0.0},
                     {"apo_image", imageJson(figures.apoImage)},
                     {"baseline_image", imageJson(figures.baselineImage)},
                     {"cost", costJson(figures.cost)}};
  nlohmann::ordered_json views = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < figures.views.size(); ++i) {
    nlohmann::ordered_json view = {{"index", i}};
    if (i < cameras.size()) {
      const Camera& c = cameras[i];
      view["eye"] = {c.eye.x(), c.eye.y(), c.eye.z()};
      view["label"] = c.label;
      view["sees_scanned_side"] = c.seesScannedSide ? nlohmann::ordered_json(*c.seesScannedSide) : nlohmann::ordered_json();
      // The whole camera, so that other renderers can draw the same view.
      view["camera"] = {{"target", {c.target.x(), c.target.y(), c.target.z()}},
                        {"up", {c.up.x(), c.up.y(), c.up.z()}},
                        {"fov_y_degrees", c.fovYDegrees},
                        {"near", c.nearPlane},
                        {"far", c.farPlane}};
    }
    view["apo"] = passJson(figures.views[i].apo);
    view["baseline"] = passJson(figures.views[i].baseline);
    view["cost"] = costJson(figures.views[i].cost);
    views.push_back(view);
  }
  json["views"] = views;
  // Decided from m (scannedSide): a one-sided scan's views start on its scanned side.
  const bool oneSided = std::any_of(cameras.begin(), cameras.end(), [](const Camera& c) { return c.seesScannedSide.has_value(); });
  json["view_order"] = oneSided ? "scanned side first" : "fixed";
  return json.dump(2) + "\n";
}

namespace {

Status writePass(const std::filesystem::path& dir, const std::string& stem, const PassImages& pass) {
  APO_RETURN_IF_ERROR(writeImagePng(dir / (stem + ".png"), pass.shaded));
  return writeNormalsPfm(dir / (stem + "_normals.pfm"), pass.normals);
}

}  // namespace

Status writeRenderOutputs(const std::filesystem::path& dir, const std::vector<ViewImages>& views, const RenderFigures& figures,
                          const RenderOptions& options) {
  const bool withReference = !figures.apoAngles.empty();
  std::vector<Camera> cameras;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const std::string prefix = fmt::format("view{:02d}_", i);
    if (withReference) APO_RETURN_IF_ERROR(writePass(dir, prefix + "reference", views[i].reference));
    APO_RETURN_IF_ERROR(writePass(dir, prefix + "baseline", views[i].baseline));
    APO_RETURN_IF_ERROR(writePass(dir, prefix + "apo", views[i].apo));
    if (withReference)
      APO_RETURN_IF_ERROR(writeImagePng(dir / (prefix + "apo_error.png"),
                                        errorHeatMap(figures.apoAngles[i], views[i].apo.shaded.width,
                                                     views[i].apo.shaded.height, kHeatMapDegrees)));
    cameras.push_back(views[i].camera);
  }
  return writeFileAtomically(dir / "render.json", renderReportJson(figures, options, cameras));
}

Status writeNormalsPfm(const std::filesystem::path& path, const NormalBuffer& normals) {
  std::string bytes = "PF\n" + std::to_string(normals.width) + " " + std::to_string(normals.height) + "\n-1.0\n";
  const std::size_t header = bytes.size();
  bytes.resize(header + 12 * static_cast<std::size_t>(normals.width) * static_cast<std::size_t>(normals.height));
  char* out = bytes.data() + header;
  for (int row = normals.height - 1; row >= 0; --row)  // PFM stores the bottom row first
    for (int column = 0; column < normals.width; ++column) {
      const std::size_t pixel = static_cast<std::size_t>(row) * static_cast<std::size_t>(normals.width) + static_cast<std::size_t>(column);
      const Vec3f n = normals.covered(pixel) ? normals.normal(pixel) : Vec3f(Vec3f::Zero());
      std::memcpy(out, n.data(), 12);  // little-endian floats on this platform, as the -1.0 scale says
      out += 12;
    }
  return writeFileAtomically(path, bytes);
}

}  // namespace apo
