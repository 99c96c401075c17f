// render: draws m with the APO (paper section 5) next to M as ground truth,
// headless under OSMesa (Mesa llvmpipe, through adapters/osmesa), and
// measures how close they are. It reads the APO through format/ only.
// docs/render.md describes the passes and render.json.
#pragma once

#include "format/format.h"
#include "core/checked.h"
#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"
#include "core/viewer_scene.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace apo {

// ---- Images and buffers read back from a pass -----------------------------

// 8-bit RGBA, row-major, row 0 at the top.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4
};

// Per pixel: world-space unit normal (x, y, z) and coverage (1 where the
// surface covers the pixel, 0 elsewhere), row-major, row 0 at the top.
struct NormalBuffer {
  int width = 0, height = 0;
  std::vector<float> data;  // width * height * 4

  bool covered(std::size_t pixel) const { return data[4 * pixel + 3] > 0.5f; }
  Vec3f normal(std::size_t pixel) const { return {data[4 * pixel], data[4 * pixel + 1], data[4 * pixel + 2]}; }
};

// ---- Metrics (pure functions, no GL) ---------------------------------------

struct AngularStats {
  std::uint64_t pixels = 0;  // covered by both buffers
  double mean = 0.0, median = 0.0, p95 = 0.0, max = 0.0;  // degrees
};

// Angle in degrees between two normals (any length), by atan2; 180 when
// either is zero or not finite.
double angleDegrees(const Vec3f& testNormal, const Vec3f& referenceNormal);
// Angle in degrees between the two buffers' normals on every pixel covered by
// both; `perPixel` (optional) receives it per pixel, NaN where not compared.
AngularStats angularErrors(const NormalBuffer& test, const NormalBuffer& reference, std::vector<float>* perPixel = nullptr);
// The same statistics over a list of angles (for the figures over all views).
AngularStats statsOfAngles(std::vector<float> degrees);

// Over the object, not the empty background both images share: MAE and
// PSNR over the RGB of the pixels covered by either image, SSIM averaged
// over the windows that hold such a pixel.
struct ImageMetrics {
  std::uint64_t pixels = 0;         // covered by either
  double meanAbsoluteError = 0.0;   // out of 255
  double meanSquaredError = 0.0;    // out of 255^2
  double psnr = 0.0;                // dB; +infinity for identical images
  double ssim = 0.0;                // of the luminance (Wang et al. 2004, 8x8 windows, stride 4)
  double silhouetteMismatch = 0.0;  // pixels covered by exactly one / pixels covered by either
  // Over the pixels both cover: the part of the error shading can change
  // (the rest is m's silhouette, which no normal field moves).
  std::uint64_t insidePixels = 0;
  double meanAbsoluteErrorInside = 0.0;
};

ImageMetrics compareImages(const Image& test, const Image& reference, const NormalBuffer& testCoverage,
                           const NormalBuffer& referenceCoverage);
// Several views' metrics as one: MAE, MSE (so PSNR) and silhouette mismatch
// over all their pixels together, SSIM the mean over the views.
ImageMetrics poolImageMetrics(const std::vector<ImageMetrics>& views);

// Angular error as colours on a fixed scale (0 to `maxDegrees`, clamped),
// uncompared pixels transparent black.
Image errorHeatMap(const std::vector<float>& degrees, int width, int height, float maxDegrees);

Status writeImagePng(const std::filesystem::path& path, const Image& image);

// ---- Point-based LOD with object textures (Maximo et al.) -------------------

// An oriented disc. Its perpendicular error (Sequential Point Trees,
// Dachsbacher et al. 2003) is the thickness, along its normal, of the
// samples it stands for; its normal spread, the largest angle (radians)
// between its normal and theirs.
struct Surfel {
  Vec3f position = Vec3f::Zero(), normal = Vec3f::UnitZ();
  float radius = 0.0f;
  float perpendicularError = 0.0f;
  float normalSpread = 0.0f;
};

// What the LOD compares with its threshold (world units, projected to
// pixels): the perpendicular error, or, where larger, the disc's radius
// times its normal spread. A reference for normals needs the second: a
// coarse disc facing the eye is thin, yet shades every pixel it covers
// with one averaged normal (docs/render.md, "Point LOD").
inline float lodError(const Surfel& s) { return std::max(s.perpendicularError, s.radius * s.normalSpread); }

