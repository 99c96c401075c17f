// m as a glTF primitive over its patches, and the tangent-space normal map
// baked in the frame glTF 2.0 viewers rebuild (docs/export.md, "The frame").
#include "export/export.h"

#include "core/triangle_geometry.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace apo {
namespace {

// The tangent of a triangle: the direction in which u grows, from its
// corners' positions and UVs; and the sign w that makes cross(N, T) w the
// direction in which v grows.
std::pair<Vec3f, float> triangleTangent(const std::array<Vec3f, 3>& p, const std::array<Vec2f, 3>& uv,
                                        const Vec3f& faceNormal) {
  const Vec3f e1 = p[1] - p[0], e2 = p[2] - p[0];
  const Vec2f d1 = uv[1] - uv[0], d2 = uv[2] - uv[0];
  const float det = d1.x() * d2.y() - d2.x() * d1.y();
  if (std::abs(det) < 1e-20f) return {faceNormal.unitOrthogonal(), 1.0f};
  const Vec3f tangent = (e1 * d2.y() - e2 * d1.y()) / det;
  const Vec3f bitangent = (e2 * d1.x() - e1 * d2.x()) / det;
  return {tangent, faceNormal.cross(tangent).dot(bitangent) < 0.0f ? -1.0f : 1.0f};
}

Vec3f orthogonalTo(const Vec3f& tangent, const Vec3f& normal) {
  const Vec3f t = tangent - normal * normal.dot(tangent);
  return t.squaredNorm() > 0.0f ? Vec3f(t.normalized()) : normal.unitOrthogonal();
}

// The viewer's frame at barycentrics w of mesh triangle `triangle`: N and
// T interpolated, N normalised, T made orthogonal to N, B = cross(N, T) w.
struct Frame {
  Vec3f tangent, bitangent, normal;
};

Frame viewerFrame(const GltfMesh& mesh, std::size_t triangle, const Vec3f& w) {
  Vec3f n = Vec3f::Zero();
  Eigen::Vector4f t = Eigen::Vector4f::Zero();
  for (int k = 0; k < 3; ++k) {
    const std::uint32_t v = mesh.indices[3 * triangle + static_cast<std::size_t>(k)];
    n += w[k] * mesh.normals[v];
    t += w[k] * mesh.tangents[v];
  }
  const float sign = mesh.tangents[mesh.indices[3 * triangle]].w() < 0.0f ? -1.0f : 1.0f;
  Frame frame;
  frame.normal = n.squaredNorm() > 0.0f ? Vec3f(n.normalized()) : Vec3f::UnitZ();
  frame.tangent = orthogonalTo(t.head<3>(), frame.normal);
  frame.bitangent = frame.normal.cross(frame.tangent) * sign;
  return frame;
}

// A texel a map fills: the triangle whose patch (or gutter) holds its
// centre, and the barycentrics of that triangle's point closest to it.
struct TexelSample {
  std::size_t texel = 0, triangle = 0;
  Vec3f weights = Vec3f::Zero();
};

// Every texel whose centre lies within the gutter of a patch, patch by
// patch (the layout gives each texel to one patch at most).
std::vector<TexelSample> patchTexels(const PatchAtlas& atlas) {
  std::vector<TexelSample> samples;
  const auto g = static_cast<float>(atlas.gutter);
  const auto flat = [](const Vec2f& v) { return Vec3f(v.x(), v.y(), 0.0f); };
  for (std::size_t f = 0; f < atlas.corners.size(); ++f) {
    const std::array<Vec2f, 3>& c = atlas.corners[f];
    const Vec2f low = c[0].cwiseMin(c[1]).cwiseMin(c[2]).array() - g;
    const Vec2f high = c[0].cwiseMax(c[1]).cwiseMax(c[2]).array() + g;
    const auto x0 = static_cast<std::uint32_t>(std::max(0.0f, std::floor(low.x())));
    const auto y0 = static_cast<std::uint32_t>(std::max(0.0f, std::floor(low.y())));
    const auto x1 = static_cast<std::uint32_t>(std::min(static_cast<float>(atlas.width), std::ceil(high.x())));
    const auto y1 = static_cast<std::uint32_t>(std::min(static_cast<float>(atlas.height), std::ceil(high.y())));
    for (std::uint32_t y = y0; y < y1; ++y)
      for (std::uint32_t x = x0; x < x1; ++x) {
        const Vec3f centre(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, 0.0f);
        const TrianglePoint closest = closestPointOnTriangle(centre, flat(c[0]), flat(c[1]), flat(c[2]));
        if (closest.squaredDistance > g * g) continue;
        samples.push_back({std::size_t{y} * atlas.width + x, f, closest.weights});
      }
  }
  return samples;
}

// The point of m at a sample (the mesh's triangle at its barycentrics).
Vec3f samplePoint(const GltfMesh& mesh, const TexelSample& sample) {
  Vec3f point = Vec3f::Zero();
  for (int k = 0; k < 3; ++k)
    point += sample.weights[k] * mesh.positions[mesh.indices[3 * sample.triangle + static_cast<std::size_t>(k)]];
  return point;
}

std::uint8_t toByte(float c) { return static_cast<std::uint8_t>(std::lround(std::clamp(c * 0.5f + 0.5f, 0.0f, 1.0f) * 255.0f)); }

// Push-pull: every empty texel takes the mean of the filled ones in the
// smallest block of the pyramid (2 x 2, 4 x 4, ...) round it that has any.
void pushPull(std::vector<Vec3f>& values, std::vector<float>& weights, std::uint32_t width, std::uint32_t height) {
  if (width <= 1 && height <= 1) return;
  const std::uint32_t w2 = (width + 1) / 2, h2 = (height + 1) / 2;
  std::vector<Vec3f> coarse(std::size_t{w2} * h2, Vec3f::Zero());
  std::vector<float> coarseWeights(coarse.size(), 0.0f);
  for (std::uint32_t y = 0; y < height; ++y)
    for (std::uint32_t x = 0; x < width; ++x) {
      const std::size_t i = std::size_t{y} * width + x, j = std::size_t{y / 2} * w2 + x / 2;
      coarse[j] += weights[i] * values[i];
      coarseWeights[j] += weights[i];
    }
  for (std::size_t j = 0; j < coarse.size(); ++j)
    if (coarseWeights[j] > 0.0f) coarse[j] /= coarseWeights[j], coarseWeights[j] = 1.0f;
  pushPull(coarse, coarseWeights, w2, h2);
  for (std::uint32_t y = 0; y < height; ++y)
    for (std::uint32_t x = 0; x < width; ++x) {
      const std::size_t i = std::size_t{y} * width + x;
      if (weights[i] == 0.0f) values[i] = coarse[std::size_t{y / 2} * w2 + x / 2];
    }
}

}  // namespace

