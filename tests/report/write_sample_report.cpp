// write_sample_report OUTDIR: a sample of what `apo run` and `apo batch`
// leave behind, for the browser check (tests/report/browser_check.py):
//
//   OUTDIR/report.html, manifest.json      one scan named "<img src=x onerror=alert(1)>.ply",
//   OUTDIR/render #1 & 'x' ?%/viewNN_*.png  its renders in a folder whose name needs percent-encoding
//   OUTDIR/more scans/b #2 & 'c'.ply/...    a second scan, as a batch puts it
//   OUTDIR/index.html                       the batch index: both scans and one failed at ingest
//
// The images are small synthetic renders: a bumpy sphere as the reference M,
// a faceted sphere as the baseline m, the bumps sampled per 3-pixel cell as m
// with the APO; the figures in render.json are measured on them by render/'s
// own metrics, and bake.json is written by bake/'s writer.
#include "report/report.h"
#include "bake/bake.h"
#include "core/file_io.h"
#include "render/render.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <utility>

namespace apo {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr int kSize = 96;   // pixels per side
constexpr int kViews = 3;
constexpr float kRadius = 0.9f;  // of the half image

enum class Surface { Bumpy, Faceted, Cells };

// The unit normal of a pass at image coordinates (s, t) in [-1, 1] inside the
// sphere's disc, for view `view`.
Vec3f surfaceNormal(Surface surface, float s, float t, int view) {
  const float phase = 1.3f * static_cast<float>(view);
  if (surface == Surface::Faceted) {  // coarse m: flat facets on a 6 x 6 grid
    s = (std::floor(s * 3.0f) + 0.5f) / 3.0f;
    t = (std::floor(t * 3.0f) + 0.5f) / 3.0f;
  } else if (surface == Surface::Cells) {  // the APO: M's normal per octree cell of 3 pixels
    const float cell = 6.0f / kSize;
    s = (std::floor(s / cell) + 0.5f) * cell;
    t = (std::floor(t / cell) + 0.5f) * cell;
  }
  const float z2 = std::max(0.02f, 1.0f - s * s - t * t);
  Vec3f n(s, t, std::sqrt(z2));
  n.normalize();
  if (surface != Surface::Faceted) n += Vec3f(0.22f * std::sin(9.0f * s + phase), 0.22f * std::cos(7.0f * t + phase), 0.0f);
  return n.normalized();
}

PassImages drawPass(Surface surface, int view) {
  PassImages pass;
  pass.shaded.width = pass.shaded.height = pass.normals.width = pass.normals.height = kSize;
  pass.shaded.rgba.assign(4 * kSize * kSize, 0);
  pass.normals.data.assign(4 * kSize * kSize, 0.0f);
  const Vec3f light = Vec3f(0.4f - 0.3f * static_cast<float>(view), 0.5f, 0.77f).normalized();
  const Vec3f albedo(0.80f, 0.77f, 0.72f);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * kSize + static_cast<std::size_t>(x);
      const float s = ((x + 0.5f) / kSize * 2.0f - 1.0f) / kRadius;
      const float t = (1.0f - (y + 0.5f) / kSize * 2.0f) / kRadius;
      std::uint8_t* rgba = &pass.shaded.rgba[4 * p];
      if (s * s + t * t > 1.0f) {  // background
        rgba[0] = rgba[1] = rgba[2] = 255;
        rgba[3] = 255;
        continue;
      }
      const Vec3f n = surfaceNormal(surface, s, t, view);
      const float shade = 0.15f + 0.85f * std::max(0.0f, n.dot(light));
      for (int c = 0; c < 3; ++c) rgba[c] = static_cast<std::uint8_t>(std::lround(255.0f * std::min(1.0f, albedo[c] * shade)));
      rgba[3] = 255;
      std::copy(n.data(), n.data() + 3, &pass.normals.data[4 * p]);
      pass.normals.data[4 * p + 3] = 1.0f;
    }
  return pass;
}

bool writeOrReport(const Status& status) {
  if (!status.ok()) std::fprintf(stderr, "write_sample_report: %s\n", status.error().message.c_str());
  return status.ok();
}

