// The bake: checks, the unit cube, the octree (section 3.1), the sampling
// (section 3.2) and the encoding (section 4), timed phase by phase.
#include "bake/bake.h"

#include "bake/bake_steps.h"
#include "bake/sampling.h"
#include "core/timing.h"

#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace apo {
namespace {

// Deeper cells than this are below float precision of the unit cube's
// coordinates in the shader (2^-16 against float's 2^-24 resolution near 1).
constexpr int kDeepestDepth = 16;
constexpr int kDeepestCoarseDepth = 10;  // a complete grid of 2^30 cells is the limit
constexpr int kMostSamples = 64;
constexpr int kDeepestBrickDepth = 4;  // 4,096 bricks; each loads its margin again

}  // namespace

template <>
Result<Checked<BakeOptions>> check(const BakeOptions& o) {
  if (o.coarseDepth < 0 || o.coarseDepth > kDeepestCoarseDepth)
    return usageError("--coarse-depth must be in [0, {}], got {}", kDeepestCoarseDepth, o.coarseDepth);
  if (o.maxDepth < o.coarseDepth || o.maxDepth > kDeepestDepth)
    return usageError("--max-depth must be in [--coarse-depth ({}), {}], got {}", o.coarseDepth, kDeepestDepth, o.maxDepth);
  if (!(o.error >= 0.0) || !std::isfinite(o.error))
    return usageError("--error must be positive (or 0: no threshold), got {}", o.error);
  if (o.budget == 0 && o.error == 0.0)
    return usageError("--budget 0 (no cap) needs an --error threshold, or the octree would grow to --max-depth everywhere");
  if (!(o.maxDistance > 0.0) || !std::isfinite(o.maxDistance))
    return usageError("--max-distance must be positive, got {}", o.maxDistance);
  if (o.n3Size != 2 && o.n3Size != 4) return usageError("--n3-size must be 2 or 4, got {}", o.n3Size);
  if (o.samples < 1 || o.samples > kMostSamples)
    return usageError("--samples must be in [1, {}], got {}", kMostSamples, o.samples);
  if (o.completeDepth < -1 || o.completeDepth > o.coarseDepth)
    return usageError("--complete-depth must be in [0, --coarse-depth ({})], got {}", o.coarseDepth, o.completeDepth);
  if (o.brickDepth < 0 || o.brickDepth > std::min(o.coarseDepth, kDeepestBrickDepth))
    return usageError("--brick-depth must be in [0, min(--coarse-depth ({}), {})], got {}", o.coarseDepth,
                      kDeepestBrickDepth, o.brickDepth);
  return Checked<BakeOptions>(o);
}

namespace {

bool allFinite(const std::vector<Vec3f>& vectors) {
  return std::all_of(vectors.begin(), vectors.end(), [](const Vec3f& v) { return v.allFinite(); });
}

}  // namespace

Status bake_steps::validateCoarseMesh(const Scan& coarse) {
  if (!coarse.isMesh())
    return badInput("the coarse mesh m has no triangles ({} points): bake needs a triangle mesh", coarse.points.size());
  if (!allFinite(coarse.points.positions)) return badInput("the coarse mesh m has a non-finite vertex");
  if (boundingBox(coarse.points.positions).diagonal() <= 0.0f) return badInput("the coarse mesh m has no extent");
  return okStatus();
}

Status validateBakeInputs(const Scan& detail, const Scan& coarse) {
  APO_RETURN_IF_ERROR(bake_steps::validateCoarseMesh(coarse));
  if (detail.points.size() == 0) return badInput("the detail surface M is empty");
  if (detail.points.normals.size() != detail.points.size())
    return badInput("the detail surface M has no normals: run `apo ingest` on a point cloud first");
  if (!allFinite(detail.points.positions) || !allFinite(detail.points.normals))
    return badInput("the detail surface M has a non-finite position or normal");
  return okStatus();
}

