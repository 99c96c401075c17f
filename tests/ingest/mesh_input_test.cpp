// Meshes that are sets of overlapping range scans (simulated: each view's
// range grid triangulated into one soup, as scanner software writes them)
// against meshes that are one surface.
#include "ingest/ingest.h"
#include "ingest/mesh_input.h"

#include "adapters/embree/embree_ray_caster.h"
#include "core/mesh_edit.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

namespace apo {
namespace {
namespace fs = std::filesystem;

// A soup of `views` triangulated range grids of a unit icosphere.
Scan rangeScanSoup(int views) {
  const Scan sphere = test::makeIcosphere(5);
  const auto caster = makeEmbreeMeshCaster(sphere).value();
  SimulateScanOptions options;
  options.views = views;
  options.raysPerSide = 80;
  options.asMesh = true;
  return simulateScan(sphere, *caster, test::checked(options)).value().scan;
}

Scan flipped(Scan mesh) {
  for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

IngestResult ingestAs(const Scan& mesh, const IngestOptions& options = {}) {
  const fs::path path = test::freshTempDir() / "input.ply";
  EXPECT_TRUE(writePly(path, mesh).ok());
  auto result = ingestScan(path, test::checked(options));
  EXPECT_TRUE(result.ok()) << result.error().message;
  return std::move(result).value();
}

TEST(SimulateScanAsMesh, EachViewIsItsOwnSheetFacingItsScanner) {
  const Scan soup = rangeScanSoup(6);
  ASSERT_GT(soup.triangles.size(), 10000u);
  const auto evidence = mesh_input::judge(soup).value();
  // No vertex shared between views; at the rim, a cell with three corners
  // gets one triangle whose neighbours were refused as grazing, and may
  // stand apart (a few per view).
  EXPECT_GE(evidence.pieces, 6u);
  EXPECT_LE(evidence.pieces, 60u);
  EXPECT_GT(evidence.boundaryEdgeFraction, 0.0);
  // Wound outward: the sphere's centre is behind every triangle.
  for (const Triangle& t : soup.triangles) {
    const auto& p = soup.points.positions;
    ASSERT_GT((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(p[t[0]]), 0.0f);
  }
}

TEST(MeshInput, AnOverlappingSoupIsReadAsScansAndItsPointsKeepOutwardNormals) {
  for (bool inward : {false, true}) {
    SCOPED_TRACE(inward ? "wound inward" : "wound outward");
    const Scan soup = inward ? flipped(rangeScanSoup(6)) : rangeScanSoup(6);
    const IngestResult result = ingestAs(soup);
    const auto& decision = result.report.meshInput;
    EXPECT_EQ(decision.decision, "scans");
    EXPECT_GE(decision.pieces, 6u);
    EXPECT_GT(decision.overlapFraction, mesh_input::kScansOverlapFraction);
    EXPECT_FALSE(result.scan.isMesh());
    EXPECT_EQ(result.report.faceOrientation.flippedComponents, inward ? decision.pieces : 0u);
    ASSERT_TRUE(result.scan.points.hasNormals());
    std::size_t outward = 0;
    for (std::size_t i = 0; i < result.scan.points.size(); ++i)
      outward += result.scan.points.normals[i].dot(result.scan.points.positions[i]) > 0.0f;
    EXPECT_EQ(outward, result.scan.points.size());
  }
}

TEST(MeshInput, OneSurfaceAndSeparatePartsStayMeshes) {
  Scan parts = test::makeIcosphere(4);
  const Scan second = test::makeIcosphere(4);
  const auto base = static_cast<std::uint32_t>(parts.points.size());
  for (const Vec3f& p : second.points.positions) parts.points.positions.push_back(p + Vec3f(2.5f, 0, 0));
  for (const Triangle& t : second.triangles) parts.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  for (const Scan& mesh : {test::makeIcosphere(5), parts}) {
    const IngestResult result = ingestAs(mesh);
    EXPECT_EQ(result.report.meshInput.decision, "surface");
    EXPECT_EQ(result.report.meshInput.overlapFraction, 0.0);
    EXPECT_TRUE(result.scan.isMesh());
  }
}

// Two registered copies of an n x n grid sheet, as one soup: every vertex
// overlaps the other piece.
Scan twoOverlappingSheets(int n) {
  Scan soup;
  for (int copy = 0; copy < 2; ++copy) {
    const auto base = static_cast<std::uint32_t>(soup.points.size());
    for (int row = 0; row < n; ++row)
      for (int column = 0; column < n; ++column)
        soup.points.positions.emplace_back(static_cast<float>(column), static_cast<float>(row), 0.01f * copy);
    for (int row = 0; row + 1 < n; ++row)
      for (int column = 0; column + 1 < n; ++column) {
        const auto at = [&](int r, int c) { return base + static_cast<std::uint32_t>(r * n + c); };
        soup.triangles.push_back({at(row, column), at(row, column + 1), at(row + 1, column + 1)});
        soup.triangles.push_back({at(row, column), at(row + 1, column + 1), at(row + 1, column)});
      }
  }
  return soup;
}

// Read as scans, a mesh of fewer vertices than a surface is reconstructed
// from would only fail later: it stays one surface (two tiny CGAL meshes of
// 7 and 8 vertices did so).
TEST(MeshInput, AMeshTooSmallToReconstructStaysASurface) {
  const auto tiny = mesh_input::judge(twoOverlappingSheets(6)).value();  // 72 vertices
  EXPECT_EQ(tiny.overlapFraction, 1.0);
  EXPECT_FALSE(tiny.looksLikeScans);
  const auto enough = mesh_input::judge(twoOverlappingSheets(8)).value();  // 128 vertices
  EXPECT_EQ(enough.overlapFraction, 1.0);
  EXPECT_TRUE(enough.looksLikeScans);
}

// Parts of a model are not scans: closed parts however close (bones.off's
// 26 bones touch), and open sheets that lie close but face apart
// (horizons.off's two stacked sheets, the two faces of a thin plate).
TEST(MeshInput, ClosedPartsAndSheetsFacingApartStayASurface) {
  Scan nested = test::makeIcosphere(4);
  const Scan other = test::makeIcosphere(4);
  const auto base = static_cast<std::uint32_t>(nested.points.size());
  for (const Vec3f& p : other.points.positions) nested.points.positions.push_back(1.01f * p + Vec3f(0.02f, 0, 0));
  for (const Triangle& t : other.triangles) nested.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  const auto closed = mesh_input::judge(nested).value();
  EXPECT_EQ(closed.pieces, 2u);
  EXPECT_EQ(closed.overlapFraction, 0.0);
  EXPECT_FALSE(closed.looksLikeScans);

  Scan plate = twoOverlappingSheets(20);
  for (std::size_t t = plate.triangles.size() / 2; t < plate.triangles.size(); ++t)
    std::swap(plate.triangles[t][1], plate.triangles[t][2]);  // the second sheet faces down
  const auto apart = mesh_input::judge(plate).value();
  EXPECT_EQ(apart.overlapFraction, 0.0);
  EXPECT_FALSE(apart.looksLikeScans);
  const auto together = mesh_input::judge(twoOverlappingSheets(20)).value();
  EXPECT_EQ(together.overlapFraction, 1.0);
  EXPECT_TRUE(together.looksLikeScans);
}

// An open shell of no thickness (a hemisphere) scanned from all round: the
// views below see its inside, and each view's faces face its own scanner,
// so scans of the inside lie on scans of the outside facing the other way
// (lion-head.off's soup: Poisson on such points made a broken M, 40.9
// degrees from its APO). Read as scans, every point faces one way.
TEST(MeshInput, ScansOfASheetSeenFromBothSidesAreTurnedToFaceOneWay) {
  const Scan sphere = test::makeIcosphere(5);
  Scan shell;
  shell.points = sphere.points;
  for (const Triangle& t : sphere.triangles)
    if (sphere.points.positions[t[0]].z() + sphere.points.positions[t[1]].z() + sphere.points.positions[t[2]].z() > 0.0f)
      shell.triangles.push_back(t);
  dropUnreferencedVertices(shell);
  const auto caster = makeEmbreeMeshCaster(shell).value();
  SimulateScanOptions options;
  options.views = 8;
  options.raysPerSide = 80;
  options.asMesh = true;
  const Scan soup = simulateScan(shell, *caster, test::checked(options)).value().scan;
  // The test's premise: some of the soup's points face up (seen from
  // outside), some down.
  const auto facingUp = [](const Scan& scan) {
    const std::vector<Vec3f> normals = scan.isMesh() ? areaWeightedVertexNormals(scan) : scan.points.normals;
    std::size_t up = 0;
    for (std::size_t i = 0; i < scan.points.size(); ++i) up += normals[i].dot(scan.points.positions[i]) > 0.0f;
    return static_cast<double>(up) / static_cast<double>(scan.points.size());
  };
  const double before = facingUp(soup);
  ASSERT_GT(before, 0.1);
  ASSERT_LT(before, 0.9);

  const IngestResult result = ingestAs(soup);
  const auto& decision = result.report.meshInput;
  ASSERT_EQ(decision.decision, "scans");
  EXPECT_GT(decision.opposedPairs, 0u);
  EXPECT_GT(decision.turnedPieces, 0u);
  const double after = facingUp(result.scan);
  EXPECT_TRUE(after > 0.99 || after < 0.01) << after << " of the points face outward";
}

// Two sheets a plate's thickness apart (two edge lengths, more than range
// noise) facing apart are two sides, not one sheet: nothing is turned.
TEST(MeshInput, TheTwoSidesOfAPlateAreNotOneSheet) {
  Scan plate = twoOverlappingSheets(20);
  for (std::size_t v = plate.points.size() / 2; v < plate.points.size(); ++v) plate.points.positions[v].z() = 2.0f;
  for (std::size_t t = plate.triangles.size() / 2; t < plate.triangles.size(); ++t)
    std::swap(plate.triangles[t][1], plate.triangles[t][0]);
  const auto evidence = mesh_input::judge(plate).value();
  EXPECT_EQ(evidence.sheets.coincidentPairs, 0u);
  EXPECT_EQ(evidence.sheets.turnedVertices, 0u);
  // The same sheets on each other (0.01 apart) are one sheet seen from both
  // sides: one of the two is turned.
  Scan sheet = twoOverlappingSheets(20);
  for (std::size_t t = sheet.triangles.size() / 2; t < sheet.triangles.size(); ++t)
    std::swap(sheet.triangles[t][1], sheet.triangles[t][0]);
  const auto one = mesh_input::judge(sheet).value();
  EXPECT_EQ(one.sheets.coincidentPairs, 1u);
  EXPECT_EQ(one.sheets.opposedPairs, 1u);
  EXPECT_EQ(one.sheets.turnedPieces, 1u);
  EXPECT_EQ(one.sheets.turnedVertices, 400u);
}

TEST(MeshInput, TheDecisionCanBeForcedEitherWay) {
  IngestOptions surface;
  surface.meshInput = MeshInput::Surface;
  const IngestResult kept = ingestAs(rangeScanSoup(4), surface);
  EXPECT_EQ(kept.report.meshInput.decision, "surface");
  EXPECT_EQ(kept.report.meshInput.requested, "surface");
  EXPECT_TRUE(kept.scan.isMesh());
  IngestOptions scans;
  scans.meshInput = MeshInput::Scans;
  const IngestResult points = ingestAs(test::makeIcosphere(3), scans);
  EXPECT_EQ(points.report.meshInput.decision, "scans");
  EXPECT_FALSE(points.scan.isMesh());
  EXPECT_TRUE(points.scan.points.hasNormals());
}

}  // namespace
}  // namespace apo