inline constexpr int kLodLevels = 4;
inline constexpr std::size_t kLodFanOut = 4;  // samples merged into one, at most

// What a patch (a sample of the coarsest level) holds in the object
// texture: its samples of levels 2, 1 and 0, in that order from `first`.
struct LodPatch {
  std::uint32_t first = 0;
  std::array<std::uint32_t, 3> count = {0, 0, 0};  // at most 4, 16, 64
  std::array<float, 3> maxError = {0, 0, 0};       // the largest lodError of each of those levels
};

// levels[0] are the points (discs of their local spacing, capped at twice
// its median), levels[k + 1] merge up to 4 adjacent samples of levels[k]
// (same side: normals less than 90 degrees apart; centres within twice the
// larger radius), grouped in Morton order. levels[3] are the patches sent to
// the GPU; objectTexture holds every patch's finer samples.
struct PointLod {
  std::array<std::vector<Surfel>, kLodLevels> levels;
  std::array<std::vector<std::uint32_t>, kLodLevels - 1> parent;  // each sample's in the next level
  std::vector<Surfel> objectTexture;
  std::vector<LodPatch> patches;  // one per levels[3] sample, in its order
};

// BadInput when the points have no normals.
Result<PointLod> buildPointLod(const PointSet& points);
// The sample standing for `children` (not empty): centre and normal
// averaged by disc area, the radius enclosing their discs, and the
// perpendicular error: the extent along the merged normal of every child's
// centre, disc tilt and own error.
Surfel mergeSurfels(const std::vector<Surfel>& children);
// A perpendicular error in pixels at `eye` (the geometry shader's
// projection).
float projectedLodError(float perpendicularError, const Vec3f& position, const Vec3f& eye, float pixelsPerWorldUnitAtOne);
// The level the geometry shader draws for a patch: the coarsest (3: the
// patch itself, then 2, 1) whose largest projected lodError is at most
// `thresholdPixels`, else 0, the points.
int chooseLodLevel(const Surfel& patch, const LodPatch& finer, const Vec3f& eye, float pixelsPerWorldUnitAtOne,
                   float thresholdPixels);

// ---- Cameras and passes (OSMesa) --------------------------------------------

// Above this share of m's area in its mean normal, m is one-sided (a scan of
// a room, a table, a terrain); a closed surface's mean normal is zero.
inline constexpr float kOneSidedShare = 0.25f;
// The side a one-sided m was scanned from: the unit area-weighted mean of
// its face normals when their sum is at least kOneSidedShare of its area,
// else zero (seen all round).
Vec3f scannedSide(const Scan& coarse);

// The views, first `count` of: the 6 axis directions, then the 8 cube
// diagonals; each looks at the centre of `box` from the distance at which the
// box's 8 corners, as projected in that view, fill the square image but for a
// margin (95% of the half-width at most, on the widest side). Given a scanned side (non-zero),
// the 14 directions are ordered by how squarely they look at it (stable:
// ties keep the order above), so that the first views see the scanned side
// (docs/render.md, "Views and passes").
std::vector<Camera> standardViews(const Aabb& box, int count, const Vec3f& scannedSide = Vec3f::Zero());

struct RenderOptions {
  int size = 1024;          // square images, pixels per side
  int views = 14;
  bool mipmapping = true;   // paper 5.2: stop where a cell is smaller than a pixel
  bool filtering = false;   // paper 5.3: trilinear blend of the 8 neighbouring cells
  int timedFrames = 5;      // frames timed per pass and view (their median); 0: no timing
  // M as points: drawn through the point LOD (Maximo et al.; docs/render.md
  // "Point LOD"), each patch at the coarsest level whose projected
  // perpendicular error is at most `lodThreshold` pixels; false: every
  // point's disc.
  bool pointLod = true;
  float lodThreshold = 0.01f;
};

// Usage error naming the option when one is out of range: size in [1, 16384]
// (llvmpipe's largest render target; a smaller GPU limit is refused when the
// context is made), views in [1, 14], timed frames in [0, 1000], the LOD
// threshold in (0, 1000] pixels.
template <>
Result<Checked<RenderOptions>> check(const RenderOptions& options);

// Texel reads per fragment of the APO pass, over the pixels m covers.
struct FetchCounts {
  std::uint64_t fragments = 0;
  double mean = 0.0;
  std::uint32_t max = 0;
};