namespace {

Status validateSeams(const DetailSurface& detail, const CoarseSurface& coarse) {
  if (!coarse.mesh || !coarse.caster) return internalError("bake: the coarse surface is incomplete");
  if (!detail.detail || !detail.caster || !detail.closest) return internalError("bake: the detail surface is incomplete");
  return okStatus();
}

// The points' areas, once they are known; an Internal error unless there is
// one per point (or none).
Status pointAreasReady(const DetailSurface& detail) {
  if (detail.awaitPointAreas) APO_RETURN_IF_ERROR(detail.awaitPointAreas());
  const Scan& M = *detail.detail;
  if (!detail.pointAreas.empty() && detail.pointAreas.size() != M.points.size())
    return internalError("bake: {} point areas for {} points", detail.pointAreas.size(), M.points.size());
  return okStatus();
}

octree::CoarseMesh coarseInUnitCube(const Scan& coarse, const UnitCubeTransform& transform) {
  octree::CoarseMesh unit;
  unit.triangles = coarse.triangles;
  unit.positions.reserve(coarse.points.size());
  for (const Vec3f& p : coarse.points.positions) unit.positions.push_back(transform.toUnit(p));
  return unit;
}

// Where each of M's primitives lies on m: M's normal through the
// primitive's centre, cast both ways, meets m within `reach`; a primitive
// whose line misses m keeps its own position. The paper files M's triangles
// under the cells they overlap, but only cells around m are kept, so detail
// of M farther from m than a cell's width would never be seen by the error
// metric (the limitation its section 6 notes); filed where they project onto
// m, they are counted in the cells whose texels will show them.
struct Projection {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> coarseNormals;  // m's interpolated normal there; zero where the line misses m
  std::vector<char> met;             // whether the line met m
  std::vector<std::uint32_t> onTriangle;  // the triangle of m it met
};

Vec3f coarseNormalAt(const Scan& coarse, const std::vector<Vec3f>& normals, const RayHit& hit) {
  const Triangle& t = coarse.triangles[hit.primitive];
  const Vec3f n = (1.0f - hit.u - hit.v) * normals[t[0]] + hit.u * normals[t[1]] + hit.v * normals[t[2]];
  const float length = n.norm();
  return length > 0.0f ? Vec3f(n / length) : Vec3f(Vec3f::Zero());
}

Projection projectOntoCoarse(const std::vector<Vec3f>& centres, const std::vector<Vec3f>& normals,
                             const CoarseSurface& coarse, const std::vector<Vec3f>& coarseNormals, float reach) {
  Projection projection{std::vector<Vec3f>(centres.size()), std::vector<Vec3f>(centres.size(), Vec3f::Zero()),
                        std::vector<char>(centres.size(), 0), std::vector<std::uint32_t>(centres.size(), 0)};
  std::vector<Vec3f>& projected = projection.positions;
  constexpr std::size_t kChunk = 8192;
  tbb::parallel_for(std::size_t{0}, (centres.size() + kChunk - 1) / kChunk, [&](std::size_t chunk) {
    const std::size_t begin = chunk * kChunk, end = std::min(centres.size(), begin + kChunk);
    // All forward, then all backward: one stream of like rays after the
    // other, as the sampling casts them (sampling.cpp): the 1.2M bunny's
    // setup 0.306 -> 0.278 s.
    std::vector<Ray> rays;
    rays.reserve(2 * (end - begin));
    for (const float direction : {1.0f, -1.0f})
      for (std::size_t i = begin; i < end; ++i) {
        Ray ray;
        ray.origin = centres[i];
        ray.direction = direction * normals[i];
        ray.tFar = reach;
        rays.push_back(ray);
      }
    std::vector<RayHit> hits;
    coarse.caster->intersect(rays, hits);
    for (std::size_t i = begin; i < end; ++i) {
      const RayHit& forward = hits[i - begin];
      const RayHit& backward = hits[(end - begin) + (i - begin)];
      if (!forward.hit() && !backward.hit()) {
        projected[i] = centres[i];
        continue;
      }
      const bool useForward = forward.hit() && (!backward.hit() || forward.t <= backward.t);
      const RayHit& hit = useForward ? forward : backward;
      projected[i] = centres[i] + (useForward ? hit.t : -hit.t) * normals[i];
      projection.coarseNormals[i] = coarseNormalAt(*coarse.mesh, coarseNormals, hit);
      projection.met[i] = 1;
      projection.onTriangle[i] = hit.primitive;
    }
  });
  return projection;
}

// Where the line through a triangle's centre along its normal meets m, when
// its three corners' lines met the same triangle of m: the plane of that
// triangle, through the corners' projections, met inside it (the corners'
// hits span it). None otherwise (a corner missed m, or met another
// triangle: projecting the centre onto the plane through corners on two
// triangles of m cost bunny00 1.6% of its accuracy), nor when the plane is
// degenerate or nearly along the line: then a ray is cast.
std::optional<Vec3f> alongNormalOntoCorners(const Vec3f& centre, const Vec3f& normal, const Projection& corners,
                                            const Triangle& t) {
  if (!corners.met[t[0]] || !corners.met[t[1]] || !corners.met[t[2]]) return std::nullopt;
  if (corners.onTriangle[t[0]] != corners.onTriangle[t[1]] || corners.onTriangle[t[0]] != corners.onTriangle[t[2]])
    return std::nullopt;
  const Vec3f &q0 = corners.positions[t[0]], &q1 = corners.positions[t[1]], &q2 = corners.positions[t[2]];
  const Vec3f planeNormal = (q1 - q0).cross(q2 - q0);
  const float length = planeNormal.norm();
  if (!(length > 0.0f)) return std::nullopt;
  const float facing = normal.dot(planeNormal) / length;
  if (std::abs(facing) < 0.5f) return std::nullopt;
  return centre + ((q0 - centre).dot(planeNormal) / length / facing) * normal;
}

// A triangle's area, centre and unit normal (zero when it has no area).
struct TriangleLine {
  float area;
  Vec3f centre, normal;
};

TriangleLine lineOf(const Scan& mesh, const Triangle& t) {
  const Vec3f &a = mesh.points.positions[t[0]], &b = mesh.points.positions[t[1]], &c = mesh.points.positions[t[2]];
  const Vec3f areaNormal = 0.5f * (b - a).cross(c - a);
  const float area = areaNormal.norm();
  return {area, (a + b + c) / 3.0f, area > 0.0f ? Vec3f(areaNormal / area) : Vec3f(Vec3f::Zero())};
}

// M for the error metric (octree_build.h): in unit-cube coordinates, each
// triangle shifted and each point moved to where it projects onto m.
Result<octree::DetailPrimitives> detailForErrorMetric(const DetailSurface& surface, const CoarseSurface& coarse,
                                                      const bake_steps::Frame& frame) {
  const Scan& M = *surface.detail;
  if (!M.isMesh()) {
    APO_RETURN_IF_ERROR(pointAreasReady(surface));  // computed meanwhile, maybe
    bake_steps::OrderFreeSum total;
    for (const float area : surface.pointAreas) total.add(area);
    const double meanArea =
        surface.pointAreas.empty() ? 1.0 : total.value() / static_cast<double>(surface.pointAreas.size());
    return bake_steps::pointsForErrorMetric(M.points, surface.pointAreas, meanArea, coarse, frame);
  }
  const std::vector<Vec3f>& coarseNormals = frame.coarseNormals;
  const float reach = frame.reach;
  const UnitCubeTransform& transform = frame.transform;
  // M's vertices along their normals onto m: m's normals there (for the
  // metric's comparison with m), and each triangle's shift wherever its
  // three corners met one triangle of m (alongNormalOntoCorners). Only the
  // other triangles cast rays from their centres (casting from every
  // centre took 6.3 s of the 7.2M-triangle torus's setup).
  const Projection corners = projectOntoCoarse(M.points.positions, M.points.normals, coarse, coarseNormals, reach);
  // Each triangle's area and shift on every core; the areas then summed,
  // and the triangles left to cast listed, in order (the loop on one core
  // took 0.05 s of the 1.2M bunny's setup).
  std::vector<float> areas(M.triangles.size());
  std::vector<char> shifted(M.triangles.size(), 0);
  std::vector<Vec3f> shifts(M.triangles.size(), Vec3f::Zero());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, M.triangles.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const TriangleLine line = lineOf(M, M.triangles[i]);
      areas[i] = line.area;
      if (const auto projected = alongNormalOntoCorners(line.centre, line.normal, corners, M.triangles[i])) {
        shifts[i] = transform.toUnit(*projected) - transform.toUnit(line.centre);
        shifted[i] = 1;
      }
    }
  });
  double totalArea = 0.0;
  for (const float area : areas) totalArea += area;
  std::vector<Vec3f> centres, normals;
  std::vector<std::size_t> fromCentre;
  for (std::size_t i = 0; i < M.triangles.size(); ++i) {
    if (shifted[i]) continue;
    // Made again for the triangles left (a fifth of the bunny's): keeping
    // every triangle's centre and normal from the pass above would take
    // 24 bytes each.
    const TriangleLine line = lineOf(M, M.triangles[i]);
    fromCentre.push_back(i);
    centres.push_back(line.centre);
    normals.push_back(line.normal);
  }
  const std::vector<Vec3f> projected = projectOntoCoarse(centres, normals, coarse, coarseNormals, reach).positions;
  for (std::size_t k = 0; k < fromCentre.size(); ++k)
    shifts[fromCentre[k]] = transform.toUnit(projected[k]) - transform.toUnit(centres[k]);
  std::vector<Vec3f> positions;
  positions.reserve(M.points.size());
  for (const Vec3f& p : M.points.positions) positions.push_back(transform.toUnit(p));
  const double meanUnitArea = totalArea / static_cast<double>(M.triangles.size()) * transform.scale * transform.scale;
  return octree::DetailPrimitives::ofMesh(positions, M.triangles, M.points.normals,
                                          meanUnitArea > 0.0 ? 1.0 / meanUnitArea : 1.0, shifts, corners.coarseNormals);
}

