// `apo render`: m with the APO next to M (the reference) and m alone, per
// view: shaded PNGs, normal buffers (PFM), error heat maps and render.json.
#include "cli/command_support.h"
#include "cli/stage_options.h"
#include "core/file_io.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <memory>
#include <optional>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct RenderCommand {
  fs::path apo, coarse, detail;
  fs::path outDir;
  RenderArguments arguments;
};

// The .apo (or .n3t) must have been baked around this m: its unit cube is m's.
Status checkTransformMatches(const fs::path& apoPath, const UnitCubeTransform& transform, const Scan& coarse) {
  const UnitCubeTransform expected = unitCubeAround(boundingBox(coarse.points.positions));
  const double scaleError = std::abs(expected.scale - transform.scale) / expected.scale;
  double offsetError = 0.0;
  for (int axis = 0; axis < 3; ++axis)
    offsetError = std::max(offsetError, std::abs(expected.offset[axis] - transform.offset[axis]));
  if (scaleError > 1e-5 || offsetError > 1e-5)
    return badInput("{}: baked around another coarse mesh: its unit-cube scale {} and offset ({}, {}, {}) are not m's ({} and "
                    "({}, {}, {}))",
                    apoPath.string(), transform.scale, transform.offset[0], transform.offset[1],
                    transform.offset[2], expected.scale, expected.offset[0], expected.offset[1], expected.offset[2]);
  return okStatus();
}

int runRender(RenderCommand command) {
  command.arguments.apply();
  const auto checked = check(command.arguments.options);
  if (!checked) return reportFailure(checked.error());
  const RenderOptions& options = **checked;
  auto drawn = readOctreeFile(command.apo);
  if (!drawn) return reportFailure(drawn.error());
  auto coarse = readScan(command.coarse);
  if (!coarse) return reportFailure(coarse.error());
  if (!coarse->isMesh()) return reportFailure(badInput("{}: m must be a triangle mesh", command.coarse.string()));
  if (Status s = checkTransformMatches(command.apo, drawn->transform(), *coarse); !s.ok()) return reportFailure(s.error());
  std::unique_ptr<Scan> detail;
  if (!command.detail.empty()) {
    auto read = readScan(command.detail);
    if (!read) return reportFailure(read.error());
    detail = std::make_unique<Scan>(std::move(read).value());
  }
  auto views = drawn->apo ? renderViews(detail.get(), *coarse, *drawn->apo, *checked)
                          : renderViews(detail.get(), *coarse, *drawn->n3tree, *checked);
  if (!views) return reportFailure(aboutInput(command.detail.empty() ? command.coarse : command.detail, views.error()));
  RenderFigures figures = measureViews(*views);
  if (drawn->n3tree) {
    figures.layout = "n3tree";
    figures.n3Size = drawn->n3tree->n;
  }
  if (Status s = writeRenderOutputs(command.outDir, *views, figures, options); !s.ok()) return reportFailure(s.error());
  if (detail)
    spdlog::info("render: {} views at {}px: APO {:.3f} deg mean from M's normals, m alone {:.3f} (x{:.2f}) -> {}",
                 views->size(), options.size, figures.apo.mean, figures.baseline.mean,
                 figures.apo.mean > 0 ? figures.baseline.mean / figures.apo.mean : 0.0, command.outDir.string());
  else
    spdlog::info("render: {} views at {}px -> {}", views->size(), options.size, command.outDir.string());
  if (options.timedFrames > 0)
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
  sub->add_option("--apo", command->apo, "The .apo file (apo bake), or the .n3t of `apo bake --layout n3tree`")->required();
  sub->add_option("--coarse", command->coarse, "m, the mesh the APO was baked around")->required();
  sub->add_option("--detail", command->detail, "M, the dense mesh or the points: the reference the metrics compare with");
  sub->add_option("-o,--out", command->outDir, "Output folder (PNGs, normal buffers, heat maps, render.json)")->required();
  addRenderOptions(*sub, command->arguments);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runRender(*command); }); });
}

}  // namespace apo::cli
