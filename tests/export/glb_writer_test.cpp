// The GLB container read back by a reader written here from the glTF 2.0
// specification's "Binary glTF Layout" (the Khronos validator checks the
// exported files in tests/export/gltf_validator_test).
#include "export/export.h"

#include "adapters/draco/draco_mesh.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace apo {
namespace {

std::uint32_t u32At(const std::string& bytes, std::size_t offset) {
  std::uint32_t value = 0;
  for (int k = 3; k >= 0; --k) value = value << 8 | static_cast<std::uint8_t>(bytes[offset + static_cast<std::size_t>(k)]);
  return value;
}

TEST(GlbWriter, HeaderChunksAndAccessorsFollowTheSpecification) {
  const Scan mesh = test::makeIcosphere(1);
  const auto atlas = packTrianglePatches(mesh, 64, 64, 1);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const GltfMesh gltf = patchMesh(mesh, *atlas);
  const std::string png = "\x89PNG not really an image, 37 bytes";
  const std::string glb = glbBytes(gltf, {png, {}}, "apo test", R"({"apo": {"map": [64, 64]}})");

  ASSERT_GE(glb.size(), 28u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_EQ(u32At(glb, 4), 2u);
  EXPECT_EQ(u32At(glb, 8), glb.size());
  const std::uint32_t jsonLength = u32At(glb, 12);
  EXPECT_EQ(glb.substr(16, 4), "JSON");
  EXPECT_EQ(jsonLength % 4, 0u);
  const auto json = nlohmann::json::parse(glb.substr(20, jsonLength));
  const std::size_t binHeader = 20 + jsonLength;
  const std::uint32_t binLength = u32At(glb, binHeader);
  EXPECT_EQ(glb.substr(binHeader + 4, 4), std::string("BIN\0", 4));
  EXPECT_EQ(binHeader + 8 + binLength, glb.size());
  const std::string bin = glb.substr(binHeader + 8, binLength);

  EXPECT_EQ(json["asset"]["version"], "2.0");
  EXPECT_EQ(json["asset"]["extras"]["apo"]["map"][0], 64);
  EXPECT_EQ(json["buffers"][0]["byteLength"], binLength);
  const auto& primitive = json["meshes"][0]["primitives"][0];
  const auto view = [&](int accessor) { return json["bufferViews"][json["accessors"][accessor]["bufferView"].get<int>()]; };
  // Every view 4-byte aligned and inside the buffer.
  for (const auto& v : json["bufferViews"]) {
    EXPECT_EQ(v["byteOffset"].get<std::size_t>() % 4, 0u);
    EXPECT_LE(v["byteOffset"].get<std::size_t>() + v["byteLength"].get<std::size_t>(), bin.size());
  }
  // Positions read back as written, min and max bounding them.
  const int positions = primitive["attributes"]["POSITION"];
  const auto& accessor = json["accessors"][positions];
  ASSERT_EQ(accessor["count"], gltf.positions.size());
  const std::size_t offset = view(positions)["byteOffset"];
  for (std::size_t i = 0; i < gltf.positions.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      float value = 0.0f;
      std::memcpy(&value, bin.data() + offset + 12 * i + 4 * static_cast<std::size_t>(k), 4);
      EXPECT_EQ(value, gltf.positions[i][k]);
      EXPECT_GE(value, accessor["min"][k].get<float>());
      EXPECT_LE(value, accessor["max"][k].get<float>());
    }
  for (const char* name : {"NORMAL", "TANGENT", "TEXCOORD_0"})
    EXPECT_EQ(json["accessors"][primitive["attributes"][name].get<int>()]["count"], gltf.positions.size()) << name;
  EXPECT_EQ(json["accessors"][primitive["indices"].get<int>()]["count"], gltf.indices.size());
  // The image's bytes, as given, behind the material's normal texture.
  const int texture = json["materials"][primitive["material"].get<int>()]["normalTexture"]["index"];
  const auto& image = json["images"][json["textures"][texture]["source"].get<int>()];
  EXPECT_EQ(image["mimeType"], "image/png");
  const auto& imageView = json["bufferViews"][image["bufferView"].get<int>()];
  EXPECT_EQ(bin.substr(imageView["byteOffset"], imageView["byteLength"]), png);
  // Without a colour map: one image, a grey base colour and no base colour texture.
  EXPECT_EQ(json["images"].size(), 1u);
  const auto& pbr = json["materials"][0]["pbrMetallicRoughness"];
  EXPECT_FALSE(pbr.contains("baseColorTexture"));
  EXPECT_EQ(pbr["baseColorFactor"][0], 0.8);
  // Tangents: unit, orthogonal to their normals, w = +1 (no mirrored patch).
  for (std::size_t i = 0; i < gltf.tangents.size(); ++i) {
    EXPECT_NEAR(gltf.tangents[i].head<3>().norm(), 1.0f, 1e-5f);
    EXPECT_NEAR(gltf.tangents[i].head<3>().dot(gltf.normals[i]), 0.0f, 1e-5f);
    EXPECT_EQ(gltf.tangents[i].w(), 1.0f);
  }
  // The same bytes every time.
  EXPECT_EQ(glbBytes(gltf, {png, {}}, "apo test", R"({"apo": {"map": [64, 64]}})"), glb);
}

// With a colour map: the material's baseColorTexture names its bytes, on
// the same UVs, the normal texture unchanged.
TEST(GlbWriter, AColourMapBecomesTheBaseColourTexture) {
  const Scan mesh = test::makeIcosphere(1);
  const auto atlas = packTrianglePatches(mesh, 64, 64, 1);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const std::string normals = "\x89PNG the normals", colors = "\x89PNG the colours, 26 b";
  const std::string glb = glbBytes(patchMesh(mesh, *atlas), {normals, colors}, "apo test", "");
  const std::uint32_t jsonLength = u32At(glb, 12);
  const auto json = nlohmann::json::parse(glb.substr(20, jsonLength));
  const std::string bin = glb.substr(20 + jsonLength + 8);
  const auto imageBytes = [&](int texture) {
    const auto& image = json["images"][json["textures"][texture]["source"].get<int>()];
    const auto& view = json["bufferViews"][image["bufferView"].get<int>()];
    return bin.substr(view["byteOffset"], view["byteLength"]);
  };
  const auto& material = json["materials"][0];
  EXPECT_EQ(imageBytes(material["normalTexture"]["index"]), normals);
  EXPECT_EQ(imageBytes(material["pbrMetallicRoughness"]["baseColorTexture"]["index"]), colors);
  EXPECT_FALSE(material["pbrMetallicRoughness"]["baseColorTexture"].contains("texCoord"));  // TEXCOORD_0, the patches
  EXPECT_EQ(material["pbrMetallicRoughness"]["baseColorFactor"], nlohmann::json::array({1.0, 1.0, 1.0, 1.0}));
}

// Draco: the compressed primitive decodes (Draco's own decoder) to the same
// triangles within its quantisation, and the GLB names it as
// KHR_draco_mesh_compression says: accessors without buffer views stating
// the decoded counts, the extension used and required.
TEST(GlbWriter, DracoCompressedPrimitiveDecodesToTheSameTriangles) {
  const Scan mesh = test::makeIcosphere(2);
  const auto atlas = packTrianglePatches(mesh, 256, 256, 1);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  const GltfMesh gltf = patchMesh(mesh, *atlas);
  const auto draco = dracoCompress(gltf);
  ASSERT_TRUE(draco.ok()) << draco.error().message;
  EXPECT_EQ(draco->faces, mesh.triangles.size());
  auto decoded = draco_adapter::decodeMesh(draco->bytes, draco->position, draco->normal, draco->tangent, draco->texcoord);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  ASSERT_EQ(decoded->indices.size(), gltf.indices.size());
  EXPECT_EQ(decoded->positions.size() / 3, draco->points);
  // Every decoded corner lies on an original corner with the same UV and
  // nearly the same normal (brute force over the originals).
  double worstPosition = 0.0, worstUv = 0.0, worstNormal = 0.0;
  for (std::uint32_t index : decoded->indices) {
    const Vec3f p(decoded->positions[3 * index], decoded->positions[3 * index + 1], decoded->positions[3 * index + 2]);
    const Vec2f uv(decoded->texcoords[2 * index], decoded->texcoords[2 * index + 1]);
    const Vec3f n(decoded->normals[3 * index], decoded->normals[3 * index + 1], decoded->normals[3 * index + 2]);
    double best = 1e9;
    std::size_t match = 0;
    for (std::size_t v = 0; v < gltf.positions.size(); ++v) {
      const double d = (gltf.positions[v] - p).norm() + (gltf.uvs[v] - uv).norm();
      if (d < best) best = d, match = v;
    }
    worstPosition = std::max(worstPosition, static_cast<double>((gltf.positions[match] - p).norm()));
    worstUv = std::max(worstUv, static_cast<double>((gltf.uvs[match] - uv).norm()));
    worstNormal = std::max(worstNormal, std::acos(std::clamp(static_cast<double>(gltf.normals[match].dot(n.normalized())), -1.0, 1.0)));
  }
  EXPECT_LT(worstPosition, 2.0 * 2.0 / (1 << 14));  // the unit sphere over 14 bits
  EXPECT_LT(worstUv, 2.0 / (1 << 16));
  EXPECT_LT(worstNormal * 180.0 / 3.14159265358979, 0.5);

  const std::string glb = glbBytes(gltf, {"png", {}}, "apo test", "", &*draco);
  const auto json = nlohmann::json::parse(glb.substr(20, u32At(glb, 12)));
  EXPECT_EQ(json["extensionsUsed"], nlohmann::json::array({"KHR_draco_mesh_compression"}));
  EXPECT_EQ(json["extensionsRequired"], nlohmann::json::array({"KHR_draco_mesh_compression"}));
  const auto& primitive = json["meshes"][0]["primitives"][0];
  const auto& extension = primitive["extensions"]["KHR_draco_mesh_compression"];
  EXPECT_EQ(extension["attributes"]["POSITION"], draco->position);
  EXPECT_EQ(extension["attributes"]["TEXCOORD_0"], draco->texcoord);
  for (const auto& accessor : json["accessors"]) EXPECT_FALSE(accessor.contains("bufferView"));
  EXPECT_EQ(json["accessors"][primitive["indices"].get<int>()]["count"], 3 * mesh.triangles.size());
  const auto& view = json["bufferViews"][extension["bufferView"].get<int>()];
  const std::size_t binStart = 20 + u32At(glb, 12) + 8;
  EXPECT_EQ(glb.substr(binStart + view["byteOffset"].get<std::size_t>(), view["byteLength"]), draco->bytes);
  // Smaller than the plain primitive.
  EXPECT_LT(glb.size(), glbBytes(gltf, {"png", {}}, "apo test", "").size() / 2);
}

}  // namespace
}  // namespace apo