// The most texels whose .apo file fits `budget` bytes (0: no cap), counting
// the 160-byte header of versions 2 and 3 (a budgeted bake may let leaves
// show m's normals: version 3).
std::uint64_t budgetTexels(std::uint64_t budget) {
  if (budget == 0) return 0;
  std::uint64_t fits = 0, over = std::uint64_t{1} << 32;  // apoFileBytes grows with the texels
  while (over - fits > 1) {
    const std::uint64_t middle = fits + (over - fits) / 2;
    (apoFileBytes(middle, true) <= budget ? fits : over) = middle;
  }
  return std::max<std::uint64_t>(fits, 1);
}

void countNodes(const Octree& octree, BakeReport& report) {
  for (const OctreeNode& node : octree.nodes) {
    if (report.nodesPerDepth.size() <= node.depth) report.nodesPerDepth.resize(node.depth + 1, 0);
    ++report.nodesPerDepth[node.depth];
    ++(node.isLeaf() ? report.leaves : report.internalNodes);
    report.refinement.internalNodesShowingCoarse += !node.isLeaf() && node.coarseNormal ? 1 : 0;
  }
}

// format's ParallelRanges on TBB's threads.
void onEveryCore(std::size_t count, const std::function<void(std::size_t, std::size_t)>& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) { body(range.begin(), range.end()); });
}

}  // namespace