Json stage(const char* name, const char* status, double seconds, double peakBytes) {
  return {{"name", name}, {"status", status}, {"seconds", seconds}, {"peak_memory_bytes", peakBytes}};
}

// One successful scan into `dir` (report.html, manifest.json and the renders
// in `dir / renders`); returns its manifest, or null if a file could not be written.
Json writeScan(const fs::path& dir, const std::string& name, const std::string& renders) {
  std::vector<ViewImages> views;
  std::vector<Camera> cameras;
  for (int v = 0; v < kViews; ++v) {
    ViewImages view;
    view.reference = drawPass(Surface::Bumpy, v);
    view.baseline = drawPass(Surface::Faceted, v);
    view.apo = drawPass(Surface::Cells, v);
    view.cost = {2.1 + 0.1 * v, 0.42, 0.97 + 0.05 * v, {5100, 6.4, 9}};
    view.camera.eye = Vec3f(v == 0 ? 2.5f : 0.0f, v == 1 ? 2.5f : 0.0f, v == 2 ? 2.5f : 0.0f);
    cameras.push_back(view.camera);
    views.push_back(std::move(view));
  }
  RenderOptions options;
  options.size = kSize;
  options.views = kViews;
  options.timedFrames = 3;
  const RenderFigures figures = measureViews(views);
  for (std::size_t i = 0; i < views.size(); ++i) {
    const fs::path prefix = dir / renders / fmt::format("view{:02d}_", i);
    const Image heatMap = errorHeatMap(figures.apoAngles[i], kSize, kSize, static_cast<float>(kReportHeatMapDegrees));
    for (const auto& [suffix, image] : {std::pair<const char*, const Image*>{"reference.png", &views[i].reference.shaded},
                                        {"baseline.png", &views[i].baseline.shaded},
                                        {"apo.png", &views[i].apo.shaded},
                                        {"apo_error.png", &heatMap}})
      if (!writeOrReport(writeImagePng(prefix.string() + suffix, *image))) return nullptr;
  }
  const std::string renderJson = renderReportJson(figures, options, cameras);
  if (!writeOrReport(writeFileAtomically(dir / renders / "render.json", renderJson))) return nullptr;

  BakeReport bake;
  bake.detailKind = "mesh";
  bake.detailPrimitives = 1'204'332;
  bake.coarseTriangles = 3000;
  bake.nodesPerDepth = {1, 8, 64, 344, 1416, 5204, 14032, 9630};
  bake.leaves = 26'790;
  bake.internalNodes = 3909;
  bake.rays = 1'203'800;
  bake.hits = 1'187'412;
  bake.fallbacks = 16'388;
  bake.textureWidth = 2048;
  bake.textureHeight = 141;
  bake.textureBytes = 2048ull * 141 * 4;
  bake.seconds = {0.21, 0.84, 3.12, 0.07};
  bake.totalSeconds = 4.24;
  bake.peakMemoryBytes = 612'000'000;

  Json manifest;
  manifest["format_version"] = 1;
  manifest["tool"] = {{"name", "apo"}, {"version", "0.1.0"}};
  manifest["input"] = {{"path", "scans/lab #1/" + name},
                       {"name", name},
                       {"sha256", "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08"},
                       {"bytes", 48'211'904}};
  manifest["options"] = {{"detail-source", "mesh"},
                         {"ingest", {{"voxel", "0"}, {"normal-k", "16"}}},
                         {"simplify", {{"faces", "3000"}, {"policy", "gh"}}},
                         {"bake", {{"error", "0.05"}, {"samples", "4"}}},
                         {"render", {{"size", std::to_string(kSize)}, {"views", std::to_string(kViews)}}}};
  manifest["status"] = "succeeded";
  manifest["error"] = nullptr;
  manifest["stages"] = {stage("ingest", "succeeded", 3.41, 410e6),  stage("reconstruct", "succeeded", 21.7, 1.9e9),
                        stage("simplify", "succeeded", 6.02, 880e6), stage("bake", "succeeded", 4.31, 612e6),
                        stage("render", "succeeded", 2.88, 350e6),   stage("report", "succeeded", 0.01, 12e6)};
  manifest["results"]["ingest"] = {
      {"format_version", 1},
      {"input", {{"path", "scans/lab #1/" + name}, {"sha256", "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08"}, {"format", "ply"}}},
      {"kind", "point_cloud"},
      {"counts", {{"points_in", 460'400}, {"points_out", 452'119}, {"triangles_in", 0}, {"triangles_out", 0}}},
      {"bounding_box", {{"min", {-1, -1, -1}}, {"max", {1, 1, 1}}, {"diagonal", 3.4641}}},
      {"normals", {{"source", "estimated"}, {"orientation", "mst"}, {"neighbours", 16}}}};
  manifest["results"]["reconstruct"] = {
      {"format_version", 1}, {"method", "advancing_front"}, {"points", {{"in", 452'119}, {"used", 452'119}}},
      {"mesh", {{"vertices", 452'119}, {"triangles", 1'204'332}}}, {"points_to_mesh", {{"mean", 0.00021}, {"p95", 0.0009}}}};
  manifest["results"]["simplify"] = {{"format_version", 1},
                                     {"policy", "gh"},
                                     {"faces", {{"in", 1'204'332}, {"target", 3000}, {"out", 3000}}},
                                     {"distance_to_input", {{"hausdorff", 0.0061}, {"mean", 0.0007}}},
                                     {"mesh", {{"vertices", 1502}, {"triangles", 3000}}}};
  manifest["results"]["bake"] = Json::parse(bakeReportJson(bake));
  manifest["results"]["render"] = Json::parse(renderJson);
  manifest["files"] = {{"M", "M.ply"},          {"m", "m.ply"},         {"apo", "scan.apo"},
                       {"texture", "texture.png"}, {"renders", renders}, {"report", "report.html"}};

  if (!writeOrReport(writeFileAtomically(dir / "manifest.json", manifest.dump(2) + "\n"))) return nullptr;
  if (!writeOrReport(writeFileAtomically(dir / "report.html", qaReportHtml(manifest)))) return nullptr;
  return manifest;
}

int run(const fs::path& outDir) {
  const std::string hostile = "<img src=x onerror=alert(1)>.ply";
  const Json first = writeScan(outDir, hostile, "render #1 & 'x' ?%");
  const std::string secondDir = "more scans/b #2 & 'c'.ply";
  const Json second = writeScan(outDir / secondDir, "b #2 & 'c'.ply", "render");
  if (first.is_null() || second.is_null()) return 1;

  Json failed;
  failed["format_version"] = 1;
  failed["input"] = {{"path", "scans/broken/<svg onload=alert(1)>.pcd"}, {"name", "<svg onload=alert(1)>.pcd"}};
  failed["status"] = "failed";
  failed["error"] = {{"stage", "ingest"},
                     {"message", "scans/broken/<svg onload=alert(1)>.pcd: line 11: DATA ascii declares 3 fields, "
                                 "found 2 <b>values</b> & \"quotes\""}};
  failed["stages"] = {stage("ingest", "failed", 0.02, 9e6), stage("reconstruct", "not_run", 0, 0),
                      stage("simplify", "not_run", 0, 0),   stage("bake", "not_run", 0, 0),
                      stage("render", "not_run", 0, 0),     stage("report", "not_run", 0, 0)};
  failed["results"] = Json::object();
  failed["files"] = Json::object();
  const std::string failedDir = "broken/<svg onload=alert(1)>.pcd";
  if (!writeOrReport(writeFileAtomically(outDir / failedDir / "manifest.json", failed.dump(2) + "\n"))) return 1;

  const std::vector<BatchRow> rows = {{".", first}, {secondDir, second}, {failedDir, failed}};
  const Json summary = {{"scans", 3}, {"succeeded", 2}, {"failed", 1}, {"skipped_up_to_date", 0}, {"seconds", 84.6}};
  if (!writeOrReport(writeFileAtomically(outDir / "index.html", batchIndexHtml(rows, summary)))) return 1;
  std::printf("write_sample_report: %s and %s\n", (outDir / "report.html").c_str(), (outDir / "index.html").c_str());
  return 0;
}

}  // namespace
}  // namespace apo

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_sample_report OUTDIR\n");
    return 1;
  }
  return apo::run(argv[1]);
}
