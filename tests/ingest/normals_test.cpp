#include "ingest/normals.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace apo::normals {
namespace {

float angleDegrees(const Vec3f& a, const Vec3f& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0f, 1.0f)) * 180.0f / std::numbers::pi_v<float>;
}

// Sphere of radius 2 centred at (1, -1, 3), with radial noise.
std::vector<Vec3f> noisySphere(std::size_t count, float noise, const Vec3f& centre) {
  std::mt19937 random(7);
  std::normal_distribution<float> gaussian(0.0f, noise);
  std::vector<Vec3f> points;
  for (const Vec3f& u : test::fibonacciSpherePoints(count)) points.push_back(centre + (2.0f + gaussian(random)) * u);
  return points;
}

// Both orientations (our propagation, the default, and CGAL's MST) must give
// the same outward normals on closed shapes.
class Orientations : public testing::TestWithParam<OrientationMethod> {};

TEST_P(Orientations, SphereWithoutViewpointIsOutwardWithin10Degrees) {
  const Vec3f centre(1, -1, 3);
  const auto points = noisySphere(20000, 0.002f, centre);
  const OrientedNormals result = estimateOrientedNormals(points, std::nullopt, 0, GetParam()).value();
  EXPECT_EQ(result.orientation, orientationMethodName(GetParam()));
  EXPECT_EQ(result.unoriented, 0u);
  float worst = 0.0f;
  for (std::size_t i = 0; i < points.size(); ++i) {
    ASSERT_TRUE(result.normals[i].allFinite()) << i;
    worst = std::max(worst, angleDegrees(result.normals[i], points[i] - centre));
  }
  EXPECT_LT(worst, 10.0f);
}

TEST_P(Orientations, SeparateObjectsAreEachOrientedOutwards) {
  const Vec3f left(-5, 0, 0), right(5, 0, 1);
  auto points = noisySphere(6000, 0.0f, left);
  const auto second = noisySphere(6000, 0.0f, right);
  points.insert(points.end(), second.begin(), second.end());
  const OrientedNormals result = estimateOrientedNormals(points, std::nullopt, 0, GetParam()).value();
  EXPECT_EQ(result.islands, 2u);
  EXPECT_EQ(result.unoriented, 0u);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& centre = i < 6000 ? left : right;
    ASSERT_LT(angleDegrees(result.normals[i], points[i] - centre), 10.0f) << i;
  }
}

// A torus (genus 1, two curvatures of opposite sign): the analytic outward
// normal is the direction from the tube's centre circle.
TEST_P(Orientations, TorusIsOutwardEverywhere) {
  const float major = 3.0f, minor = 1.0f;
  std::vector<Vec3f> points, truth;
  const int around = 240, tube = 80;
  for (int i = 0; i < around; ++i)
    for (int j = 0; j < tube; ++j) {
      const float u = 2.0f * std::numbers::pi_v<float> * (static_cast<float>(i) + 0.5f * static_cast<float>(j % 2)) / around;
      const float v = 2.0f * std::numbers::pi_v<float> * static_cast<float>(j) / tube;
      const Vec3f ring(std::cos(u), std::sin(u), 0.0f);
      const Vec3f n = std::cos(v) * ring + std::sin(v) * Vec3f::UnitZ();
      points.push_back(major * ring + minor * n);
      truth.push_back(n);
    }
  const OrientedNormals result = estimateOrientedNormals(points, std::nullopt, 0, GetParam()).value();
  for (std::size_t i = 0; i < points.size(); ++i) ASSERT_LT(angleDegrees(result.normals[i], truth[i]), 10.0f) << i;
}

INSTANTIATE_TEST_SUITE_P(EstimateOrientedNormals, Orientations,
                         testing::Values(OrientationMethod::Propagation, OrientationMethod::CgalMst),
                         [](const auto& info) { return orientationMethodName(info.param) == "mst" ? std::string("CgalMst") : std::string("Propagation"); });

TEST(EstimateOrientedNormals, ViewpointInsideTheSphereTurnsNormalsInwards) {
  const Vec3f centre(1, -1, 3);
  const auto points = noisySphere(5000, 0.0f, centre);
  Viewpoint sensor;
  sensor.origin = centre;
  const OrientedNormals result = estimateOrientedNormals(points, Sensors::single(sensor.origin), 12).value();
  EXPECT_EQ(result.orientation, "viewpoint");
  EXPECT_EQ(result.neighbours, 12);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_LT(angleDegrees(result.normals[i], centre - points[i]), 10.0f) << i;
}