// What each pass of a view costs: the median wall time of one frame (clear,
// draw, glFinish, so the rasteriser's work is in it) over the timed frames,
// 0 when not timed or not drawn; and the APO pass's texel reads, counted by
// a variant of its shader.
struct ViewCost {
  double referenceMilliseconds = 0.0, baselineMilliseconds = 0.0, apoMilliseconds = 0.0;
  FetchCounts apoFetches;
  // The reference pass's primitives: sent (M's triangles, its points, or
  // the point LOD's patches) and drawn (triangles, or surfels emitted).
  std::uint64_t referenceSent = 0, referenceDrawn = 0;
};

struct PassImages {
  Image shaded;
  NormalBuffer normals;
};

struct ViewImages {
  Camera camera;
  PassImages reference;  // M; empty when no M was given
  PassImages baseline;   // m with its own vertex normals
  PassImages apo;        // m with the APO
  ViewCost cost;
};

// Renders every view's passes. M, when given, is drawn with its interpolated
// vertex normals (computed if absent) when it is a mesh, as oriented discs of
// its points' spacing (surfels) with their normals when it is a point cloud;
// points without normals are BadInput.
// `onViewDone(done, total)`, when given, is called after each view.
Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const ApoTexture& apo,
                                            const Checked<RenderOptions>& options,
                                            const std::function<void(int, int)>& onViewDone = {});
// The same passes with m drawn through the same octree stored as an
// N^3-tree (format.h N3Tree): its walk down the indirection pool, its LOD
// pool for mip-mapping, its filtering (docs/render.md, "Layouts").
Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const N3Tree& tree,
                                            const Checked<RenderOptions>& options,
                                            const std::function<void(int, int)>& onViewDone = {});

// ---- The report's viewer (WebGL2) -------------------------------------------

// The passes as GLSL ES 3.00 for WebGL2: the OSMesa shaders' own texts
// (the APO walk above all, paper 5.1-5.3) with "#version 300 es" and
// precisions before them; the same uniforms, attributes (0: position, 1:
// normal, 2: radius) and outputs (0: shaded, 1: normal and coverage); plus
// the points as sprites and the heat map, which the viewer alone draws.
ViewerShaders webglShaders();
// The APO's uniforms for the WebGL2 APO pass (those the OSMesa pass sets
// from the texture, besides the camera's), set in `scene` with the texture.
void setWebglApo(const ApoTexture& apo, ViewerScene& scene);
// A mesh as the passes draw it: positions, vertex normals as drawn
// (vertexNormalsAsDrawn), indices.
ViewerGeometry webglMesh(const Scan& mesh);
// Points as the viewer draws them: the finest level of the point LOD
// (buildPointLod) of at most `maxPoints` samples, each with its disc's
// radius; the description says which level. BadInput without normals.
Result<ViewerGeometry> webglPoints(const PointSet& points, std::size_t maxPoints);

// ---- Figures of the rendered views (render.json) ---------------------------

struct PassFigures {
  AngularStats angles;  // against the reference's normals
  ImageMetrics image;   // against the reference's shaded image
};

struct ViewFigures {
  PassFigures apo, baseline;  // empty without a reference pass
  ViewCost cost;
};

// Over all views: the mean of the views' median frame times, and the texel
// reads of every fragment.
struct RenderCost {
  double referenceMilliseconds = 0.0, baselineMilliseconds = 0.0, apoMilliseconds = 0.0;
  FetchCounts apoFetches;
  // The reference's primitives sent (the same in every view) and drawn
  // (the mean over the views).
  std::uint64_t referenceSent = 0;
  double referenceDrawn = 0.0;
};

RenderCost totalCost(const std::vector<ViewImages>& views);

struct RenderFigures {
  // What the APO pass walked: "apo", or "n3tree" with its N (set by the
  // caller, which chose the layout).
  std::string layout = "apo";
  int n3Size = 0;
  std::vector<ViewFigures> views;
  AngularStats apo, baseline;  // over the pixels of all views
  ImageMetrics apoImage, baselineImage;  // pooled over the views
  RenderCost cost;
  // Per view, the APO's angle per pixel (NaN where not compared), for the
  // heat maps; empty without a reference pass.
  std::vector<std::vector<float>> apoAngles;
};

// Needs the reference pass in every view for the angles and image metrics;
// the cost is measured either way.
RenderFigures measureViews(const std::vector<ViewImages>& views);