GltfMesh patchMesh(const Scan& coarse, const PatchAtlas& atlas) {
  const auto& p = coarse.points.positions;
  const std::vector<Vec3f> vertexNormals = vertexNormalsAsDrawn(coarse);
  GltfMesh mesh;
  const Vec2f scale(1.0f / static_cast<float>(atlas.width), 1.0f / static_cast<float>(atlas.height));
  for (std::size_t f = 0; f < coarse.triangles.size(); ++f) {
    const Triangle& t = coarse.triangles[f];
    const std::array<Vec3f, 3> corners{p[t[0]], p[t[1]], p[t[2]]};
    std::array<Vec2f, 3> uv;
    for (std::size_t k = 0; k < 3; ++k) uv[k] = atlas.corners[f][k].cwiseProduct(scale);
    Vec3f faceNormal = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    faceNormal = faceNormal.squaredNorm() > 0.0f ? Vec3f(faceNormal.normalized()) : Vec3f::UnitZ();
    const auto [tangent, sign] = triangleTangent(corners, atlas.corners[f], faceNormal);
    for (std::size_t k = 0; k < 3; ++k) {
      Vec3f n = vertexNormals[t[k]];
      n = n.squaredNorm() > 0.0f ? Vec3f(n.normalized()) : faceNormal;
      const Vec3f tk = orthogonalTo(tangent, n);
      mesh.indices.push_back(static_cast<std::uint32_t>(mesh.positions.size()));
      mesh.positions.push_back(corners[k]);
      mesh.normals.push_back(n);
      mesh.tangents.emplace_back(tk.x(), tk.y(), tk.z(), sign);
      mesh.uvs.push_back(uv[k]);
    }
  }
  return mesh;
}

