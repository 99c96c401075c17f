// The tangent-space normal map against an analytic normal field, decoded
// here as the glTF 2.0 specification says a viewer decodes it (written
// apart from export/, from the spec's text): interpolated NORMAL and
// TANGENT, T made orthogonal to N, B = cross(N, T) w, the texture sampled
// bilinearly at texel centres, n = normalize(T x + B y + N z).
#include "export/export.h"

#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace apo {
namespace {

Vec3f specDecode(const GltfMesh& mesh, const NormalMap& map, std::size_t triangle, const std::array<float, 3>& w) {
  Vec3f n = Vec3f::Zero(), t = Vec3f::Zero();
  Vec2f uv = Vec2f::Zero();
  for (std::size_t k = 0; k < 3; ++k) {
    const std::uint32_t v = mesh.indices[3 * triangle + k];
    n += w[k] * mesh.normals[v];
    t += w[k] * mesh.tangents[v].head<3>();
    uv += w[k] * mesh.uvs[v];
  }
  n.normalize();
  t = (t - n * n.dot(t)).normalized();
  const Vec3f b = n.cross(t) * mesh.tangents[mesh.indices[3 * triangle]].w();
  const double x = std::clamp(uv.x() * map.width - 0.5, 0.0, map.width - 1.0);
  const double y = std::clamp(uv.y() * map.height - 0.5, 0.0, map.height - 1.0);
  const auto x0 = static_cast<std::uint32_t>(std::floor(x)), y0 = static_cast<std::uint32_t>(std::floor(y));
  const std::uint32_t x1 = std::min(x0 + 1, map.width - 1), y1 = std::min(y0 + 1, map.height - 1);
  const double fx = x - x0, fy = y - y0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  const auto add = [&](std::uint32_t tx, std::uint32_t ty, double weight) {
    const std::size_t i = 3 * (std::size_t{ty} * map.width + tx);
    c += weight * Eigen::Vector3d(map.rgb[i], map.rgb[i + 1], map.rgb[i + 2]) / 255.0;
  };
  add(x0, y0, (1 - fx) * (1 - fy));
  add(x1, y0, fx * (1 - fy));
  add(x0, y1, (1 - fx) * fy);
  add(x1, y1, fx * fy);
  c = c * 2.0 - Eigen::Vector3d::Ones();
  return (t * static_cast<float>(c.x()) + b * static_cast<float>(c.y()) + n * static_cast<float>(c.z())).normalized();
}

// A smooth field that turns m's normal by up to about 17 degrees.
Vec3f wavyField(const Vec3f& point, const Vec3f& coarseNormal) {
  const Vec3f push(std::sin(3.0f * point.y()), std::cos(2.0f * point.z()), std::sin(2.5f * point.x()));
  return (coarseNormal + 0.3f * (push - coarseNormal * coarseNormal.dot(push))).normalized();
}

struct Measured {
  double mean = 0.0, max = 0.0;
};

// The decoded normal against the field at random points of every triangle.
Measured decodedAgainstField(const Scan& mesh, const GltfMesh& gltf, const NormalMap& map, const NormalField& field) {
  std::mt19937 random(7);
  Measured measured;
  std::size_t count = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int s = 0; s < 20; ++s) {
      const std::array<float, 3> w = test::randomBarycentrics(random);
      Vec3f point = Vec3f::Zero(), coarse = Vec3f::Zero();
      for (std::size_t k = 0; k < 3; ++k) {
        point += w[k] * gltf.positions[gltf.indices[3 * f + k]];
        coarse += w[k] * gltf.normals[gltf.indices[3 * f + k]];
      }
      const double degrees = test::degreesBetween(specDecode(gltf, map, f, w), field(point, coarse.normalized()));
      measured.mean += degrees;
      measured.max = std::max(measured.max, degrees);
      ++count;
    }
  measured.mean /= static_cast<double>(count);
  return measured;
}

TEST(NormalMap, AViewerDecodesTheFieldUpToTexelsAndEightBits) {
  const Scan mesh = test::makeIcosphere(3);
  const auto atlas = packTrianglePatches(mesh, 1024, 1024, 2);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const GltfMesh gltf = patchMesh(mesh, *atlas);
  ASSERT_EQ(gltf.positions.size(), 3 * mesh.triangles.size());
  const NormalMap map = bakeTangentNormalMap(gltf, *atlas, wavyField);
  EXPECT_EQ(map.texelsWithoutAnswer, 0u);
  EXPECT_GT(map.texelsFilled, static_cast<std::uint64_t>(atlas->usedShare * 1024 * 1024));
  const Measured wavy = decodedAgainstField(mesh, gltf, map, wavyField);
  // 8-bit rounding alone is about 0.2 degrees at most per component pair;
  // the bilinear blend of a smooth field adds little at this density.
  EXPECT_LT(wavy.mean, 0.25) << "max " << wavy.max;
  EXPECT_LT(wavy.max, 1.0);

  // m's own normal everywhere: the map is flat blue and decodes to m.
  const NormalField coarseOnly = [](const Vec3f&, const Vec3f& coarse) { return coarse; };
  const NormalMap flat = bakeTangentNormalMap(gltf, *atlas, coarseOnly);
  EXPECT_LT(decodedAgainstField(mesh, gltf, flat, coarseOnly).max, 0.5);
  // No answer: m's normal too, counted.
  const NormalMap silent = bakeTangentNormalMap(gltf, *atlas, [](const Vec3f&, const Vec3f&) { return Vec3f::Zero(); });
  EXPECT_EQ(silent.texelsWithoutAnswer, silent.texelsFilled);
  EXPECT_LT(decodedAgainstField(mesh, gltf, silent, coarseOnly).max, 0.5);
}