namespace bake_steps {

Frame frameOf(const Scan& coarse, const BakeOptions& options) {
  Frame frame;
  frame.box = boundingBox(coarse.points.positions);
  frame.transform = unitCubeAround(frame.box);
  frame.coarseUnit = coarseInUnitCube(coarse, frame.transform);
  frame.coarseNormals = vertexNormalsAsDrawn(coarse);
  frame.reach = static_cast<float>(options.maxDistance * frame.box.diagonal());
  frame.completeDepth = options.completeDepth < 0 ? options.coarseDepth : options.completeDepth;
  frame.maxTexels = budgetTexels(options.budget);
  return frame;
}

// Leaves show m's normals where those are closer, or two normals where m's
// sides part M's, with a budget; with none, the tree is the paper's.
octree::BuildSettings buildSettingsOf(const BakeOptions& options, const Frame& frame) {
  return {options.coarseDepth, options.maxDepth,   options.error,
          frame.maxTexels,     frame.completeDepth, options.budget > 0,
          options.budget > 0 && options.twoSidedLeaves};
}

void OrderFreeSum::add(float value) {
  if (!std::isfinite(value)) {
    nonFinite_ = true;
    return;
  }
  int exponent = 0;
  const float mantissa = std::frexp(value, &exponent);  // value = mantissa 2^exponent, |mantissa| in [0.5, 1)
  bins_[static_cast<std::size_t>(exponent - kLowestExponent)] += static_cast<std::int64_t>(std::ldexp(mantissa, 24));
}

void OrderFreeSum::add(const OrderFreeSum& other) {
  for (std::size_t i = 0; i < bins_.size(); ++i) bins_[i] += other.bins_[i];
  nonFinite_ = nonFinite_ || other.nonFinite_;
}

double OrderFreeSum::value() const {
  if (nonFinite_) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (std::size_t i = 0; i < bins_.size(); ++i)
    sum += std::ldexp(static_cast<double>(bins_[i]), static_cast<int>(i) + kLowestExponent - 24);
  return sum;
}

octree::DetailPrimitives pointsForErrorMetric(const PointSet& points, const std::vector<float>& areas, double meanArea,
                                              const CoarseSurface& coarse, const Frame& frame) {
  octree::DetailPrimitives detail;
  detail.normals = points.normals;
  Projection projection = projectOntoCoarse(points.positions, detail.normals, coarse, frame.coarseNormals, frame.reach);
  detail.weights = areas.empty() ? std::vector<float>(points.size(), 1.0f) : areas;
  detail.positions.reserve(points.size());
  for (const Vec3f& p : projection.positions) detail.positions.push_back(frame.transform.toUnit(p));
  detail.coarseNormals = std::move(projection.coarseNormals);
  detail.coarseKnown = true;
  if (meanArea > 0.0)
    for (float& w : detail.weights) w = static_cast<float>(w / meanArea);
  return detail;
}

Status checkBudgetMet(const octree::BuiltOctree& built, const BakeOptions& options) {
  if (options.budget > 0 && built.refinement.texels > budgetTexels(options.budget))
    return usageError("--budget {} bytes is below the {} bytes of the octree's complete levels (--coarse-depth {}): raise "
                      "--budget or lower --coarse-depth",
                      options.budget, apoFileBytes(built.refinement.texels, true), options.coarseDepth);
  return okStatus();
}

RefinementReport refinementReport(const octree::RefinementOutcome& outcome, const BakeOptions& options) {
  RefinementReport report;
  report.budgetBytes = options.budget;
  report.errorThreshold = options.error;
  report.stoppedBy = outcome.stoppedBy;
  report.l21 = outcome.error;
  report.rmsDegrees = outcome.rmsDegrees();
  report.leavesShowingCoarse = outcome.leavesShowingCoarse;
  report.twoSidedLeaves = outcome.twoSidedLeaves;
  report.leavesAtMaxDepth = outcome.leavesAtMaxDepth;
  report.sumDepth = outcome.sumDepth;
  return report;
}

Status encodeInto(Bake& bake, octree::BuiltOctree built, const Scan& coarse, const BakeOptions& options,
                  const Frame& frame) {
  BakeReport& report = bake.report;
  const Stopwatch phase;
  auto texture = encodeApo(built.octree, frame.completeDepth, options.encoding,
                           static_cast<std::uint8_t>(options.coarseDepth), static_cast<std::uint8_t>(options.maxDepth),
                           onEveryCore);
  if (!texture) return texture.error();
  bake.texture = std::move(texture).value();
  bake.texture.origin = coarse.origin;  // m's local frame, for readers of the file
  report.seconds.encode = phase.seconds();

  bake.octree = std::move(built.octree);
  countNodes(bake.octree, report);
  report.textureWidth = bake.texture.width;
  report.textureHeight = bake.texture.height;
  report.textureBytes = bake.texture.texels.size();
  if (options.layout == TextureLayout::N3Tree) {
    const Stopwatch building;
    auto tree = buildN3Tree(bake.octree, options.n3Size, options.encoding);
    if (!tree) return tree.error();
    tree->origin = bake.texture.origin;
    report.n3tree = N3TreeReport{tree->n, tree->levels, tree->usedGrids, tree->poolSize(), tree->twoSidedLeaves,
                                 tree->textureBytes(), building.seconds()};
    bake.n3tree = std::move(tree).value();
  }
  return okStatus();
}

}  // namespace bake_steps

