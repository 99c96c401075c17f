// Internal to reconstruct: figures of a mesh counted on its triangles as a
// soup (our own code, no library), and an even sampling of its surface.
// measureMesh (reconstruct.h) is the public face of the first.
#pragma once

#include "core/geometry.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace apo {

// Component index of each triangle (triangles sharing an edge are
// connected), numbered in the order of their first triangle.
struct TriangleComponents {
  std::vector<std::uint32_t> ofTriangle;
  std::uint32_t count = 0;
};
TriangleComponents triangleComponents(const Scan& mesh);

// Deterministic sampling of a mesh's surface: `count` points spread in
// proportion to area (fixed seed); none when the mesh has no area.
std::vector<Vec3f> sampleSurface(const Scan& mesh, std::size_t count);

}  // namespace apo
