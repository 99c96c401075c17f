// `apo render`: m with the APO next to M (the reference) and m alone, per
// view: shaded PNGs, normal buffers (PFM), error heat maps and render.json.
#include "bake/bake.h"
#include "cli/command_support.h"
#include "core/file_io.h"
#include "ingest/ingest.h"
#include "render/render.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

// The heat maps' fixed colour scale, degrees.
constexpr float kHeatMapDegrees = 10.0f;

struct RenderCommand {
  fs::path apo, coarse, detail;
  fs::path outDir;
  bool noMipmapping = false;
  RenderOptions options;
};

// The .apo must have been baked around this m: its unit cube is m's.
Status checkTransformMatches(const fs::path& apoPath, const ApoTexture& texture, const Scan& coarse) {
  const UnitCubeTransform expected = unitCubeAround(boundingBox(coarse.points.positions));
  const double scaleError = std::abs(expected.scale - texture.transform.scale) / expected.scale;
  double offsetError = 0.0;
  for (int axis = 0; axis < 3; ++axis)
    offsetError = std::max(offsetError, std::abs(expected.offset[axis] - texture.transform.offset[axis]));
  if (scaleError > 1e-5 || offsetError > 1e-5)
    return badInput("{}: baked around another coarse mesh: its unit-cube scale {} and offset ({}, {}, {}) are not m's ({} and "
                    "({}, {}, {}))",
                    apoPath.string(), texture.transform.scale, texture.transform.offset[0], texture.transform.offset[1],
                    texture.transform.offset[2], expected.scale, expected.offset[0], expected.offset[1], expected.offset[2]);
  return okStatus();
}

Status writePass(const fs::path& dir, const std::string& stem, const PassImages& pass) {
  APO_RETURN_IF_ERROR(writeImagePng(dir / (stem + ".png"), pass.shaded));
  return writeNormalsPfm(dir / (stem + "_normals.pfm"), pass.normals);
}

// The reference and the heat maps exist only when M was given.
Status writeViews(const fs::path& dir, const std::vector<ViewImages>& views, const RenderFigures& figures) {
  const bool withReference = !figures.apoAngles.empty();
  for (std::size_t i = 0; i < views.size(); ++i) {
    const std::string prefix = fmt::format("view{:02d}_", i);
    if (withReference) APO_RETURN_IF_ERROR(writePass(dir, prefix + "reference", views[i].reference));
    APO_RETURN_IF_ERROR(writePass(dir, prefix + "baseline", views[i].baseline));
    APO_RETURN_IF_ERROR(writePass(dir, prefix + "apo", views[i].apo));
    if (withReference)
      APO_RETURN_IF_ERROR(writeImagePng(dir / (prefix + "apo_error.png"),
                                        errorHeatMap(figures.apoAngles[i], views[i].apo.shaded.width,
                                                     views[i].apo.shaded.height, kHeatMapDegrees)));
  }
  return okStatus();
}

int runRender(RenderCommand command) {
  command.options.mipmapping = !command.noMipmapping;
  auto texture = readApoFile(command.apo);
  if (!texture) return reportFailure(texture.error());
  auto coarse = readScan(command.coarse);
  if (!coarse) return reportFailure(coarse.error());
  if (!coarse->isMesh()) return reportFailure(badInput("{}: m must be a triangle mesh", command.coarse.string()));
  if (Status s = checkTransformMatches(command.apo, *texture, *coarse); !s.ok()) return reportFailure(s.error());
  std::unique_ptr<Scan> detail;
  if (!command.detail.empty()) {
    auto read = readScan(command.detail);
    if (!read) return reportFailure(read.error());
    detail = std::make_unique<Scan>(std::move(read).value());
  }
  auto views = renderViews(detail.get(), *coarse, *texture, command.options);
  if (!views) return reportFailure(aboutInput(command.detail.empty() ? command.coarse : command.detail, views.error()));
  std::vector<Camera> cameras;
  for (const ViewImages& view : *views) cameras.push_back(view.camera);
  const RenderFigures figures = measureViews(*views);
  if (Status s = writeViews(command.outDir, *views, figures); !s.ok()) return reportFailure(s.error());
  if (Status s = writeFileAtomically(command.outDir / "render.json", renderReportJson(figures, command.options, cameras));
      !s.ok())
    return reportFailure(s.error());
  if (detail)
    spdlog::info("render: {} views at {}px: APO {:.3f} deg mean from M's normals, m alone {:.3f} (x{:.2f}) -> {}",
                 views->size(), command.options.size, figures.apo.mean, figures.baseline.mean,
                 figures.apo.mean > 0 ? figures.baseline.mean / figures.apo.mean : 0.0, command.outDir.string());
  else
    spdlog::info("render: {} views at {}px -> {}", views->size(), command.options.size, command.outDir.string());
  if (command.options.timedFrames > 0)
    spdlog::info("render: median frame {:.1f} ms with the APO ({:.1f} texel reads per fragment, at most {}), {:.1f} ms for m "
                 "alone{}",
                 figures.cost.apoMilliseconds, figures.cost.apoFetches.mean, figures.cost.apoFetches.max,
                 figures.cost.baselineMilliseconds,
                 detail ? fmt::format(", {:.1f} ms for M", figures.cost.referenceMilliseconds) : std::string());
  return kExitSuccess;
}

}  // namespace

void addRenderCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<RenderCommand>();
  CLI::App* sub = app.add_subcommand("render", "Render m with the APO next to M, headless, and measure the difference");
  sub->add_option("--apo", command->apo, "The .apo file (apo bake)")->required();
  sub->add_option("--coarse", command->coarse, "m, the mesh the APO was baked around")->required();
  sub->add_option("--detail", command->detail, "M, the dense mesh or the points: the reference the metrics compare with");
  sub->add_option("-o,--out", command->outDir, "Output folder (PNGs, normal buffers, heat maps, render.json)")->required();
  sub->add_option("--size", command->options.size, "Image side in pixels")->capture_default_str();
  sub->add_option("--views", command->options.views, "Views: the 6 axis directions, then the 8 cube diagonals")
      ->check(CLI::Range(1, 14))
      ->capture_default_str();
  sub->add_flag("--no-mipmap", command->noMipmapping, "Walk to the leaves even where cells are smaller than a pixel");
  sub->add_flag("--filter", command->options.filtering, "Trilinear filtering of the 8 neighbouring cells (paper 5.3)");
  sub->add_option("--frames", command->options.timedFrames, "Frames timed per pass and view (median); 0: no timing")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runRender(*command); }); });
}

}  // namespace apo::cli
