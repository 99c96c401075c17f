// What the report's interactive viewer (report.h viewerHtml) draws: plain
// data made by render/ (webglScene: its GLSL ES shaders, m, M and the APO
// texture as WebGL2 takes them) and turned into a page by report/, which
// knows nothing of GL. Cameras are render's views.
#pragma once

#include "core/geometry.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace apo {

// A pinhole camera looking at `target`; images are square in the OSMesa
// passes, and the viewer keeps the vertical field of view.
struct Camera {
  Vec3f eye = Vec3f::Zero(), target = Vec3f::Zero(), up = Vec3f::UnitY();
  float fovYDegrees = 30.0f;
  float nearPlane = 0.1f, farPlane = 10.0f;
  std::string label;  // where the eye is from the target: "+x", "-y", "+x-y+z", ...
  // Of a one-sided scan: whether the view looks at the scanned side (its
  // eye on the side m's normals face); none for a surface seen all round.
  std::optional<bool> seesScannedSide;
};

// A uniform of a WebGL2 program: its GLSL name, the WebGL call's suffix
// ("1i", "1ui", "1f", "3f") and its values.
struct ViewerUniform {
  std::string name;
  std::string type;
  std::vector<double> values;
};

// A mesh (indices set, 3 per triangle) or points (radii set: each point's
// disc), with one normal per vertex.
struct ViewerGeometry {
  std::vector<float> positions, normals, radii;  // 3, 3 and 1 per vertex
  std::vector<std::uint32_t> indices;
  std::string description;  // what it is, for the viewer's label ("M, 69,451 triangles")
  bool isMesh() const { return !indices.empty(); }
};

// The shaders, each a complete GLSL ES 3.00 text. Every fragment shader
// writes the shaded colour to output 0 and the normal and coverage to
// output 1, as the OSMesa passes do.
struct ViewerShaders {
  std::string meshVertex, meshFragment;    // a mesh with its vertex normals
  std::string apoFragment;                 // m with the APO (uses meshVertex)
  std::string pointVertex, pointFragment;  // points as discs facing the eye
  std::string screenVertex, heatFragment;  // the angle between two normal buffers, coloured
};

struct ViewerScene {
  ViewerShaders shaders;
  std::vector<ViewerUniform> apoUniforms;  // besides the camera's and the textures' units
  std::uint32_t textureWidth = 0, textureHeight = 0;
  std::vector<std::uint8_t> texture;  // the APO, RGBA8 unsigned integers
  ViewerGeometry coarse, detail;      // m; M (or its preview), empty when there is none
  std::vector<Camera> views;          // the report's standard views, in its order
  bool mipmapping = true, filtering = false;  // the run's render options
  float heatMapDegrees = 10.0f;       // the heat map's full scale
  float boundingRadius = 1.0f;        // of m, about views[0].target
};

}  // namespace apo