// Texels outside every patch hold what push-pull brings from the nearest
// filled ones: no texel of the map keeps an unset (black) value.
TEST(NormalMap, EveryTexelOutsideThePatchesIsFilledFromNearby) {
  const Scan mesh = test::makeIcosphere(2);
  const auto atlas = packTrianglePatches(mesh, 256, 256, 2);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const NormalMap map = bakeTangentNormalMap(patchMesh(mesh, *atlas), *atlas, wavyField);
  ASSERT_EQ(map.rgb.size(), 256u * 256u * 3u);
  std::size_t unitLength = 0;
  for (std::size_t i = 0; i < map.rgb.size(); i += 3) {
    const Vec3f c = Vec3f(map.rgb[i], map.rgb[i + 1], map.rgb[i + 2]) / 127.5f - Vec3f::Ones();
    unitLength += std::abs(c.norm() - 1.0f) < 0.1f ? 1 : 0;
    EXPECT_GT(map.rgb[i + 2], 127) << "texel " << i / 3 << " points below the surface";
  }
  // Means of unit vectors of a smooth field stay close to unit length.
  EXPECT_GT(unitLength, map.rgb.size() / 3 * 95 / 100);
}

// The base colour map: a smooth colour of position, sampled by a viewer
// bilinearly at the vertices' interpolated UVs, against the colour itself.
Rgb8 smoothColor(const Vec3f& p) {
  const auto channel = [](float v) { return static_cast<std::uint8_t>(std::lround(127.5f + 120.0f * std::sin(v))); };
  return {channel(3.0f * p.x()), channel(2.0f * p.y() + 1.0f), channel(2.5f * p.z() - 0.5f)};
}

TEST(ColorMap, AViewerSamplesTheScansColourUpToTexels) {
  const Scan mesh = test::makeIcosphere(3);
  const auto atlas = packTrianglePatches(mesh, 512, 512, 2);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const GltfMesh gltf = patchMesh(mesh, *atlas);
  std::size_t asked = 0;
  const ColorField field = [&](const std::vector<Vec3f>& points) -> Result<std::vector<Rgb8>> {
    asked += points.size();
    std::vector<Rgb8> colors;
    for (const Vec3f& p : points) colors.push_back(smoothColor(p));
    return colors;
  };
  const auto map = bakeColorMap(gltf, *atlas, field);
  ASSERT_TRUE(map.ok()) << map.error().message;
  ASSERT_EQ(map->rgb.size(), 512u * 512u * 3u);
  EXPECT_GT(asked, static_cast<std::size_t>(atlas->usedShare * 512 * 512));  // every texel of every patch, gutters too
  std::mt19937 random(11);
  double sum = 0.0, worst = 0.0;
  std::size_t count = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int s = 0; s < 10; ++s) {
      const std::array<float, 3> w = test::randomBarycentrics(random);
      Vec3f point = Vec3f::Zero();
      Vec2f uv = Vec2f::Zero();
      for (std::size_t k = 0; k < 3; ++k) {
        point += w[k] * gltf.positions[gltf.indices[3 * f + k]];
        uv += w[k] * gltf.uvs[gltf.indices[3 * f + k]];
      }
      // Bilinear, texel centres at half-integers (glTF's sampler, linear).
      const double x = uv.x() * 512 - 0.5, y = uv.y() * 512 - 0.5;
      const auto x0 = static_cast<std::size_t>(std::floor(x)), y0 = static_cast<std::size_t>(std::floor(y));
      const double fx = x - x0, fy = y - y0;
      const Rgb8 truth = smoothColor(point);
      for (int c = 0; c < 3; ++c) {
        const auto at = [&](std::size_t tx, std::size_t ty) { return double(map->rgb[3 * (ty * 512 + tx) + c]); };
        const double sampled = (1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) +
                               (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1);
        const double wanted = c == 0 ? truth.r : c == 1 ? truth.g : truth.b;
        sum += std::abs(sampled - wanted);
        worst = std::max(worst, std::abs(sampled - wanted));
        ++count;
      }
    }
  // A texel spans about 1/90 of the sphere's radius here: the colour moves
  // by about 4 levels across one, and the blend of a smooth colour is closer.
  EXPECT_LT(sum / count, 1.5) << "worst " << worst;
  EXPECT_LT(worst, 8.0);
}

// A field that fails, fails the map; one that answers for too few points is
// an internal error, not a map of stale texels.
TEST(ColorMap, AFailingOrShortFieldFailsTheMap) {
  const Scan mesh = test::makeIcosphere(1);
  const auto atlas = packTrianglePatches(mesh, 64, 64, 1);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const GltfMesh gltf = patchMesh(mesh, *atlas);
  const auto failed = bakeColorMap(gltf, *atlas, [](const std::vector<Vec3f>&) -> Result<std::vector<Rgb8>> {
    return badInput("scan.ply: unreadable colours");
  });
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.error().message.find("scan.ply"), std::string::npos);
  const auto shortAnswer = bakeColorMap(gltf, *atlas, [](const std::vector<Vec3f>&) -> Result<std::vector<Rgb8>> {
    return std::vector<Rgb8>(3);
  });
  EXPECT_FALSE(shortAnswer.ok());
}

}  // namespace
}  // namespace apo
