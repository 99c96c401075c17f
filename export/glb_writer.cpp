// The GLB container (glTF 2.0, section "Binary glTF Layout"): a 12-byte
// header, a JSON chunk padded with spaces, a BIN chunk padded with zeros,
// every buffer view 4-byte aligned.
#include "export/export.h"

#include "adapters/draco/draco_mesh.h"

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

Result<DracoPrimitive> dracoCompress(const GltfMesh& mesh) {
  draco_adapter::FlatMesh flat;
  for (const Vec3f& p : mesh.positions) flat.positions.insert(flat.positions.end(), {p.x(), p.y(), p.z()});
  for (const Vec3f& n : mesh.normals) flat.normals.insert(flat.normals.end(), {n.x(), n.y(), n.z()});
  for (const Eigen::Vector4f& t : mesh.tangents) flat.tangents.insert(flat.tangents.end(), {t.x(), t.y(), t.z(), t.w()});
  for (const Vec2f& uv : mesh.uvs) flat.texcoords.insert(flat.texcoords.end(), {uv.x(), uv.y()});
  flat.indices = mesh.indices;
  auto encoded = draco_adapter::encodeMesh(flat);
  if (!encoded) return encoded.error();
  DracoPrimitive draco;
  draco.bytes = std::move(encoded->bytes);
  draco.position = encoded->position;
  draco.normal = encoded->normal;
  draco.tangent = encoded->tangent;
  draco.texcoord = encoded->texcoord;
  draco.points = encoded->points;
  draco.faces = encoded->faces;
  draco.low = encoded->low;
  draco.high = encoded->high;
  return draco;
}

std::string glbBytes(const GltfMesh& mesh, const GlbImages& images, const std::string& generator,
                     const std::string& extras, const DracoPrimitive* draco) {
  std::string bin;
  Json views = Json::array(), accessors = Json::array();
  Json primitive = {{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TANGENT", 2}, {"TEXCOORD_0", 3}}},
                    {"indices", 4},
                    {"material", 0}};
  if (draco == nullptr) {
    // The vertex attributes as plain float arrays (Eigen's fixed vectors are packed floats).
    const int positions = addView(bin, views, mesh.positions, kArrayBuffer);
    const int normals = addView(bin, views, mesh.normals, kArrayBuffer);
    const int tangents = addView(bin, views, mesh.tangents, kArrayBuffer);
    const int uvs = addView(bin, views, mesh.uvs, kArrayBuffer);
    const int indices = addView(bin, views, mesh.indices, kElementArrayBuffer);
    Vec3f low = Vec3f::Constant(std::numeric_limits<float>::max()), high = -low;
    for (const Vec3f& p : mesh.positions) low = low.cwiseMin(p), high = high.cwiseMax(p);
    Json position = floatAccessor(positions, mesh.positions.size(), "VEC3");
    position["min"] = {low.x(), low.y(), low.z()};
    position["max"] = {high.x(), high.y(), high.z()};
    accessors.push_back(std::move(position));
    accessors.push_back(floatAccessor(normals, mesh.normals.size(), "VEC3"));
    accessors.push_back(floatAccessor(tangents, mesh.tangents.size(), "VEC4"));
    accessors.push_back(floatAccessor(uvs, mesh.uvs.size(), "VEC2"));
    accessors.push_back(
        {{"bufferView", indices}, {"componentType", kUnsignedInt}, {"count", mesh.indices.size()}, {"type", "SCALAR"}});
  } else {
    // KHR_draco_mesh_compression: the accessors state what the decoder gives
    // and point at no buffer view; the compressed bytes have their own.
    const std::vector<char> compressed(draco->bytes.begin(), draco->bytes.end());
    const int view = addView(bin, views, compressed, 0);
    const auto decoded = [&](const char* type) {
      return Json{{"componentType", kFloat}, {"count", draco->points}, {"type", type}};
    };
    Json position = decoded("VEC3");
    position["min"] = draco->low;
    position["max"] = draco->high;
    accessors.push_back(std::move(position));
    accessors.push_back(decoded("VEC3"));
    accessors.push_back(decoded("VEC4"));
    accessors.push_back(decoded("VEC2"));
    accessors.push_back({{"componentType", kUnsignedInt}, {"count", std::uint64_t{draco->faces} * 3}, {"type", "SCALAR"}});
    primitive["extensions"]["KHR_draco_mesh_compression"] = {
        {"bufferView", view},
        {"attributes",
         {{"POSITION", draco->position}, {"NORMAL", draco->normal}, {"TANGENT", draco->tangent}, {"TEXCOORD_0", draco->texcoord}}}};
  }
  Json imageList = Json::array(), textures = Json::array();
  for (const std::string* png : {&images.normalPng, &images.colorPng}) {
    if (png->empty()) continue;
    const int view = addView(bin, views, std::vector<char>(png->begin(), png->end()), 0);
    textures.push_back({{"sampler", 0}, {"source", imageList.size()}});
    imageList.push_back({{"bufferView", view}, {"mimeType", "image/png"}});
  }
  const bool colored = !images.colorPng.empty();
  Json pbr = {{"baseColorFactor", colored ? Json{1.0, 1.0, 1.0, 1.0} : Json{0.8, 0.8, 0.8, 1.0}},
              {"metallicFactor", 0.0},
              {"roughnessFactor", 0.7}};
  if (colored) pbr["baseColorTexture"] = {{"index", 1}};

  Json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", generator}};
  if (!extras.empty()) gltf["asset"]["extras"] = Json::parse(extras);
  gltf["scene"] = 0;
  gltf["scenes"] = Json::array({{{"nodes", {0}}}});
  gltf["nodes"] = Json::array({{{"mesh", 0}}});
  if (draco != nullptr) {
    gltf["extensionsUsed"] = Json::array({"KHR_draco_mesh_compression"});
    gltf["extensionsRequired"] = Json::array({"KHR_draco_mesh_compression"});
  }
  gltf["meshes"] = Json::array({{{"primitives", Json::array({std::move(primitive)})}}});
  gltf["materials"] = Json::array({{{"pbrMetallicRoughness", std::move(pbr)}, {"normalTexture", {{"index", 0}}}}});
  gltf["samplers"] = Json::array(
      {{{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}, {"wrapS", kClampToEdge}, {"wrapT", kClampToEdge}}});
  gltf["images"] = std::move(imageList);
  gltf["textures"] = std::move(textures);
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
