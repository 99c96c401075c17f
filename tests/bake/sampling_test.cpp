// The sampling (paper 3.2) against independent references: the same bake
// through brute-force ray casting and closest points must match Embree and
// FLANN, and the leaf normals must match the normal field integrated over
// each leaf's part of m.
#include "bake/bake.h"
#include "bake/sampling.h"

#include "adapters/flann/flann_search.h"
#include "ingest/ingest.h"
#include "pipeline/bake_seams.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>

namespace apo {
namespace {

using test::degreesBetween;

// The paper's threshold, no budget: a tree that float (Embree) and double
// (brute force) seams agree on. (The budget's order of splits follows
// differences of a few ulps in the error metric.)
BakeOptions smallOptions() {
  BakeOptions options;
  options.coarseDepth = 3;
  options.maxDepth = 6;
  options.budget = 0;
  options.error = 0.05;
  return options;
}

double worstLeafDifference(const Octree& a, const Octree& b) {
  EXPECT_EQ(a.nodes.size(), b.nodes.size());
  double worst = 0.0;
  for (std::size_t n = 0; n < std::min(a.nodes.size(), b.nodes.size()); ++n)
    worst = std::max(worst, degreesBetween(a.nodes[n].normal, b.nodes[n].normal));
  return worst;
}

TEST(Sampling, EmbreeAndFlannAgreeWithBruteForceOnAMesh) {
  const test::BumpySphere shape;
  const Scan coarse = test::makeIcosphere(2);
  const Scan detail = shape.mesh(4);
  auto production = bakeApo(detail, coarse, test::checked(smallOptions()));
  ASSERT_TRUE(production.ok()) << production.error().message;
  const test::BruteForceCaster caster(detail);
  const test::BruteForceClosestPoint closest(detail);
  DetailSurface surface;
  surface.detail = &detail;
  surface.caster = &caster;
  surface.closest = &closest;
  const test::BruteForceCaster coarseCaster(coarse);
  auto reference = bakeWith(surface, {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  EXPECT_EQ(production->report.hits, reference->report.hits);
  EXPECT_EQ(production->report.fallbacks, reference->report.fallbacks);
  // Float (Embree) against double (brute force) interpolation.
  EXPECT_LT(worstLeafDifference(production->octree, reference->octree), 0.05);
}

TEST(Sampling, EmbreeDiscsAgreeWithBruteForceOnPoints) {
  const test::BumpySphere shape;
  const Scan coarse = test::makeIcosphere(2);
  Scan points = shape.mesh(4);
  points.triangles.clear();  // the vertices, with their exact normals
  auto production = bakeApo(points, coarse, test::checked(smallOptions()));
  ASSERT_TRUE(production.ok()) << production.error().message;
  const std::vector<float> radii = discRadii(points.points).value();
  const test::BruteForceCaster caster(points, radii);
  const test::BruteForceClosestPoint closest(points);
  DetailSurface surface;
  surface.detail = &points;
  surface.caster = &caster;
  surface.closest = &closest;
  for (const float r : radii) surface.pointAreas.push_back(r * r);
  const test::BruteForceCaster coarseCaster(coarse);
  auto reference = bakeWith(surface, {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  EXPECT_EQ(production->report.hits, reference->report.hits);
  // Neighbouring discs overlap: where two are hit at nearly the same t, float
  // and double may pick different ones, whose normals differ by the angle
  // between neighbouring points (~1 degree here). Most leaves agree exactly.
  const Octree& a = production->octree;
  const Octree& b = reference->octree;
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  std::size_t same = 0;
  for (std::size_t n = 0; n < a.nodes.size(); ++n) same += degreesBetween(a.nodes[n].normal, b.nodes[n].normal) < 0.01 ? 1 : 0;
  EXPECT_GT(same, a.nodes.size() * 95 / 100);
  EXPECT_LT(worstLeafDifference(a, b), 2.0);
}

// pipeline's bakeApo computes a point scan's areas beside the projection onto
// m (DetailSurface::awaitPointAreas): given late, they bake the same bytes;
// the wait's error, or a wrong count, fails the bake.
TEST(Sampling, PointAreasGivenLaterBakeTheSameAndTheirFailureFailsTheBake) {
  const test::BumpySphere shape;
  const Scan coarse = test::makeIcosphere(2);
  Scan points = shape.mesh(3);
  points.triangles.clear();
  const std::vector<float> radii = discRadii(points.points).value();
  std::vector<float> areas;
  for (const float r : radii) areas.push_back(r * r);
  const test::BruteForceCaster caster(points, radii);
  const test::BruteForceClosestPoint closest(points);
  const test::BruteForceCaster coarseCaster(coarse);
  const auto surfaceWith = [&](std::function<Status(DetailSurface&)> await) {
    auto surface = std::make_unique<DetailSurface>();
    surface->detail = &points;
    surface->caster = &caster;
    surface->closest = &closest;
    DetailSurface* s = surface.get();
    if (await) surface->awaitPointAreas = [s, await] { return await(*s); };
    else surface->pointAreas = areas;
    return surface;
  };
  auto given = bakeWith(*surfaceWith(nullptr), {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_TRUE(given.ok()) << given.error().message;
  int waits = 0;
  auto late = bakeWith(*surfaceWith([&](DetailSurface& s) {
                         ++waits;
                         s.pointAreas = areas;
                         return okStatus();
                       }),
                       {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_TRUE(late.ok()) << late.error().message;
  EXPECT_EQ(waits, 1);
  EXPECT_EQ(late->texture.texels, given->texture.texels);
  // Areas that differ change the bake: the late ones are really used.
  auto reweighted = bakeWith(*surfaceWith([&](DetailSurface& s) {
                           s.pointAreas = areas;
                           for (std::size_t i = 0; i < s.pointAreas.size() / 2; ++i) s.pointAreas[i] *= 100.0f;
                           return okStatus();
                         }),
                         {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_TRUE(reweighted.ok()) << reweighted.error().message;
  EXPECT_NE(reweighted->texture.texels, given->texture.texels);

  auto failed = bakeWith(*surfaceWith([](DetailSurface&) -> Status { return internalError("the k-d tree failed"); }),
                         {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().message, "the k-d tree failed");
  auto tooFew = bakeWith(*surfaceWith([&](DetailSurface& s) {
                           s.pointAreas.assign(areas.size() - 1, 1.0f);
                           return okStatus();
                         }),
                         {&coarse, &coarseCaster}, test::checked(smallOptions()));
  ASSERT_FALSE(tooFew.ok());
  EXPECT_NE(tooFew.error().message.find("point areas for"), std::string::npos) << tooFew.error().message;
}

// m: one large triangle in z = 0. M: a fine grid just above it whose normal
// field tilts along x, n(x) = normalize(sin(3 x), 0, 1). The truth for a leaf
// is n averaged over the part of m inside it, integrated densely here.
struct TiltedField {
  Scan coarse, detail;

  static Vec3f normalAt(float x) { return Vec3f(std::sin(3.0f * x), 0.0f, 1.0f).normalized(); }

  TiltedField() {
    coarse.points.positions = {{-1, -1, 0}, {3, -1, 0}, {-1, 3, 0}};
    coarse.points.normals.assign(3, Vec3f::UnitZ());
    coarse.triangles = {{0, 1, 2}};
    const int n = 200;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const float x = -1.0f + 4.0f * i / n, y = -1.0f + 4.0f * j / n;
        detail.points.positions.emplace_back(x, y, 0.005f);
        detail.points.normals.push_back(normalAt(x));
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const auto v = [n](int a, int b) { return static_cast<std::uint32_t>(b * (n + 1) + a); };
        detail.triangles.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
        detail.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
      }
  }
};

// Mean over the leaves of the angle between the leaf's normal and the field
// averaged over m inside the leaf (dense samples of the triangle).
double meanErrorAgainstIntegratedField(const Bake& bake, const TiltedField& field) {
  const Octree& octree = bake.octree;
  std::vector<Vec3f> centre(octree.nodes.size(), Vec3f::Constant(0.5f));
  std::vector<float> width(octree.nodes.size(), 1.0f);
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    std::uint32_t child = octree.nodes[n].firstChild;
    for (int c = 0; c < 8; ++c)
      if (octree.nodes[n].childMask & (1u << c)) {
        centre[child] = childCentre(centre[n], width[n], c);
        width[child++] = 0.5f * width[n];
      }
  }
  double sum = 0.0;
  int leaves = 0;
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    if (!octree.nodes[n].isLeaf()) continue;
    Vec3f integrated = Vec3f::Zero();
    const int steps = 60;
    for (int i = 0; i < steps; ++i)
      for (int j = 0; j < steps; ++j) {
        const Vec3f unit = centre[n] + width[n] * Vec3f((i + 0.5f) / steps - 0.5f, (j + 0.5f) / steps - 0.5f, 0.0f);
        const Vec3f world = octree.transform.toWorld(Vec3f(unit.x(), unit.y(), octree.transform.toUnit(Vec3f::Zero()).z()));
        if (world.x() < -1.0f || world.y() < -1.0f || world.x() + world.y() > 2.0f) continue;  // outside m
        integrated += TiltedField::normalAt(world.x());
      }
    if (integrated.squaredNorm() == 0.0f) continue;
    sum += degreesBetween(octree.nodes[n].normal, integrated);
    ++leaves;
  }
  return sum / leaves;
}

TEST(Sampling, SeveralOriginsPerTriangleFollowTheFieldBetterThanOne) {
  const TiltedField field;
  BakeOptions options;
  options.coarseDepth = 2;
  options.maxDepth = 2;  // large cells, one large triangle: the case K > 1 is for
  options.samples = 1;
  auto paper = bakeApo(field.detail, field.coarse, test::checked(options));
  ASSERT_TRUE(paper.ok()) << paper.error().message;
  options.samples = 16;
  auto stratified = bakeApo(field.detail, field.coarse, test::checked(options));
  ASSERT_TRUE(stratified.ok());
  const double paperError = meanErrorAgainstIntegratedField(*paper, field);
  const double stratifiedError = meanErrorAgainstIntegratedField(*stratified, field);
  EXPECT_LT(stratifiedError, paperError / 3.0) << "1 origin: " << paperError << " deg, 16: " << stratifiedError;
  EXPECT_LT(stratifiedError, 2.0);  // 16 origins over a field turning ~3 rad per cell
  EXPECT_EQ(paper->report.rays, 2 * paper->report.leaves);  // one triangle, one origin per leaf
}

}  // namespace
}  // namespace apo