// Rough shares of a bake's time (measured on the bumpy bunny): setup 5%,
// octree build 55%, sampling 35%, encoding 5%; only for progress.
constexpr double kBuildStart = 0.05, kSamplingStart = 0.6, kEncodingStart = 0.95;

Result<Bake> bakeWith(const DetailSurface& detail, const CoarseSurface& coarseSurface,
                      const Checked<BakeOptions>& checkedOptions, const ProgressCallback& onProgress) {
  const BakeOptions& options = *checkedOptions;
  APO_RETURN_IF_ERROR(validateSeams(detail, coarseSurface));
  APO_RETURN_IF_ERROR(validateBakeInputs(*detail.detail, *coarseSurface.mesh));
  const Scan& coarse = *coarseSurface.mesh;
  Stopwatch total;
  Bake bake;
  BakeReport& report = bake.report;
  report.detailKind = detail.detail->isMesh() ? "mesh" : "points";
  report.detailPrimitives = detail.detail->isMesh() ? detail.detail->triangles.size() : detail.detail->points.size();
  report.coarseTriangles = coarse.triangles.size();

  Stopwatch phase;
  const bake_steps::Frame frame = bake_steps::frameOf(coarse, options);
  octree::BuiltOctree built;
  {
    auto metricInput = detailForErrorMetric(detail, coarseSurface, frame);
    if (!metricInput) return metricInput.error();
    report.seconds.setup += phase.seconds();
    reportProgress(onProgress, kBuildStart);
    phase = Stopwatch();
    built = octree::buildOctree(frame.coarseUnit, *metricInput, bake_steps::buildSettingsOf(options, frame));
  }
  APO_RETURN_IF_ERROR(bake_steps::checkBudgetMet(built, options));
  report.refinement = bake_steps::refinementReport(built.refinement, options);
  built.octree.transform = frame.transform;
  report.seconds.build = phase.seconds();
  const int sumDepth = built.refinement.sumDepth;
  spdlog::info("bake: octree of {} nodes built in {:.2f} s{}", built.octree.nodes.size(), report.seconds.build,
               sumDepth > 0 ? fmt::format(" (M's triangles clipped once at depth {})", sumDepth) : std::string());

  reportProgress(onProgress, kSamplingStart);
  phase = Stopwatch();
  APO_RETURN_IF_ERROR(detail.caster->ready());
  APO_RETURN_IF_ERROR(detail.closest->ready());
  if (const double waited = phase.seconds(); waited >= 0.01)
    spdlog::info("bake: the sampling waited {:.2f} s for M's ray caster", waited);
  // With a budget, internal nodes may show m's normals, as leaves may.
  const sampling::SamplingSettings sampling{options.samples, frame.reach, options.budget > 0};
  const sampling::SampleCounts counts = sampling::sampleNormalField(
      built, {&frame.coarseUnit, &coarse.points.positions, &frame.coarseNormals}, detail, sampling,
      [&](std::size_t done, std::size_t total) {
        reportProgress(onProgress, kSamplingStart + (kEncodingStart - kSamplingStart) * static_cast<double>(done) /
                                                        static_cast<double>(total));
      });
  if (counts.unanswered > 0)
    return internalError("bake: the closest-point search over M failed for {} of {} samples whose rays missed M",
                         counts.unanswered, counts.unanswered + counts.fallbacks);
  report.rays = counts.rays;
  report.hits = counts.hits;
  report.fallbacks = counts.fallbacks;
  report.seconds.sample = phase.seconds();
  spdlog::info("bake: {} rays, {} samples hit M, {} by the closest point, in {:.2f} s", counts.rays, counts.hits,
               counts.fallbacks, report.seconds.sample);

  APO_RETURN_IF_ERROR(bake_steps::encodeInto(bake, std::move(built), coarse, options, frame));
  report.totalSeconds = total.seconds();
  report.peakMemoryBytes = peakResidentBytes();
  reportProgress(onProgress, 1.0);
  return bake;
}

}  // namespace apo
