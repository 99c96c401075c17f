// The GLB container (glTF 2.0, section "Binary glTF Layout"): a 12-byte
// header, a JSON chunk padded with spaces, a BIN chunk padded with zeros,
// every buffer view 4-byte aligned.
#include "export/export.h"

#include <nlohmann/json.hpp>

#include <cstring>
#include <limits>

namespace apo {
namespace {

using Json = nlohmann::ordered_json;

// glTF's numeric constants.
constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kLinear = 9729, kLinearMipmapLinear = 9987, kClampToEdge = 33071;

void appendRaw(std::string& bin, const void* data, std::size_t bytes) {
  bin.append(static_cast<const char*>(data), bytes);
  while (bin.size() % 4 != 0) bin.push_back('\0');
}

// Appends the values as a buffer view (and returns its index).
template <class T>
int addView(std::string& bin, Json& views, const std::vector<T>& values, int target) {
  const std::size_t offset = bin.size(), bytes = values.size() * sizeof(T);
  appendRaw(bin, values.data(), bytes);
  Json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}};
  if (target != 0) view["target"] = target;
  views.push_back(std::move(view));
  return static_cast<int>(views.size() - 1);
}

Json floatAccessor(int view, std::size_t count, const char* type) {
  return {{"bufferView", view}, {"componentType", kFloat}, {"count", count}, {"type", type}};
}

void appendU32(std::string& out, std::uint32_t value) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((value >> (8 * k)) & 0xFFu));
}

}  // namespace

std::string glbBytes(const GltfMesh& mesh, const std::string& normalPng, const std::string& generator,
                     const std::string& extras) {
  std::string bin;
  Json views = Json::array(), accessors = Json::array();
  // The vertex attributes as plain float arrays (Eigen's fixed vectors are packed floats).
  const int positions = addView(bin, views, mesh.positions, kArrayBuffer);
  const int normals = addView(bin, views, mesh.normals, kArrayBuffer);
  const int tangents = addView(bin, views, mesh.tangents, kArrayBuffer);
  const int uvs = addView(bin, views, mesh.uvs, kArrayBuffer);
  const int indices = addView(bin, views, mesh.indices, kElementArrayBuffer);
  const std::vector<char> pngBytes(normalPng.begin(), normalPng.end());
  const int image = addView(bin, views, pngBytes, 0);

  Vec3f low = Vec3f::Constant(std::numeric_limits<float>::max()), high = -low;
  for (const Vec3f& p : mesh.positions) low = low.cwiseMin(p), high = high.cwiseMax(p);
  Json position = floatAccessor(positions, mesh.positions.size(), "VEC3");
  position["min"] = {low.x(), low.y(), low.z()};
  position["max"] = {high.x(), high.y(), high.z()};
  accessors.push_back(std::move(position));
  accessors.push_back(floatAccessor(normals, mesh.normals.size(), "VEC3"));
  accessors.push_back(floatAccessor(tangents, mesh.tangents.size(), "VEC4"));
  accessors.push_back(floatAccessor(uvs, mesh.uvs.size(), "VEC2"));
  accessors.push_back({{"bufferView", indices}, {"componentType", kUnsignedInt}, {"count", mesh.indices.size()}, {"type", "SCALAR"}});

  Json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", generator}};
  if (!extras.empty()) gltf["asset"]["extras"] = Json::parse(extras);
  gltf["scene"] = 0;
  gltf["scenes"] = Json::array({{{"nodes", {0}}}});
  gltf["nodes"] = Json::array({{{"mesh", 0}}});
  gltf["meshes"] = Json::array({{{"primitives",
                                  Json::array({{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TANGENT", 2}, {"TEXCOORD_0", 3}}},
                                                {"indices", 4},
                                                {"material", 0}}})}}});
  gltf["materials"] = Json::array({{{"pbrMetallicRoughness",
                                     {{"baseColorFactor", {0.8, 0.8, 0.8, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.7}}},
                                    {"normalTexture", {{"index", 0}}}}});
  gltf["samplers"] = Json::array(
      {{{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}, {"wrapS", kClampToEdge}, {"wrapT", kClampToEdge}}});
  gltf["images"] = Json::array({{{"bufferView", image}, {"mimeType", "image/png"}}});
  gltf["textures"] = Json::array({{{"sampler", 0}, {"source", 0}}});
  gltf["accessors"] = std::move(accessors);
  gltf["bufferViews"] = std::move(views);
  gltf["buffers"] = Json::array({{{"byteLength", bin.size()}}});

  std::string json = gltf.dump();
  while (json.size() % 4 != 0) json.push_back(' ');
  std::string glb;
  glb.reserve(12 + 8 + json.size() + 8 + bin.size());
  glb += "glTF";
  appendU32(glb, 2);
  appendU32(glb, static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  appendU32(glb, static_cast<std::uint32_t>(json.size()));
  glb += "JSON";
  glb += json;
  appendU32(glb, static_cast<std::uint32_t>(bin.size()));
  glb += std::string("BIN\0", 4);
  glb += bin;
  return glb;
}

}  // namespace apo
