// orientFacesOutward on shapes whose outside is known: closed spheres, a
// multi-view soup of a sphere's caps, and a lone sheet.
#include "ingest/face_orientation.h"

#include "adapters/embree/embree_ray_caster.h"
#include "core/mesh_edit.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

namespace apo::faces {
namespace {

Scan flipped(Scan mesh) {
  for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

// Appends `part` to `whole` as a separate piece (its own vertices), moved by `shift`.
void append(Scan& whole, const Scan& part, const Vec3f& shift = Vec3f::Zero()) {
  const auto base = static_cast<std::uint32_t>(whole.points.size());
  for (const Vec3f& p : part.points.positions) whole.points.positions.push_back(p + shift);
  for (const Triangle& t : part.triangles) whole.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

// The fraction of triangles whose normal points away from the origin
// (`centre`), the truth for a sphere.
double outwardFraction(const Scan& mesh, const Vec3f& centre = Vec3f::Zero()) {
  std::size_t outward = 0;
  for (const Triangle& t : mesh.triangles) {
    const auto& p = mesh.points.positions;
    const Vec3f n = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    outward += n.dot(p[t[0]] - centre) > 0.0f;
  }
  return static_cast<double>(outward) / static_cast<double>(mesh.triangles.size());
}

FaceOrientation orient(Scan& mesh) {
  return orientFacesOutward(mesh, makeEmbreeMeshCaster).value();
}

// The triangles of `sphere` whose centroid lies within `angle` of `axis`, as
// their own piece: one range scan's view of it.
Scan cap(const Scan& sphere, const Vec3f& axis, float cosine) {
  Scan part;
  part.points = sphere.points;
  for (const Triangle& t : sphere.triangles) {
    const Vec3f c = (sphere.points.positions[t[0]] + sphere.points.positions[t[1]] + sphere.points.positions[t[2]]) / 3.0f;
    if (c.normalized().dot(axis) > cosine) part.triangles.push_back(t);
  }
  return part;
}

TEST(OrientFacesOutward, AClosedSphereWoundInwardIsFlippedByItsVolume) {
  Scan inward = flipped(test::makeIcosphere(3));
  ASSERT_EQ(outwardFraction(inward), 0.0);
  const FaceOrientation result = orient(inward);
  EXPECT_EQ(result.components, 1u);
  EXPECT_EQ(result.byVolume, 1u);
  EXPECT_EQ(result.flippedComponents, 1u);
  EXPECT_EQ(result.flippedTriangles, inward.triangles.size());
  EXPECT_EQ(outwardFraction(inward), 1.0);

  Scan outward = test::makeIcosphere(3);
  EXPECT_EQ(orient(outward).flippedTriangles, 0u);
  EXPECT_EQ(outwardFraction(outward), 1.0);
}

// Closed pieces need no rays: no caster is built for them. An open piece
// asks for one, and the caster's failure is the call's.
TEST(OrientFacesOutward, BuildsACasterOnlyForOpenPieces) {
  int built = 0;
  const CasterFactory failing = [&](const Scan&) -> Result<std::unique_ptr<RayCaster>> {
    ++built;
    return internalError("no caster here");
  };
  Scan closed = flipped(test::makeIcosphere(3));
  EXPECT_EQ(orientFacesOutward(closed, failing).value().flippedComponents, 1u);
  EXPECT_EQ(built, 0);
  Scan open = cap(test::makeIcosphere(3), Vec3f::UnitZ(), 0.5f);
  const auto result = orientFacesOutward(open, failing);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().message, "no caster here");
  EXPECT_EQ(built, 1);
}

TEST(OrientFacesOutward, OnlyThePieceWoundInwardIsFlipped) {
  Scan two;
  append(two, test::makeIcosphere(2), Vec3f(-3, 0, 0));
  append(two, flipped(test::makeIcosphere(2)), Vec3f(3, 0, 0));
  const FaceOrientation result = orient(two);
  EXPECT_EQ(result.components, 2u);
  EXPECT_EQ(result.flippedComponents, 1u);
  Scan left, right;
  left.points = right.points = two.points;
  const std::size_t half = two.triangles.size() / 2;
  left.triangles.assign(two.triangles.begin(), two.triangles.begin() + static_cast<std::ptrdiff_t>(half));
  right.triangles.assign(two.triangles.begin() + static_cast<std::ptrdiff_t>(half), two.triangles.end());
  EXPECT_EQ(outwardFraction(left, Vec3f(-3, 0, 0)), 1.0);
  EXPECT_EQ(outwardFraction(right, Vec3f(3, 0, 0)), 1.0);
}

// Six overlapping open caps (a soup of six range scans of a sphere), two of
// them wound inward: rays from outside see those two from behind.
TEST(OrientFacesOutward, InwardScansOfAMultiViewSoupAreFlipped) {
  const Scan sphere = test::makeIcosphere(4);
  const Vec3f axes[] = {Vec3f::UnitX(), -Vec3f::UnitX(), Vec3f::UnitY(), -Vec3f::UnitY(), Vec3f::UnitZ(), -Vec3f::UnitZ()};
  for (bool allInward : {false, true}) {
    Scan soup;
    for (int i = 0; i < 6; ++i) {
      const Scan part = cap(sphere, axes[i], 0.3f);
      append(soup, (allInward || i == 1 || i == 4) ? flipped(part) : part);
    }
    dropUnreferencedVertices(soup);
    ASSERT_LT(outwardFraction(soup), allInward ? 0.01 : 0.9);
    const FaceOrientation result = orient(soup);
    EXPECT_EQ(result.components, 6u);
    EXPECT_EQ(result.byVisibility, 6u);
    EXPECT_EQ(result.flippedComponents, allInward ? 6u : 2u);
    EXPECT_EQ(outwardFraction(soup), 1.0);
  }
}

// A fragment no ray reaches (three triangles just under a cap, wound
// inward) turns like the decided triangles nearest to it.
TEST(OrientFacesOutward, AFragmentNoRayReachesFollowsItsNeighbours) {
  const Scan sphere = test::makeIcosphere(4);
  const Vec3f axes[] = {Vec3f::UnitX(), -Vec3f::UnitX(), Vec3f::UnitY(), -Vec3f::UnitY(), Vec3f::UnitZ(), -Vec3f::UnitZ()};
  Scan soup;
  for (const Vec3f& axis : axes) append(soup, cap(sphere, axis, 0.3f));
  Scan fragment = cap(sphere, Vec3f(0.6f, 0.0f, 0.8f), 0.998f);
  dropUnreferencedVertices(fragment);
  ASSERT_GE(fragment.triangles.size(), 1u);
  ASSERT_LE(fragment.triangles.size(), 12u);
  for (Vec3f& p : fragment.points.positions) p *= 0.99f;
  append(soup, flipped(fragment));
  dropUnreferencedVertices(soup);
  const FaceOrientation result = orient(soup);
  EXPECT_EQ(result.components, 7u);
  EXPECT_EQ(result.byVisibility, 6u);
  EXPECT_EQ(result.byNeighbours, 1u);
  EXPECT_EQ(result.undecided, 0u);
  EXPECT_EQ(result.flippedComponents, 1u);
  EXPECT_EQ(outwardFraction(soup), 1.0);
}

// A lone open sheet has no inside: seen alike from both sides, it is left
// as it is in either winding.
TEST(OrientFacesOutward, ALoneSheetIsLeftAsItIs) {
  const Scan sheet = cap(test::makeIcosphere(3), Vec3f::UnitZ(), 0.9f);
  for (const Scan& original : {sheet, flipped(sheet)}) {
    Scan copy = original;
    const FaceOrientation result = orient(copy);
    EXPECT_EQ(result.flippedTriangles, 0u);
    EXPECT_EQ(copy.triangles, original.triangles);
  }
}

}  // namespace
}  // namespace apo::faces