// A tilted plane far from the origin (georeferenced coordinates): every
// normal is the plane's own, facing the viewpoint, whichever side it is on.
TEST(EstimateOrientedNormals, PlaneNormalsAreExactAndFaceTheViewpoint) {
  const Vec3f u = Vec3f(1, 0, 0.5f).normalized(), v = Vec3f(0, 1, -0.25f).normalized();
  const Vec3f truth = u.cross(v).normalized();
  const Vec3f corner(5000.0f, -3000.0f, 200.0f);
  std::vector<Vec3f> plane;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) plane.push_back(corner + 0.1f * i * u + 0.1f * j * v);
  for (float side : {1.0f, -1.0f}) {
    Viewpoint sensor;
    sensor.origin = corner + side * 5.0f * truth;
    const OrientedNormals result = estimateOrientedNormals(plane, Sensors::single(sensor.origin), 10).value();
    for (const Vec3f& n : result.normals) EXPECT_LT(angleDegrees(n, side * truth), 0.1f);  // float positions near 5000
  }
}

// A declared position beside a closed object sees a third of it: turned
// towards it, the far side's normals point in, the propagation (each island
// signed by the position) disagrees on that third, and the far side is
// hidden behind the near one: the position is refused and the
// propagation's outward normals kept.
TEST(EstimateOrientedNormals, APositionTheNormalsDisagreeWithIsRefused) {
  const Vec3f centre(1, -1, 3);
  const auto points = noisySphere(8000, 0.0f, centre);
  const OrientedNormals result = estimateOrientedNormals(points, Sensors::single(centre + Vec3f(6, 0, 0)), 12).value();
  ASSERT_TRUE(result.agreement.has_value());
  EXPECT_FALSE(result.agreement->sensorsKept);
  EXPECT_NEAR(result.agreement->share(), 1.0 / 3.0, 0.03);  // the cap seen from 3 radii: (1 - 1/3) / 2 of the sphere
  EXPECT_GT(result.agreement->sight.share(), 0.5);
  EXPECT_EQ(result.orientation, "propagation");
  for (std::size_t i = 0; i < points.size(); ++i) ASSERT_LT(angleDegrees(result.normals[i], points[i] - centre), 10.0f) << i;
}

// Where the points were seen from, per point: a thin ellipsoid (a plate
// 20 times wider than thick) scanned from 8 positions around it. Turned
// towards their own scan's position (grazing ones by propagation from
// squarely seen ones), the normals face out but for a few at the rim; the
// propagation alone crosses the rim and turns half the plate inside out.
TEST(EstimateOrientedNormals, ScanPositionsOrientEveryPointTowardsItsOwnScanner) {
  Scan plate = test::makeIcosphere(4);
  for (Vec3f& p : plate.points.positions) p.z() *= 0.05f;
  SimulateScanOptions options;
  options.views = 8;
  options.raysPerSide = 70;
  options.rangeNoise = 0.0;
  options.misregistration = 0.0;
  options.withNormals = true;
  const test::BruteForceCaster caster(plate);
  const SimulatedScan simulated = simulateScan(plate, caster, test::checked(options)).value();
  const PointSet& points = simulated.scan.points;
  ASSERT_EQ(points.stations.size(), points.size());
  Sensors sensors{{}, points.stations};
  for (const ScanStation& station : simulated.scan.stations) sensors.positions.push_back(station.position);
  // Orientation errors only: normals opposite to the truth where the fitted
  // plane is within 60 degrees of the true one either way (at the rim,
  // neighbourhoods spanning both faces fit planes that no sign makes right).
  const auto flipped = [&](const std::vector<Vec3f>& normals) {
    std::size_t count = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
      count += normals[i].allFinite() && normals[i].dot(points.normals[i]) < -0.5f;
    return count;
  };
  const OrientedNormals bySensors = estimateOrientedNormals(points.positions, sensors, 12).value();
  const OrientedNormals byPropagation = estimateOrientedNormals(points.positions, std::nullopt, 12).value();
  EXPECT_EQ(bySensors.orientation, "viewpoint");
  const std::size_t bySensorsFlipped = flipped(bySensors.normals), byPropagationFlipped = flipped(byPropagation.normals);
  EXPECT_LT(bySensorsFlipped, points.size() / 200);       // 26 of 14,463
  EXPECT_GT(byPropagationFlipped, points.size() / 4);     // 7,157
  RecordProperty("flipped_by_positions", static_cast<int>(bySensorsFlipped));
  RecordProperty("flipped_by_propagation", static_cast<int>(byPropagationFlipped));
  RecordProperty("points", static_cast<int>(points.size()));
}

