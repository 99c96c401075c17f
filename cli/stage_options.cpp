#include "cli/stage_options.h"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <map>

namespace apo::cli {
namespace {

// "{a,b,c}" for the help: CLI11 would print the map's enum values, as
// characters for a uint8_t enum.
template <class Map>
std::string choicesOf(const Map& choices) {
  std::string names;
  for (const auto& [name, value] : choices) names += (names.empty() ? "" : ",") + name;
  return "{" + names + "}";
}

// The name `choices` gives `value`: an enum option's default as --help shows
// it, read from the options struct, where each default is written once.
template <class Map>
std::string nameOf(const Map& choices, const typename Map::mapped_type& value) {
  const auto named = std::find_if(choices.begin(), choices.end(), [&](const auto& choice) { return choice.second == value; });
  return named == choices.end() ? std::string() : named->first;
}

// A byte count as --budget reads it back: 3145728 -> "3MiB".
std::string byteSizeText(std::uint64_t bytes) {
  constexpr std::uint64_t kKiB = 1024, kMiB = kKiB * kKiB;
  if (bytes != 0 && bytes % kMiB == 0) return fmt::format("{}MiB", bytes / kMiB);
  if (bytes != 0 && bytes % kKiB == 0) return fmt::format("{}KiB", bytes / kKiB);
  return std::to_string(bytes);
}

// Unsigned options: CLI11 would read "-5" as 2^64 - 5.
const CLI::Validator kNotNegative = CLI::NonNegativeNumber.description("");

// The options added by `add` go under `group` in --help.
template <class Add>
void addGroup(CLI::App& app, const std::string& group, Add&& add) {
  const std::size_t before = app.get_options().size();
  add();
  std::vector<CLI::Option*> options = app.get_options(std::function<bool(CLI::Option*)>{});
  for (std::size_t i = before; i < options.size(); ++i) options[i]->group(group);
}

}  // namespace

void IngestArguments::apply() {
  if (sensor.size() == 3) options.sensorPosition = Vec3f(sensor[0], sensor[1], sensor[2]);
  options.orientation = orient == "mst" ? OrientationMethod::CgalMst : OrientationMethod::Propagation;
  options.meshInput = meshInput == "surface" ? MeshInput::Surface : meshInput == "scans" ? MeshInput::Scans : MeshInput::Auto;
}

void SimplifyArguments::apply() {
  options.policy = policy == "lt" ? SimplifyPolicy::LindstromTurk : SimplifyPolicy::GarlandHeckbert;
  options.quickFirstPass = !noQuickPass;
}

void RenderArguments::apply() {
  options.mipmapping = !noMipmapping;
  if (filterByDefault) options.filtering = !noFiltering;
  options.pointLod = !noPointLod;
}

void addIngestOptions(CLI::App& app, IngestArguments& arguments) {
  IngestOptions& o = arguments.options;
  app.add_flag("!--no-merge-duplicates", o.mergeDuplicates, "Keep exact duplicate points");
  app.add_flag("--remove-outliers", o.removeOutliers, "Statistical outlier removal (PCL)");
  app.add_option("--outlier-k", o.outlierNeighbours, "Neighbours for outlier statistics")->capture_default_str();
  app.add_option("--outlier-std", o.outlierStdDevs, "Keep points within mean + this many std-devs")->capture_default_str();
  app.add_option("--voxel", o.voxelSize, "Voxel downsampling size in scan units (0: off)")->capture_default_str();
  app.add_option("--max-scan-points", o.maxScanPoints,
                 "A binary PLY, LAS or LAZ point file above this many points is read a run at a time into at most this "
                 "many voxel centroids (0: always read whole)")
      ->capture_default_str();
  app.add_flag("!--no-normals", o.estimateNormals, "Do not estimate normals for point clouds without them");
  app.add_option("--normal-k", o.normalNeighbours, "Neighbours for normal estimation (0: chosen from the data)")
      ->capture_default_str();
  app.add_flag("--force-normals", o.forceNormalEstimation, "Re-estimate normals even when the file has them");
  app.add_option("--sensor", arguments.sensor, "Scanner position X Y Z: estimated normals face it (overrides the file's viewpoint)")
      ->expected(3);
  app.add_option("--mesh-input", arguments.meshInput,
                 "A mesh is one surface (M as it is) or a set of overlapping range scans (its points reconstructed); "
                 "auto decides from the overlap of its pieces")
      ->check(CLI::IsMember({"auto", "surface", "scans"}))
      ->capture_default_str();
  app.add_flag("!--no-grid-mesh", o.triangulateGrid,
               "Read an organised cloud (a depth frame) as loose points instead of triangulating its grid");
  app.add_flag("!--keep-winding", o.orientFaces,
               "Keep mesh faces as wound in the file (by default pieces wound inward are flipped)");
  app.add_option("--orient", arguments.orient,
                 "Orientation of estimated normals without a sensor: propagation (k-NN graph, fast) or mst (CGAL's)")
      ->check(CLI::IsMember({"propagation", "mst"}))
      ->capture_default_str();
}

void addReconstructOptions(CLI::App& app, ReconstructOptions& o) {
  const std::map<std::string, ReconstructionMethod> methods = {{"auto", ReconstructionMethod::Auto},
                                                               {"poisson", ReconstructionMethod::Poisson},
                                                               {"advancing-front", ReconstructionMethod::AdvancingFront},
                                                               {"scale-space", ReconstructionMethod::ScaleSpace}};
  app.add_option("--method", o.method,
                 "auto (Poisson for closed objects, advancing front for open scans), poisson, advancing-front, "
                 "scale-space")
      ->transform(CLI::CheckedTransformer(methods, CLI::ignore_case).description(choicesOf(methods)))
      ->default_str(nameOf(methods, o.method));
  app.add_option_function<std::uint64_t>(
         "--max-points", [&o](const std::uint64_t& value) { o.maxPoints = value; },
         "Reconstruct from a density-aware subsample above this many points (0: never)")
      ->check(kNotNegative)
      ->default_str(fmt::format("{} for poisson, {} for the others", defaultMaxPoints(ReconstructionMethod::Poisson),
                                defaultMaxPoints(ReconstructionMethod::AdvancingFront)));
  app.add_option("--trim", o.trim, "Poisson: drop triangles farther than this many average spacings from the points")
      ->capture_default_str();
  app.add_option("--radius-ratio", o.radiusRatioBound,
                 "Advancing front / scale space: drop triangles with a circumradius above this many spacings")
      ->capture_default_str();
  app.add_option("--min-component", o.minComponent, "Drop components below this fraction of the total area")
      ->capture_default_str();
  app.add_option("--spacing-k", o.spacingNeighbours, "Neighbours for the average spacing")->capture_default_str();
  app.add_option("--poisson-distance", o.poissonSpacing, "Poisson mesher distance bound in spacings (0: 0.375)")
      ->capture_default_str();
  app.add_option("--poisson-radius", o.poissonRadius, "Poisson triangle size bound in spacings (CGAL's default: 30)")
      ->capture_default_str();
  app.add_option("--scale", o.scaleSpaceScale, "Scale-space smoothing scale in spacings (0: 4)")->capture_default_str();
  app.add_option("--seed", o.seed, "Seed of CGAL's random generator")->check(kNotNegative)->capture_default_str();
}

void addSimplifyOptions(CLI::App& app, SimplifyArguments& arguments) {
  auto* faces =
      app.add_option("--faces", arguments.options.targetFaces, "Target face count")->check(kNotNegative)->capture_default_str();
  app.add_option("--ratio", arguments.options.ratio, "Target as a fraction of the input faces, in (0, 1]")->excludes(faces);
  app.add_option("--policy", arguments.policy, "gh: Garland-Heckbert quadrics (the paper's), lt: Lindstrom-Turk")
      ->check(CLI::IsMember({"gh", "lt"}))
      ->capture_default_str();
  app.add_flag("--no-quick-pass", arguments.noQuickPass,
               "CGAL's collapses only, without meshoptimizer's first pass on meshes above 200,000 faces");
}

void addBakeOptions(CLI::App& app, BakeArguments& arguments) {
  BakeOptions& o = arguments.options;
  app.add_option("--coarse-depth", o.coarseDepth, "Depth of the initial complete octree around m")->capture_default_str();
  app.add_option("--max-depth", o.maxDepth, "Deepest refinement")->capture_default_str();
  app.add_option("--budget", o.budget,
                 "Bytes the .apo file may take (3MiB, 500kB, ...; 0: no cap): the octree is refined where a split "
                 "removes the most error per byte until they are spent")
      ->transform(CLI::AsSizeValue(true))
      ->default_str(byteSizeText(o.budget));
  app.add_option("--error", o.error,
                 "L2,1 threshold, the paper's stopping rule (paper: 0.3, 0.1, 0.05; 0: none, the budget alone)")
      ->capture_default_str();
  app.add_option("--max-distance", o.maxDistance,
                 "Ray reach as a fraction of m's bounding-box diagonal (at least the cell's diagonal)")
      ->capture_default_str();
  app.add_option("--samples", o.samples, "Ray origins per leaf and triangle of m (1: the paper's, from the closest point to the cell centre; K > 1: stratified over the triangle in the cell)")->capture_default_str();
  app.add_option("--complete-depth", o.completeDepth, "Levels stored as a dense grid of roots (-1: the coarse depth)")
      ->capture_default_str();
  const std::map<std::string, NormalEncoding> encodings = {{"xyz8", NormalEncoding::Xyz8},
                                                           {"oct24", NormalEncoding::Oct24}};
  app.add_option("--normal-encoding", o.encoding, "xyz8 (the paper's 8 bits per axis) or oct24 (octahedral)")
      ->transform(CLI::CheckedTransformer(encodings, CLI::ignore_case).description(choicesOf(encodings)))
      ->default_str(normalEncodingName(o.encoding));
  app.add_flag("--one-sided", [&o](std::int64_t) { o.twoSidedLeaves = false; },
               "One normal per leaf, as in the paper: no two-sided leaves across thin parts");
  const std::map<std::string, TextureLayout> layouts = {{"apo", TextureLayout::Apo}, {"n3tree", TextureLayout::N3Tree}};
  app.add_option("--layout", o.layout,
                 "apo: the APO texture (paper section 4); n3tree: also GPU Gems 2's N^3-tree of the same octree "
                 "(scan.n3t), which the renders then draw")
      ->transform(CLI::CheckedTransformer(layouts, CLI::ignore_case).description(choicesOf(layouts)))
      ->default_str(nameOf(layouts, o.layout));
  app.add_option("--n3-size", o.n3Size, "N of the N^3-tree: 2 (an octree) or 4 (two levels per grid)")
      ->check(CLI::IsMember({2, 4}))
      ->capture_default_str();
  app.add_option("--brick-depth", o.brickDepth,
                 "Bake M's points brick by brick, the bricks being the octree's cells of this depth that hold m "
                 "(1: 8 at most, 2: 64, ...; 0: in one piece): only one brick's points and search structures are "
                 "held at a time, and the .apo is the same (docs/bake.md, \"Bricks\")")
      ->capture_default_str();
  app.add_option("--threads", arguments.threads, "Worker threads (0: all cores); the output does not depend on it")
      ->capture_default_str();
}

void addRenderOptions(CLI::App& app, RenderArguments& arguments) {
  RenderOptions& o = arguments.options;
  app.add_option("--size", o.size, "Image side in pixels")->capture_default_str();
  app.add_option("--views", o.views, "Views: the 6 axis directions, then the 8 cube diagonals")
      ->check(CLI::Range(1, 14))
      ->capture_default_str();
  app.add_flag("--no-mipmap", arguments.noMipmapping, "Walk to the leaves even where cells are smaller than a pixel");
  if (arguments.filterByDefault)
    app.add_flag("--no-filter", arguments.noFiltering,
                 "No trilinear filtering of the 8 neighbouring cells (paper 5.3): each leaf's normal as it is");
  else
    app.add_flag("--filter", o.filtering, "Trilinear filtering of the 8 neighbouring cells (paper 5.3)");
  app.add_option("--frames", o.timedFrames, "Frames timed per pass and view (median); 0: no timing")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  app.add_flag("--no-point-lod", arguments.noPointLod,
               "M as points: draw every point's disc instead of the point LOD (Maximo et al.)");
  app.add_option("--lod-threshold", o.lodThreshold,
                 "M as points: the point LOD draws each patch at the coarsest level whose error (the perpendicular "
                 "error, or radius x normal spread where larger) projects to at most this many pixels")
      ->capture_default_str();
}

void addExportOptions(CLI::App& app, ExportOptions& options) {
  app.add_option("--map-size", options.mapSize, "The GLB's normal map: texels per side (square)")
      ->check(CLI::Range(16, 16384))
      ->capture_default_str();
  app.add_option("--gutter", options.gutter, "Texels kept free round each triangle's patch of the normal map")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  app.add_flag("--draco", options.draco, "Compress the GLB's mesh with Draco (KHR_draco_mesh_compression)");
  app.add_option_function<std::string>(
         "--patch-size", [&options](const std::string& rule) { options.detailSizing = rule == "detail"; },
         "Each triangle's patch of the maps sized from the detail it covers (detail), or all at one texel density "
         "(uniform) [detail]")
      ->check(CLI::IsMember({"detail", "uniform"}));
  app.add_flag("--no-color{false}", options.color,
               "No base colour map in the GLB, even when the scan has colours (by default they are baked into one)");
}

void addStageOptionGroups(CLI::App& app, StageArguments& arguments) {
  app.add_option("--detail-source", arguments.detailSource,
                 "What the APO is baked from: mesh (the dense mesh M, reconstructed or the input mesh), points (the "
                 "scan's points with their normals, also the reference renders), or auto (a point scan: both baked, "
                 "the one closer to the scan's own points kept)")
      ->check(CLI::IsMember({"auto", "mesh", "points"}))
      ->capture_default_str();
  app.add_flag("--keep-georeference", arguments.keepGeoreference,
               "Write M.ply and m.ply in the scan's own (world) coordinates, in double, instead of its local frame "
               "(a scan far from zero is processed in a local frame whose origin the outputs record)");
  app.add_flag("--all-points", arguments.allPoints,
               "A scan above --max-scan-points: bake the APO from every point, not from the voxel centroids (a "
               "point store under OUTDIR/.scratch, removed once baked; the bake in bricks, --brick-depth or 2)");
  app.add_option("--point-normals", arguments.pointNormals,
                 "With --all-points, each point's normal: centroids (its nearest voxel centroid's, fitted over as "
                 "many centroids as the scan's normals; measured closer to the surface on noisy scans) or fitted (a "
                 "plane over its own nearest points at full density)")
      ->check(CLI::IsMember({"centroids", "fitted"}))
      ->capture_default_str();
  addGroup(app, "Ingest", [&] { addIngestOptions(app, arguments.ingest); });
  addGroup(app, "Reconstruct", [&] { addReconstructOptions(app, arguments.reconstruct); });
  addGroup(app, "Simplify", [&] { addSimplifyOptions(app, arguments.simplify); });
  addGroup(app, "Bake", [&] { addBakeOptions(app, arguments.bake); });
  addGroup(app, "Render", [&] { addRenderOptions(app, arguments.render); });
  addGroup(app, "Export", [&] {
    app.add_flag("--no-export", arguments.noExport, "No asset.glb (the export stage is skipped)");
    addExportOptions(app, arguments.exporting);
  });
  addGroup(app, "Report", [&] {
    app.add_flag("--no-viewer", arguments.noViewer,
                 "No viewer.html: the report without its interactive WebGL2 view (which carries the APO texture and "
                 "M, a few MB)");
  });
  app.add_option("--config", arguments.configFile,
                 "TOML file holding any of these options by name, without dashes (`faces = 5000`); the command line wins");
}

RunOptions runOptionsFrom(StageArguments arguments) {
  arguments.ingest.apply();
  arguments.simplify.apply();
  arguments.render.apply();
  RunOptions options;
  options.detailSource = arguments.detailSource == "points" ? DetailSource::Points
                         : arguments.detailSource == "mesh"  ? DetailSource::Mesh
                                                             : DetailSource::Auto;
  options.keepGeoreference = arguments.keepGeoreference;
  options.allPoints = arguments.allPoints;
  options.pointNormals = arguments.pointNormals == "fitted" ? PointNormals::Fitted : PointNormals::Centroids;
  options.ingest = arguments.ingest.options;
  options.reconstruct = arguments.reconstruct;
  options.simplify = arguments.simplify.options;
  options.bake = arguments.bake.options;
  options.render = arguments.render.options;
  options.exporting = arguments.exporting;
  options.exporting.enabled = !arguments.noExport;
  options.viewer = !arguments.noViewer;
  return options;
}

std::vector<std::string> givenStageArguments(const CLI::App& app) {
  // Not stage options: where outputs go, how the batch itself runs, and what
  // the worker is given anyway (its threads) or has already been applied
  // (the config file's options are among the given ones).
  static const std::vector<std::string> kNotPassed = {"--out",   "--jobs",  "--threads",   "--config", "--help", "--scan-timeout",
                                                      "--shard", "--merge", "--tasks",     "--partition", "--time", "--mem",
                                                      "--cpus",  "--dry-run"};
  std::vector<std::string> arguments;
  for (const CLI::Option* option : app.get_options()) {
    const std::string name = option->get_name();
    if (option->count() == 0 || name.rfind("--", 0) != 0 ||
        std::find(kNotPassed.begin(), kNotPassed.end(), name) != kNotPassed.end())
      continue;
    arguments.push_back(name);
    if (!isFlag(*option))
      for (const std::string& value : option->results()) arguments.push_back(value);
  }
  return arguments;
}

}  // namespace apo::cli
