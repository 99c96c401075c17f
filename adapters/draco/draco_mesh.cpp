// Draco behind plain data (adapters/draco/draco_mesh.h).
#include "adapters/draco/draco_mesh.h"

#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include <algorithm>
#include <limits>

namespace draco_adapter {
namespace {

// Each corner's value of one attribute, face by face.
void setFaces(draco::TriangleSoupMeshBuilder& builder, int attribute, const std::vector<float>& values, int components,
              const std::vector<std::uint32_t>& indices) {
  const auto at = [&](std::uint32_t vertex) { return values.data() + static_cast<std::size_t>(vertex) * components; };
  for (std::size_t f = 0; f < indices.size() / 3; ++f)
    builder.SetAttributeValuesForFace(attribute, draco::FaceIndex(static_cast<std::uint32_t>(f)), at(indices[3 * f]),
                                      at(indices[3 * f + 1]), at(indices[3 * f + 2]));
}

std::vector<float> valuesOf(const draco::PointAttribute& attribute, std::uint32_t points, int components) {
  std::vector<float> values(static_cast<std::size_t>(points) * components);
  for (std::uint32_t p = 0; p < points; ++p)
    attribute.ConvertValue<float>(attribute.mapped_index(draco::PointIndex(p)), static_cast<std::int8_t>(components),
                                  values.data() + static_cast<std::size_t>(p) * components);
  return values;
}

}  // namespace

apo::Result<Encoded> encodeMesh(const FlatMesh& mesh, const Quantization& bits) {
  const std::size_t vertices = mesh.positions.size() / 3, faces = mesh.indices.size() / 3;
  if (faces == 0 || mesh.normals.size() != vertices * 3 || mesh.tangents.size() != vertices * 4 ||
      mesh.texcoords.size() != vertices * 2)
    return apo::internalError("Draco: {} faces over {} vertices with mismatched attributes", faces, vertices);
  for (std::uint32_t index : mesh.indices)
    if (index >= vertices) return apo::internalError("Draco: index {} past {} vertices", index, vertices);
  draco::TriangleSoupMeshBuilder builder;
  builder.Start(static_cast<int>(faces));
  const int position = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  const int normal = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
  const int tangent = builder.AddAttribute(draco::GeometryAttribute::GENERIC, 4, draco::DT_FLOAT32);
  const int texcoord = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
  setFaces(builder, position, mesh.positions, 3, mesh.indices);
  setFaces(builder, normal, mesh.normals, 3, mesh.indices);
  setFaces(builder, tangent, mesh.tangents, 4, mesh.indices);
  setFaces(builder, texcoord, mesh.texcoords, 2, mesh.indices);
  std::unique_ptr<draco::Mesh> built = builder.Finalize();
  if (!built) return apo::internalError("Draco could not build the mesh");

  draco::ExpertEncoder encoder(*built);
  encoder.SetAttributeQuantization(position, bits.position);
  encoder.SetAttributeQuantization(normal, bits.normal);
  encoder.SetAttributeQuantization(tangent, bits.tangent);
  encoder.SetAttributeQuantization(texcoord, bits.texcoord);
  encoder.SetSpeedOptions(5, 5);
  encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
  draco::EncoderBuffer buffer;
  if (const draco::Status status = encoder.EncodeToBuffer(&buffer); !status.ok())
    return apo::internalError("Draco could not encode the mesh: {}", status.error_msg_string());
  Encoded encoded;
  encoded.bytes.assign(buffer.data(), buffer.size());
  encoded.position = static_cast<int>(built->attribute(position)->unique_id());
  encoded.normal = static_cast<int>(built->attribute(normal)->unique_id());
  encoded.tangent = static_cast<int>(built->attribute(tangent)->unique_id());
  encoded.texcoord = static_cast<int>(built->attribute(texcoord)->unique_id());
  // The decoder's counts, which glTF's accessors must state.
  auto decoded = decodeMesh(encoded.bytes, encoded.position, encoded.normal, encoded.tangent, encoded.texcoord);
  if (!decoded) return decoded.error();
  encoded.points = static_cast<std::uint32_t>(decoded->positions.size() / 3);
  encoded.faces = static_cast<std::uint32_t>(decoded->indices.size() / 3);
  encoded.low.fill(std::numeric_limits<float>::max());
  encoded.high.fill(std::numeric_limits<float>::lowest());
  for (std::size_t i = 0; i < decoded->positions.size(); ++i) {
    encoded.low[i % 3] = std::min(encoded.low[i % 3], decoded->positions[i]);
    encoded.high[i % 3] = std::max(encoded.high[i % 3], decoded->positions[i]);
  }
  return encoded;
}

apo::Result<FlatMesh> decodeMesh(const std::string& bytes, int position, int normal, int tangent, int texcoord) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) return apo::badInput("Draco could not decode the mesh: {}", decoded.status().error_msg_string());
  const draco::Mesh& mesh = *decoded.value();
  const std::uint32_t points = mesh.num_points();
  FlatMesh flat;
  const std::pair<int, int> wanted[] = {{position, 3}, {normal, 3}, {tangent, 4}, {texcoord, 2}};
  std::vector<float>* into[] = {&flat.positions, &flat.normals, &flat.tangents, &flat.texcoords};
  for (int k = 0; k < 4; ++k) {
    const draco::PointAttribute* attribute = mesh.GetAttributeByUniqueId(static_cast<std::uint32_t>(wanted[k].first));
    if (attribute == nullptr || attribute->num_components() != wanted[k].second)
      return apo::badInput("the Draco mesh has no attribute {} of {} components", wanted[k].first, wanted[k].second);
    *into[k] = valuesOf(*attribute, points, wanted[k].second);
  }
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) flat.indices.push_back(mesh.face(draco::FaceIndex(f))[k].value());
  return flat;
}

}  // namespace draco_adapter