// A slab as thick as a neighbourhood is wide, each face scanned from its
// own side (a part as thin as a scan's ear or leg): a point's nearest k lie
// on both faces and fit planes at any angle; with scan positions, the
// neighbours seen from the other side are left out (sameSideNeighbours) and
// every plane is the face's.
TEST(EstimateOrientedNormals, ScanPositionsKeepTheOtherSidesPointsOutOfAPlane) {
  std::mt19937 random(3);
  std::uniform_real_distribution<float> jitter(-0.05f, 0.05f);
  std::vector<Vec3f> points, truth;
  Sensors sensors{{Vec3f(30, 30, 100), Vec3f(30, 30, -100)}, {}};
  for (int face = 0; face < 2; ++face)
    for (int x = 0; x < 60; ++x)
      for (int y = 0; y < 60; ++y) {
        points.emplace_back(x + jitter(random), y + jitter(random), (face == 0 ? 1.0f : -1.0f) + jitter(random));
        truth.emplace_back(0.0f, 0.0f, face == 0 ? 1.0f : -1.0f);
        sensors.ofPoint.push_back(static_cast<std::uint16_t>(face));
      }
  // Planes more than 30 degrees from the true one, either way.
  const auto wrongPlanes = [&](const std::vector<Vec3f>& normals) {
    std::size_t count = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
      count += !normals[i].allFinite() || std::abs(normals[i].dot(truth[i])) < 0.866f;
    return count;
  };
  const std::size_t sameSide = wrongPlanes(estimateOrientedNormals(points, sensors, 32).value().normals);
  const std::size_t everyNeighbour = wrongPlanes(estimateOrientedNormals(points, std::nullopt, 32).value().normals);
  RecordProperty("wrong_planes_same_side", static_cast<int>(sameSide));
  RecordProperty("wrong_planes_every_neighbour", static_cast<int>(everyNeighbour));
  EXPECT_GT(everyNeighbour, points.size() / 20) << sameSide;  // 472 of 7,200
  EXPECT_EQ(sameSide, 0u);
}

// Coincident points and fewer than three points fit no plane: NaN normals.
TEST(EstimateOrientedNormals, NeighbourhoodsWithoutExtentHaveNoNormal) {
  const std::vector<Vec3f> same(20, Vec3f(1, 2, 3));
  for (const Vec3f& n : estimateOrientedNormals(same, std::nullopt, 8).value().normals) EXPECT_FALSE(n.allFinite());
  const std::vector<Vec3f> pair{Vec3f(0, 0, 0), Vec3f(1, 0, 0)};
  for (const Vec3f& n : estimateOrientedNormals(pair, std::nullopt, 8).value().normals) EXPECT_FALSE(n.allFinite());
}

TEST(ChooseNeighbourCount, NoiseAsksForLargerNeighbourhoods) {
  const Vec3f centre = Vec3f::Zero();
  const int clean = chooseNeighbourCount(noisySphere(20000, 0.0f, centre)).value();
  const int noisy = chooseNeighbourCount(noisySphere(20000, 0.02f, centre)).value();
  EXPECT_EQ(clean, kCandidateNeighbourCounts[0]);
  EXPECT_GT(noisy, clean);
}

TEST(ChooseNeighbourCount, RefusesNeighbourhoodsAlongScanLines) {
  // Rows of points 100x denser along x than across rows: small k sees lines.
  std::vector<Vec3f> rows;
  for (int row = 0; row < 40; ++row)
    for (int i = 0; i < 400; ++i) rows.emplace_back(i * 0.001f, row * 0.1f, 0.0f);
  const int k = chooseNeighbourCount(rows).value();
  EXPECT_EQ(k, kCandidateNeighbourCounts[std::size(kCandidateNeighbourCounts) - 1]);
}

TEST(ChooseNeighbourCount, TinyCloudsUseWhatTheyHave) { EXPECT_EQ(chooseNeighbourCount(noisySphere(5, 0, Vec3f::Zero())).value(), 5); }

}  // namespace
}  // namespace apo::normals
