// Draco mesh compression (Debian libdraco-dev) behind plain data: the
// glTF export's KHR_draco_mesh_compression, and its decoder for the tests.
#pragma once

#include "core/error.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace draco_adapter {

// A triangle mesh as flat float arrays (3 per position and normal, 4 per
// tangent, 2 per texture coordinate) and 3 indices per triangle.
struct FlatMesh {
  std::vector<float> positions, normals, tangents, texcoords;
  std::vector<std::uint32_t> indices;
};

// Quantisation bits per attribute (Draco's own defaults are coarser for
// texture coordinates than a 1024^2 map tolerates).
struct Quantization {
  int position = 14, normal = 12, tangent = 12, texcoord = 16;
};

// The compressed bytes and what glTF's extension names: each attribute's
// Draco unique id, and the decoded point and face counts.
struct Encoded {
  std::string bytes;
  int position = -1, normal = -1, tangent = -1, texcoord = -1;
  std::uint32_t points = 0, faces = 0;
  std::array<float, 3> low{}, high{};  // the decoded positions' bounds (glTF's accessor min and max)
};

// Edgebreaker at speed 5; the same bytes for the same mesh.
apo::Result<Encoded> encodeMesh(const FlatMesh& mesh, const Quantization& bits = {});

// Decodes bytes made by encodeMesh (or any Draco mesh with those four
// attributes, by unique id): per point and per face, as FlatMesh.
apo::Result<FlatMesh> decodeMesh(const std::string& bytes, int position, int normal, int tangent, int texcoord);

}  // namespace draco_adapter
