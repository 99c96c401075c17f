// Wavefront OBJ geometry: "v x y z [w] [r g b]", "vn x y z" and polygon faces
// "f" with corners "i", "i/t", "i//n" or "i/t/n" (1-based, or negative to
// count back from the last element defined so far). Everything else (vt,
// groups, materials, lines, points, smoothing) does not describe the surface
// and is skipped.
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace apo::readers {
namespace {

using parse::fail;
using parse::TextCursor;

// Per-vertex normal bookkeeping: OBJ attaches normals to face corners, not to
// vertices. These mark vertices no corner has given a normal yet.
constexpr std::uint32_t kObjUnreferenced = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint32_t kObjNoNormal = kObjUnreferenced - 1;
constexpr std::size_t kObjMaxVertices = kObjNoNormal;

struct ObjCorner {
  std::uint32_t vertex = 0;
  std::uint32_t normal = kObjNoNormal;
};

struct ObjContent {
  PointSet points;  // positions, and colors while every vertex so far has one
  std::vector<Vec3f> normals;  // "vn" lines, in file order
  // Per vertex: the normal of its first corner that has one, kObjNoNormal if
  // its corners have none, kObjUnreferenced if it is in no face. Grown only
  // when faces are read, so point clouds do not pay for it.
  std::vector<std::uint32_t> vertexNormal;
  bool anyCornerNormal = false;
  std::vector<Triangle> triangles;
  std::vector<ObjCorner> face;  // reused for every "f" line
};

float objValue(const TextCursor& cursor, std::string_view token) {
  // Doubles beyond float range round to infinities, which cleaning drops.
  return static_cast<float>(cursor.number(token, "a vertex"));
}

Vec3f objVector(const TextCursor& cursor, const std::string_view* tokens) {
  return {objValue(cursor, tokens[0]), objValue(cursor, tokens[1]), objValue(cursor, tokens[2])};
}

std::uint8_t objColorChannel(const TextCursor& cursor, std::string_view token) {
  const double value = cursor.number(token, "a vertex color");
  if (!(value >= 0.0 && value <= 1.0))
    fail("line {}: vertex color value {} out of range 0..1", cursor.lineNumber(), parse::quoted(token));
  return static_cast<std::uint8_t>(std::lround(value * 255.0));
}

// Colors are kept only if every vertex has one: the first vertex without a
// color drops them all.
void addObjVertex(const TextCursor& cursor, const std::vector<std::string_view>& tokens, ObjContent& obj) {
  const std::size_t values = tokens.size() - 1;
  if (values != 3 && values != 4 && values != 6 && values != 7)
    fail("line {}: expected 'v x y z [w] [r g b]', got {} values", cursor.lineNumber(), values);
  if (obj.points.positions.size() == kObjMaxVertices)
    fail("line {}: more than {} vertices", cursor.lineNumber(), kObjMaxVertices);
  PointSet& points = obj.points;
  points.positions.push_back(objVector(cursor, &tokens[1]));
  if (values == 4 || values == 7) objValue(cursor, tokens[4]);  // w: validated, not kept

  if (values < 6) {
    points.colors.clear();
    return;
  }
  const std::string_view* rgb = &tokens[values - 2];
  const Rgb8 color{objColorChannel(cursor, rgb[0]), objColorChannel(cursor, rgb[1]),
                   objColorChannel(cursor, rgb[2])};
  const bool everyVertexSoFarHasColor = points.colors.size() + 1 == points.positions.size();
  if (everyVertexSoFarHasColor) points.colors.push_back(color);
}

void addObjNormal(const TextCursor& cursor, const std::vector<std::string_view>& tokens, ObjContent& obj) {
  if (tokens.size() != 4) fail("line {}: expected 'vn x y z', got {} values", cursor.lineNumber(), tokens.size() - 1);
  obj.normals.push_back(objVector(cursor, &tokens[1]));
}

// Resolves a 1-based or negative (relative) OBJ index against the `count`
// elements defined so far.
std::uint32_t objIndex(const TextCursor& cursor, std::string_view token, std::size_t count,
                       std::string_view element, std::string_view elements) {
  const std::int64_t index = cursor.integer(token, "a face");
  const std::int64_t resolved = index > 0 ? index - 1 : static_cast<std::int64_t>(count) + index;
  if (index == 0 || resolved < 0 || static_cast<std::uint64_t>(resolved) >= count)
    fail("line {}: {} index {} out of range ({} {} defined so far)", cursor.lineNumber(), element, index, count,
         elements);
  return static_cast<std::uint32_t>(resolved);
}

// "i", "i/t", "i//n" or "i/t/n"; texture indices are not used.
ObjCorner parseObjCorner(const TextCursor& cursor, std::string_view token, const ObjContent& obj) {
  const std::size_t firstSlash = token.find('/');
  ObjCorner corner;
  corner.vertex = objIndex(cursor, token.substr(0, firstSlash), obj.points.size(), "vertex", "vertices");
  if (firstSlash == std::string_view::npos) return corner;
  const std::size_t secondSlash = token.find('/', firstSlash + 1);
  if (secondSlash == std::string_view::npos) return corner;
  corner.normal = objIndex(cursor, token.substr(secondSlash + 1), obj.normals.size(), "normal", "normals");
  return corner;
}

void recordCornerNormals(const std::vector<ObjCorner>& face, ObjContent& obj) {
  if (obj.vertexNormal.size() < obj.points.size()) obj.vertexNormal.resize(obj.points.size(), kObjUnreferenced);
  for (const ObjCorner& corner : face) {
    std::uint32_t& normal = obj.vertexNormal[corner.vertex];
    if (normal == kObjUnreferenced || normal == kObjNoNormal) normal = corner.normal;
    obj.anyCornerNormal |= corner.normal != kObjNoNormal;
  }
}

// Fan-triangulates the polygon around its first corner.
void addObjFace(const TextCursor& cursor, const std::vector<std::string_view>& tokens, ObjContent& obj) {
  if (tokens.size() < 4)
    fail("line {}: face has {} vertices, a face needs at least 3", cursor.lineNumber(), tokens.size() - 1);
  obj.face.clear();
  for (std::size_t i = 1; i < tokens.size(); ++i) obj.face.push_back(parseObjCorner(cursor, tokens[i], obj));
  for (std::size_t i = 2; i < obj.face.size(); ++i)
    obj.triangles.push_back({obj.face[0].vertex, obj.face[i - 1].vertex, obj.face[i].vertex});
  recordCornerNormals(obj.face, obj);
}

// Meshes: one normal per vertex from its face corners, kept only if every
// vertex in a face has one. Vertices in no face get a zero normal; cleaning
// drops unreferenced vertices before normals are used. Point clouds: "vn"
// lines pair with "v" lines by order when there are as many.
std::vector<Vec3f> objVertexNormals(ObjContent& obj) {
  if (obj.triangles.empty())
    return obj.normals.size() == obj.points.size() ? std::move(obj.normals) : std::vector<Vec3f>{};
  if (!obj.anyCornerNormal) return {};
  obj.vertexNormal.resize(obj.points.size(), kObjUnreferenced);
  std::vector<Vec3f> normals;
  normals.reserve(obj.points.size());
  for (const std::uint32_t normal : obj.vertexNormal) {
    if (normal == kObjNoNormal) return {};
    normals.push_back(normal == kObjUnreferenced ? Vec3f::Zero() : obj.normals[normal]);
  }
  return normals;
}

[[noreturn]] void failNoObjVertices(const TextCursor& cursor) {
  if (cursor.lineNumber() == 0) fail("line 1: empty file");
  fail("line {}: no points: the file has no 'v' lines", cursor.lineNumber());
}

}  // namespace

Scan readObj(std::string_view bytes) {
  TextCursor cursor(bytes);
  std::vector<std::string_view> tokens;
  ObjContent obj;
  std::string_view line;
  while (cursor.next(line)) {
    // Trailing comments are not in the OBJ spec, but some writers emit them.
    parse::splitWhitespace(line.substr(0, line.find('#')), tokens);
    if (tokens.empty()) continue;
    const std::string_view keyword = tokens.front();
    if (keyword == "v") addObjVertex(cursor, tokens, obj);
    else if (keyword == "vn") addObjNormal(cursor, tokens, obj);
    else if (keyword == "f") addObjFace(cursor, tokens, obj);
  }
  if (obj.points.size() == 0) failNoObjVertices(cursor);

  Scan scan;
  scan.points.normals = objVertexNormals(obj);
  scan.points.positions = std::move(obj.points.positions);
  scan.points.colors = std::move(obj.points.colors);
  scan.triangles = std::move(obj.triangles);
  return scan;
}

}  // namespace apo::readers