// render.json (format_version 1, docs/render.md).
std::string renderReportJson(const RenderFigures& figures, const RenderOptions& options, const std::vector<Camera>& cameras);

// The heat maps' fixed colour scale, degrees.
inline constexpr float kHeatMapDegrees = 10.0f;

// Every view's files into `dir` (docs/render.md): viewNN_{reference,
// baseline,apo}.png and _normals.pfm, viewNN_apo_error.png (the reference
// and the heat maps only when there is a reference pass), and render.json.
Status writeRenderOutputs(const std::filesystem::path& dir, const std::vector<ViewImages>& views, const RenderFigures& figures,
                          const RenderOptions& options);

// A world-space normal buffer as a PFM image (Portable Float Map, RGB,
// little-endian, rows bottom-up as PFM requires): uncovered pixels are 0 0 0.
Status writeNormalsPfm(const std::filesystem::path& path, const NormalBuffer& normals);

// The shader's walk against format/'s lookupTexture: for every pixel m
// covers, the node the GLSL walk stopped at (read back) and the node the CPU
// walk reaches from the same unit-cube point (also read back, exact floats);
// the texel reads the fetch-counting variant counted on each pixel against
// those that walk needs (the grid entry, two per level descended, two at the
// node it stops at); the largest angle between the normal the shader decodes
// there and the CPU's decodeNormal of the same bytes (either encoding); and
// the largest angle between the filtered normal the shader draws (no
// mip-mapping) and lookupTextureFiltered (float rounding apart, they blend
// the same 8 normals with the same weights).
struct WalkAgreement {
  std::uint64_t pixels = 0, mismatches = 0, fetchMismatches = 0;
  double maxNormalDegrees = 0.0, maxFilteredDegrees = 0.0;
};
Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const ApoTexture& apo, int size, int views);
// The same for the N^3-tree against lookupN3Tree and lookupN3TreeFiltered:
// the place is the pool cell (or LOD cell) the walk stopped at, the reads
// N3Lookup::reads.
Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const N3Tree& tree, int size, int views);

// Fidelity to the scan itself, for point scans (whose M is a reconstruction
// and can be far from them), by the method of ../shared/tools/scan_eval.py.
// The probes: `count` points spread over m by area (fixed seed); the truth at
// each is the sum of the normals of the 8 scan points nearest to it; probes
// over holes (nearest scan point farther than 3 x the median of that
// distance) are left out, `drawn` says how many there were. Made once, they
// judge any number of APOs of that m. BadInput when the scan has no normals.
struct ScanProbes {
  std::uint64_t drawn = 0;
  std::vector<Vec3f> positions, coarseNormals, truths;  // the kept probes: m's interpolated normal there
};
Result<ScanProbes> probeAgainstScan(const PointSet& scan, const Scan& coarse, std::size_t count = 200000);
// The APO's filtered lookup against the truth at every kept probe (180
// degrees where it has no answer).
AngularStats apoErrorAgainstScan(const ScanProbes& probes, const ApoTexture& apo);

// The same figures per view: the kept probes a camera sees, those where m's
// interpolated normal faces the eye and no part of m lies between the probe
// and the eye (a ray cast through `coarse`, m's caster). A probe can be seen
// from several views. "pixels": the probes seen.
struct ViewAgainstScan {
  AngularStats coarse, apo;
};
struct ScanViews {
  std::vector<Camera> cameras;
  const RayCaster* coarse = nullptr;  // none: no per-view figures
};

// Everything against the scan: m's interpolated normal and the APO at the
// probes; and M (when it is a mesh): each scan point's distance to M (every
// n-th point, at most about `drawn` of them), as fractions of M's diagonal,
// and the angle between its normal and M's at the closest point; per view
// of `views` (ViewAgainstScan) when given m's caster.
struct ScanFidelity {
  std::uint64_t probes = 0, kept = 0;
  AngularStats coarse, apo;  // "pixels": probes kept
  AngularStats dense;        // "pixels": scan points
  double denseMeanDistance = 0.0, denseP95Distance = 0.0;
  std::vector<ViewAgainstScan> views;
};
Result<ScanFidelity> measureAgainstScan(const ScanProbes& probes, const PointSet& scan, const Scan& dense,
                                        const ApoTexture& apo, const ScanViews& views = {});
// The manifest's results.render.against_scan (docs/render.md).
std::string scanFidelityJson(const ScanFidelity& fidelity);

}  // namespace apo
