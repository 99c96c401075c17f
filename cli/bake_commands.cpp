// `apo bake` (M and m to the APO: scan.apo, texture.png, bake.json) and
// `apo lookup` (the APO's normals at given points, without the renderer).
#include "cli/command_support.h"
#include "cli/stage_options.h"
#include "core/file_io.h"
#include "core/geometry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <memory>

namespace apo::cli {
namespace fs = std::filesystem;
namespace {

struct BakeCommand {
  fs::path detail;
  fs::path coarse;
  fs::path outDir;
  BakeArguments arguments;
};

int runBake(const BakeCommand& command) {
  const auto options = check(command.arguments.options);
  if (!options) return reportFailure(options.error());
  const auto threads = limitThreads(command.arguments.threads);
  auto detail = readScan(command.detail);
  if (!detail) return reportFailure(detail.error());
  // Here, in place: bakeApo adds them to a copy of M (the 1.2M bunny's 21 MB
  // copied on one core).
  addVertexNormalsIfMissing(*detail);
  auto coarse = readScan(command.coarse);
  if (!coarse) return reportFailure(coarse.error());
  if (!coarse->isMesh())
    return reportFailure(badInput("{}: the coarse mesh m must be a triangle mesh, the file has only points",
                                  command.coarse.string()));
  auto bake = bakeApo(*detail, *coarse, *options);
  if (!bake) return reportFailure(aboutInput(command.detail, bake.error()));
  if (Status s = writeApoFile(command.outDir / "scan.apo", bake->texture); !s.ok()) return reportFailure(s.error());
  if (Status s = writeApoPng(command.outDir / "texture.png", bake->texture); !s.ok()) return reportFailure(s.error());
  if (bake->n3tree)
    if (Status s = writeN3TreeFile(command.outDir / "scan.n3t", *bake->n3tree); !s.ok()) return reportFailure(s.error());
  if (Status s = writeFileAtomically(command.outDir / "bake.json", bakeReportJson(bake->report)); !s.ok())
    return reportFailure(s.error());
  const BakeReport& r = bake->report;
  spdlog::info("bake: {} leaves, {} internal nodes, texture {}x{} ({} KiB), {} fallbacks of {} samples, {:.2f} s -> {}",
               r.leaves, r.internalNodes, r.textureWidth, r.textureHeight, r.textureBytes >> 10, r.fallbacks,
               r.hits + r.fallbacks, r.totalSeconds, (command.outDir / "scan.apo").string());
  if (r.n3tree)
    spdlog::info("bake: the N^3-tree of N = {}: {} levels, {} grids, {} KiB -> {}", r.n3tree->n, r.n3tree->levels,
                 r.n3tree->grids, r.n3tree->bytes >> 10, (command.outDir / "scan.n3t").string());
  return kExitSuccess;
}

struct LookupCommand {
  fs::path apo;
  fs::path points;
  fs::path output;
  fs::path coarse;  // m: needed by files whose leaves may show m's own normal
  int depth = 255;
  bool filter = false;
};

// m's normal at each point, when the file's leaves may show it or pick a
// side by it (versions 3 and 4).
Result<std::vector<Vec3f>> coarseNormalsFor(const LookupCommand& command, const OctreeFile& file,
                                            const std::vector<Vec3f>& points) {
  if (!file.needsCoarseNormals()) return std::vector<Vec3f>(points.size(), Vec3f::Zero());
  if (command.coarse.empty())
    return usageError("{}: some leaves show m's own normal or pick one of two sides by it{}: give m with --coarse",
                      command.apo.string(),
                      file.apo ? fmt::format(" (format version {})", file.apo->twoSidedLeaves > 0 ? 4 : 3) : std::string());
  auto coarse = readScan(command.coarse);
  if (!coarse) return coarse.error();
  if (!coarse->isMesh()) return badInput("{}: m must be a triangle mesh", command.coarse.string());
  return coarseNormalsAt(*coarse, points);
}

// The normal of either layout at a unit-cube point, plain or filtered.
std::optional<Vec3f> lookUp(const OctreeFile& file, const LookupCommand& command, const Vec3f& unit, const Vec3f& coarse) {
  if (file.apo) {
    const Lookup found = command.filter ? lookupTextureFiltered(*file.apo, unit, coarse)
                                        : lookupTexture(*file.apo, unit, command.depth, coarse);
    return found.found ? std::optional<Vec3f>(found.normal) : std::nullopt;
  }
  const N3Lookup found = command.filter ? lookupN3TreeFiltered(*file.n3tree, unit, coarse)
                                        : lookupN3Tree(*file.n3tree, unit, command.depth, coarse);
  return found.found ? std::optional<Vec3f>(found.normal) : std::nullopt;
}

int runLookup(const LookupCommand& command) {
  auto texture = readOctreeFile(command.apo);
  if (!texture) return reportFailure(texture.error());
  auto points = readScan(command.points);
  if (!points) return reportFailure(points.error());
  const std::vector<Vec3f>& positions = points->points.positions;
  const auto coarseNormals = coarseNormalsFor(command, *texture, positions);
  if (!coarseNormals) return reportFailure(coarseNormals.error());
  std::string text;
  std::uint64_t outside = 0;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    // The filtered lookup is the one the report, the measure against the
    // scan and the accuracy bench use (format/format.h).
    const Vec3f unit = texture->transform().toUnit(positions[i]);
    const std::optional<Vec3f> found = lookUp(*texture, command, unit, (*coarseNormals)[i]);
    outside += found ? 0 : 1;
    const Vec3f n = found.value_or(Vec3f::Zero());
    text += fmt::format("{:.9g} {:.9g} {:.9g}\n", n.x(), n.y(), n.z());
  }
  if (Status s = writeFileAtomically(command.output, text); !s.ok()) return reportFailure(s.error());
  spdlog::info("lookup: {} points, {} outside the octree -> {}", points->points.size(), outside, command.output.string());
  return kExitSuccess;
}

}  // namespace

void addBakeCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<BakeCommand>();
  CLI::App* sub = app.add_subcommand("bake", "Bake the octree texture (APO) of M's normals around m");
  sub->add_option("--detail", command->detail, "M: the dense mesh, or points with normals (scan.ply of apo ingest)")
      ->required();
  sub->add_option("--coarse", command->coarse, "m: the coarse triangle mesh (m.ply of apo simplify)")->required();
  sub->add_option("-o,--out", command->outDir, "Output folder (scan.apo, texture.png, bake.json; scan.n3t with --layout n3tree)")->required();
  addBakeOptions(*sub, command->arguments);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runBake(*command); }); });
}

void addLookupCommand(CLI::App& app, int& exitCode) {
  auto command = std::make_shared<LookupCommand>();
  CLI::App* sub = app.add_subcommand("lookup", "Decode the APO's normal at world-space points, as the shader would");
  sub->add_option("apo", command->apo, "The .apo file, or the .n3t of `apo bake --layout n3tree`")->required();
  sub->add_option("points", command->points, "Points, one `x y z` per line (.xyz)")->required();
  sub->add_option("-o,--out", command->output, "Output: one `nx ny nz` per point, `0 0 0` outside the octree")
      ->required();
  sub->add_option("--coarse", command->coarse,
                  "m (m.ply): where nodes show m's own normal or pick a side by it (format versions 3 and 4), its normal at the exact closest point");
  CLI::Option* depth = sub->add_option("--depth", command->depth, "Stop the walk at this depth")->capture_default_str();
  sub->add_flag("--filter", command->filter,
                "Trilinear filtering of the 8 neighbouring cells, as the shader with filtering on and the report's "
                "figures (paper 5.3)")
      ->excludes(depth);
  sub->callback([command, &exitCode] { exitCode = guarded([&] { return runLookup(*command); }); });
}

}  // namespace apo::cli