NormalMap bakeTangentNormalMap(const GltfMesh& mesh, const PatchAtlas& atlas, const NormalField& field) {
  NormalMap map;
  map.width = atlas.width;
  map.height = atlas.height;
  const std::size_t texels = std::size_t{atlas.width} * atlas.height;
  std::vector<Vec3f> values(texels, Vec3f::Zero());
  std::vector<float> weights(texels, 0.0f);
  // Each sample on its own (the field is thread-safe), on every core; then
  // written in sample order, so that where two samples share a texel the
  // later one wins whatever the threads' timing.
  const std::vector<TexelSample> samples = patchTexels(atlas);
  std::vector<std::uint8_t> answered(samples.size(), 0);
  std::vector<Vec3f> tangentSpace(samples.size());
  tbb::parallel_for(std::size_t{0}, samples.size(), [&](std::size_t s) {
    const TexelSample& sample = samples[s];
    const Frame frame = viewerFrame(mesh, sample.triangle, sample.weights);
    const Vec3f wanted = field(samplePoint(mesh, sample), frame.normal);
    answered[s] = wanted.squaredNorm() > 0.0f ? 1 : 0;
    const Vec3f n = answered[s] != 0 ? Vec3f(wanted.normalized()) : frame.normal;
    tangentSpace[s] = Vec3f(n.dot(frame.tangent), n.dot(frame.bitangent), n.dot(frame.normal));
  });
  for (std::size_t s = 0; s < samples.size(); ++s) {
    values[samples[s].texel] = tangentSpace[s];
    weights[samples[s].texel] = 1.0f;
  }
  map.texelsFilled = samples.size();
  for (const std::uint8_t a : answered) map.texelsWithoutAnswer += a != 0 ? 0 : 1;
  if (map.texelsFilled > 0) pushPull(values, weights, atlas.width, atlas.height);
  map.rgb.resize(texels * 3);
  for (std::size_t i = 0; i < texels; ++i) {
    const Vec3f v = map.texelsFilled > 0 ? values[i] : Vec3f::UnitZ();
    for (int k = 0; k < 3; ++k) map.rgb[3 * i + static_cast<std::size_t>(k)] = toByte(v[k]);
  }
  return map;
}

Result<ColorMap> bakeColorMap(const GltfMesh& mesh, const PatchAtlas& atlas, const ColorField& field) {
  const std::vector<TexelSample> samples = patchTexels(atlas);
  std::vector<Vec3f> points;
  points.reserve(samples.size());
  for (const TexelSample& sample : samples) points.push_back(samplePoint(mesh, sample));
  auto colors = field(points);
  if (!colors) return colors.error();
  if (colors->size() != points.size())
    return internalError("the colour field answered {} of {} points", colors->size(), points.size());
  const std::size_t texels = std::size_t{atlas.width} * atlas.height;
  std::vector<Vec3f> values(texels, Vec3f::Zero());
  std::vector<float> weights(texels, 0.0f);
  for (std::size_t s = 0; s < samples.size(); ++s) {
    const Rgb8& c = (*colors)[s];
    values[samples[s].texel] = Vec3f(c.r, c.g, c.b);
    weights[samples[s].texel] = 1.0f;
  }
  if (!samples.empty()) pushPull(values, weights, atlas.width, atlas.height);
  ColorMap map;
  map.width = atlas.width;
  map.height = atlas.height;
  map.rgb.resize(texels * 3);
  for (std::size_t i = 0; i < texels; ++i)
    for (int k = 0; k < 3; ++k)
      map.rgb[3 * i + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::lround(std::clamp(values[i][k], 0.0f, 255.0f)));
  return map;
}

}  // namespace apo
