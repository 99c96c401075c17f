// Reproducible inputs and a quality measure for the bake benchmark
// (bench/bake_bench.sh, docs/benchmarks.md "The paper: Lacoste et al. 2007, Table 1"):
//
//   make_detail_mesh displace IN OUT.ply [--amplitude 0.001] [--period-edges 50]
//       Moves every vertex of the mesh IN along its area-weighted normal by
//       amplitude x diag x sin(w x) sin(w y) sin(w z) (coordinates from the
//       bbox minimum, w = 2 pi / (period-edges x the mean edge length)): bumps
//       half a period, 25 triangles, wide, tilting the normal by up to
//       atan(amplitude x diag x w).
//   make_detail_mesh torus M.ply m.ply [--nu 3000 --nv 1200 --coarse-nu 150 --coarse-nv 50]
//                    [--amplitude 0.001] [--period-edges 50] [--coarse-shift-u 0.3 --coarse-shift-v 0.6]
//       A torus (R = 1, r = 0.4) as an nu x nv grid (2 nu nv triangles) whose
//       vertices move along the tube's normal by amplitude x diag x
//       sin(ku u) sin(kv v), ku = round(nu / period-edges),
//       kv = round(nv / period-edges), and the plain torus as a
//       coarse-nu x coarse-nv grid for m, shifted by --coarse-shift-u 0.3 and
//       --coarse-shift-v 0.6 of M's grid step. Outward, counter-clockwise.
//   make_detail_mesh sample m.ply COUNT SEED POINTS.xyz MNORMALS.xyz
//       COUNT points uniform by area on m (mt19937_64, SEED) and m's
//       interpolated vertex normal at each (the file's normals, else
//       area-weighted ones, as `apo bake` takes them).
//   make_detail_mesh compare M.ply POINTS.xyz MNORMALS.xyz NORMALS.xyz [--reach 0.01]
//       Angle between each normal of NORMALS.xyz (`apo lookup` output) and M's
//       interpolated vertex normal at two reference points of M:
//       "closest" (the exact closest point of M, CGAL AABB tree) and "ray"
//       (the nearest hit of the rays from the point both ways along m's
//       normal up to reach x M's bbox diagonal, Embree: the field the bake
//       samples). Also m's own normal against both (the error without the
//       APO). Prints one JSON object.
#include "core/geometry.h"
#include "adapters/embree/embree_ray_caster.h"
#include "ingest/ingest.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace {

using apo::Scan;
using apo::Vec3f;
using Vec3d = Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

// --key value options after the positionals.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;

  double number(const std::string& key, double fallback) const {
    const auto it = options.find(key);
    return it == options.end() ? fallback : std::stod(it->second);
  }
};

Args parseArgs(int argc, char** argv) {
  Args args;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.starts_with("--") && i + 1 < argc) {
      args.options[a.substr(2)] = argv[++i];
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

Scan readOrDie(const std::string& path) {
  auto scan = apo::readScan(path);
  if (!scan) {
    std::fprintf(stderr, "%s\n", scan.error().message.c_str());
    std::exit(2);
  }
  return std::move(*scan);
}

void writeOrDie(const std::string& path, const Scan& scan) {
  if (auto s = apo::writePly(path, scan); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.error().message.c_str());
    std::exit(3);
  }
}

double meanEdgeLength(const Scan& mesh) {
  double sum = 0.0;
  for (const apo::Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k)
      sum += (mesh.points.positions[t[k]] - mesh.points.positions[t[(k + 1) % 3]]).cast<double>().norm();
  return sum / (3.0 * static_cast<double>(mesh.triangles.size()));
}

int displace(const Args& args) {
  if (args.positional.size() != 2) return 1;
  Scan mesh = readOrDie(args.positional[0]);
  if (!mesh.isMesh()) return 2;
  const apo::Aabb box = apo::boundingBox(mesh.points.positions);
  const double diag = box.diagonal();
  const double amplitude = args.number("amplitude", 0.001) * diag;
  const double period = args.number("period-edges", 50) * meanEdgeLength(mesh);
  const double w = 2.0 * kPi / period;
  const std::vector<Vec3f> normals = apo::areaWeightedVertexNormals(mesh);
  for (std::size_t i = 0; i < mesh.points.size(); ++i) {
    const Vec3d p = (mesh.points.positions[i] - box.min).cast<double>();
    const double f = std::sin(w * p.x()) * std::sin(w * p.y()) * std::sin(w * p.z());
    mesh.points.positions[i] = (mesh.points.positions[i].cast<double>() + amplitude * f * normals[i].cast<double>())
                                   .cast<float>();
  }
  mesh.points.normals.clear();
  writeOrDie(args.positional[1], mesh);
  std::printf("displace: %zu vertices, %zu triangles, diag %.6g, amplitude %.6g, period %.6g (max tilt %.1f deg)\n",
              mesh.points.size(), mesh.triangles.size(), diag, amplitude, period,
              std::atan(amplitude * w) * 180.0 / kPi);
  return 0;
}

// nu x nv grid on the torus, displaced by amplitude sin(ku u) sin(kv v), its
// vertices at u = 2 pi (i / nu) + phaseU, v = 2 pi (j / nv) + phaseV.
Scan torusGrid(int nu, int nv, double amplitude, int ku, int kv, double phaseU = 0.0, double phaseV = 0.0) {
  constexpr double R = 1.0, r = 0.4;
  Scan mesh;
  mesh.points.positions.reserve(static_cast<std::size_t>(nu) * nv);
  for (int i = 0; i < nu; ++i) {
    const double u = 2.0 * kPi * i / nu + phaseU;
    for (int j = 0; j < nv; ++j) {
      const double v = 2.0 * kPi * j / nv + phaseV;
      const Vec3d n(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
      const Vec3d centre(R * std::cos(u), R * std::sin(u), 0.0);
      const double h = r + amplitude * std::sin(ku * u) * std::sin(kv * v);
      mesh.points.positions.push_back((centre + h * n).cast<float>());
    }
  }
  auto index = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + (j % nv)); };
  mesh.triangles.reserve(2 * static_cast<std::size_t>(nu) * nv);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      // d(u) x d(v) is the outward normal: (i,j) (i+1,j) (i+1,j+1) is counter-clockwise from outside.
      mesh.triangles.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
      mesh.triangles.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
    }
  return mesh;
}

int torus(const Args& args) {
  if (args.positional.size() != 2) return 1;
  const int nu = static_cast<int>(args.number("nu", 3000)), nv = static_cast<int>(args.number("nv", 1200));
  const int cnu = static_cast<int>(args.number("coarse-nu", 150)), cnv = static_cast<int>(args.number("coarse-nv", 50));
  const double periodEdges = args.number("period-edges", 50);
  const int ku = static_cast<int>(std::lround(nu / periodEdges)), kv = static_cast<int>(std::lround(nv / periodEdges));
  const double diag = std::sqrt(2.8 * 2.8 * 2 + 0.8 * 0.8);  // bbox of the plain torus
  const double amplitude = args.number("amplitude", 0.001) * diag;
  const Scan detail = torusGrid(nu, nv, amplitude, ku, kv);
  writeOrDie(args.positional[0], detail);
  // m's grid lines are shifted off M's (by default 0.3 and 0.6 of M's grid
  // step, off M's diagonals too): rays from m's edges would otherwise run
  // exactly through M's edges and vertices.
  const double shiftU = args.number("coarse-shift-u", 0.3), shiftV = args.number("coarse-shift-v", 0.6);
  const Scan coarse = torusGrid(cnu, cnv, 0.0, 0, 0, 2.0 * kPi * shiftU / nu, 2.0 * kPi * shiftV / nv);
  writeOrDie(args.positional[1], coarse);
  std::printf("torus: M %zu triangles (%d x %d, ku %d, kv %d, amplitude %.6g), m %zu triangles (%d x %d)\n",
              detail.triangles.size(), nu, nv, ku, kv, amplitude, coarse.triangles.size(), cnu, cnv);
  return 0;
}

// Uniform double in [0, 1) from 53 bits: the same numbers on every platform.
double unit(std::mt19937_64& random) { return static_cast<double>(random() >> 11) * 0x1.0p-53; }

int sample(const Args& args) {
  if (args.positional.size() != 5) return 1;
  const Scan m = readOrDie(args.positional[0]);
  const std::size_t count = std::stoull(args.positional[1]);
  std::mt19937_64 random(std::stoull(args.positional[2]));
  const std::vector<Vec3f> normals = apo::vertexNormalsAsDrawn(m);
  std::vector<double> cumulative;
  double total = 0.0;
  for (const apo::Triangle& t : m.triangles) {
    const Vec3d a = m.points.positions[t[0]].cast<double>(), b = m.points.positions[t[1]].cast<double>(),
                c = m.points.positions[t[2]].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cumulative.push_back(total);
  }
  std::string points, mnormals;
  for (std::size_t s = 0; s < count; ++s) {
    const double pick = unit(random) * total;
    const std::size_t f = std::min<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(), cumulative.size() - 1);
    const double r1 = std::sqrt(unit(random)), r2 = unit(random);
    const double wa = 1.0 - r1, wb = r1 * (1.0 - r2), wc = r1 * r2;
    const apo::Triangle& t = m.triangles[f];
    const Vec3d p = wa * m.points.positions[t[0]].cast<double>() + wb * m.points.positions[t[1]].cast<double>() +
                    wc * m.points.positions[t[2]].cast<double>();
    const Vec3d n = (wa * normals[t[0]].cast<double>() + wb * normals[t[1]].cast<double>() +
                     wc * normals[t[2]].cast<double>()).normalized();
    points += fmt::format("{:.9g} {:.9g} {:.9g}\n", p.x(), p.y(), p.z());
    mnormals += fmt::format("{:.9g} {:.9g} {:.9g}\n", n.x(), n.y(), n.z());
  }
  std::FILE* f1 = std::fopen(args.positional[3].c_str(), "wb");
  std::FILE* f2 = std::fopen(args.positional[4].c_str(), "wb");
  if (!f1 || !f2) return 3;
  std::fwrite(points.data(), 1, points.size(), f1);
  std::fwrite(mnormals.data(), 1, mnormals.size(), f2);
  std::fclose(f1);
  std::fclose(f2);
  return 0;
}

// Rows of three numbers (the .xyz files above, `apo lookup` output).
std::vector<Vec3d> readTriples(const std::string& path) {
  std::vector<Vec3d> rows;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    std::fprintf(stderr, "%s: cannot open\n", path.c_str());
    std::exit(2);
  }
  double x, y, z;
  while (std::fscanf(f, "%lf %lf %lf", &x, &y, &z) == 3) rows.emplace_back(x, y, z);
  std::fclose(f);
  return rows;
}

double degreesBetween(const Vec3d& a, const Vec3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / kPi;
}

// M's interpolated vertex normal at barycentrics (wa, wb, wc) of triangle t.
Vec3d interpolatedNormal(const std::vector<Vec3f>& normals, const apo::Triangle& t, double wa, double wb, double wc) {
  return (wa * normals[t[0]].cast<double>() + wb * normals[t[1]].cast<double>() + wc * normals[t[2]].cast<double>())
      .normalized();
}

// Barycentrics of p (on or near triangle abc) in the triangle, clamped to it.
std::array<double, 3> barycentrics(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& p) {
  const Vec3d v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denom = d00 * d11 - d01 * d01;
  if (!(denom > 0.0)) return {1.0 / 3, 1.0 / 3, 1.0 / 3};
  double v = (d11 * d20 - d01 * d21) / denom, w = (d00 * d21 - d01 * d20) / denom;
  v = std::clamp(v, 0.0, 1.0);
  w = std::clamp(w, 0.0, 1.0 - v);
  return {1.0 - v - w, v, w};
}

struct Stats {
  std::vector<double> degrees;
  std::string json() {
    std::sort(degrees.begin(), degrees.end());
    double sum = 0.0, squares = 0.0;
    for (double d : degrees) {
      sum += d;
      squares += d * d;
    }
    const auto at = [&](double q) {
      return degrees.empty() ? 0.0 : degrees[std::min(degrees.size() - 1, static_cast<std::size_t>(q * degrees.size()))];
    };
    const double n = std::max<double>(1.0, static_cast<double>(degrees.size()));
    return fmt::format(R"({{"count": {}, "mean": {:.4f}, "rms": {:.4f}, "median": {:.4f}, "p95": {:.4f}, "p99": {:.4f}, "max": {:.4f}}})",
                       degrees.size(), sum / n, std::sqrt(squares / n), at(0.5), at(0.95), at(0.99),
                       degrees.empty() ? 0.0 : degrees.back());
  }
};

int compare(const Args& args) {
  if (args.positional.size() != 4) return 1;
  const Scan M = readOrDie(args.positional[0]);
  if (!M.isMesh()) return 2;
  const std::vector<Vec3d> points = readTriples(args.positional[1]), mnormals = readTriples(args.positional[2]),
                           baked = readTriples(args.positional[3]);
  if (points.size() != mnormals.size() || points.size() != baked.size()) {
    std::fprintf(stderr, "compare: %zu points, %zu m normals, %zu baked normals\n", points.size(), mnormals.size(),
                 baked.size());
    return 2;
  }
  const std::vector<Vec3f> normals = apo::vertexNormalsAsDrawn(M);
  const double reach = args.number("reach", 0.01) * apo::boundingBox(M.points.positions).diagonal();

  // Closest point: CGAL's AABB tree over M's triangles, in double.
  using K = CGAL::Simple_cartesian<double>;
  using Triangles = std::vector<K::Triangle_3>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>>>;
  Triangles triangles;
  triangles.reserve(M.triangles.size());
  auto point = [&](std::uint32_t v) {
    const Vec3f& p = M.points.positions[v];
    return K::Point_3(p.x(), p.y(), p.z());
  };
  for (const apo::Triangle& t : M.triangles) triangles.emplace_back(point(t[0]), point(t[1]), point(t[2]));
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();

  // Ray: both ways along m's normal, the nearer hit.
  auto caster = apo::makeEmbreeMeshCaster(M);
  if (!caster) {
    std::fprintf(stderr, "%s\n", caster.error().message.c_str());
    return 3;
  }
  std::vector<apo::Ray> rays(2 * points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    for (int way = 0; way < 2; ++way) {
      apo::Ray& ray = rays[2 * i + way];
      ray.origin = points[i].cast<float>();
      ray.direction = (way == 0 ? mnormals[i] : Vec3d(-mnormals[i])).cast<float>();
      ray.tFar = static_cast<float>(reach);
    }
  std::vector<apo::RayHit> hits;
  (*caster)->intersect(rays, hits);

  Stats closestBaked, rayBaked, closestM, rayM;
  std::size_t outside = 0, rayMisses = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto [p, id] = tree.closest_point_and_primitive(K::Point_3(points[i].x(), points[i].y(), points[i].z()));
    const apo::Triangle& t = M.triangles[static_cast<std::size_t>(id - triangles.cbegin())];
    const auto w = barycentrics(M.points.positions[t[0]].cast<double>(), M.points.positions[t[1]].cast<double>(),
                                M.points.positions[t[2]].cast<double>(), Vec3d(p.x(), p.y(), p.z()));
    const Vec3d closestNormal = interpolatedNormal(normals, t, w[0], w[1], w[2]);
    closestM.degrees.push_back(degreesBetween(mnormals[i], closestNormal));
    const bool inside = baked[i].squaredNorm() > 0.0;
    outside += inside ? 0 : 1;
    if (inside) closestBaked.degrees.push_back(degreesBetween(baked[i], closestNormal));

    const apo::RayHit& forward = hits[2 * i];
    const apo::RayHit& backward = hits[2 * i + 1];
    const apo::RayHit* hit = forward.hit() && (!backward.hit() || forward.t <= backward.t) ? &forward
                             : backward.hit()                                              ? &backward
                                                                                           : nullptr;
    if (!hit) {
      ++rayMisses;
      continue;
    }
    const Vec3d rayNormal =
        interpolatedNormal(normals, M.triangles[hit->primitive], 1.0 - hit->u - hit->v, hit->u, hit->v);
    rayM.degrees.push_back(degreesBetween(mnormals[i], rayNormal));
    if (inside) rayBaked.degrees.push_back(degreesBetween(baked[i], rayNormal));
  }
  fmt::print(
      R"({{"points": {}, "outside_octree": {}, "ray_misses": {}, "baked_vs_closest": {}, "baked_vs_ray": {}, "m_vs_closest": {}, "m_vs_ray": {}}})"
      "\n",
      points.size(), outside, rayMisses, closestBaked.json(), rayBaked.json(), closestM.json(), rayM.json());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string command = argc > 1 ? argv[1] : "";
  const Args args = parseArgs(argc, argv);
  int code = 1;
  if (command == "displace") code = displace(args);
  else if (command == "torus") code = torus(args);
  else if (command == "sample") code = sample(args);
  else if (command == "compare") code = compare(args);
  if (code == 1)
    std::fprintf(stderr,
                 "usage: make_detail_mesh displace IN OUT.ply [--amplitude A] [--period-edges P]\n"
                 "     | torus M.ply m.ply [--nu --nv --coarse-nu --coarse-nv --amplitude --period-edges --coarse-shift-u/v]\n"
                 "     | sample m.ply COUNT SEED POINTS.xyz MNORMALS.xyz\n"
                 "     | compare M.ply POINTS.xyz MNORMALS.xyz NORMALS.xyz [--reach R]\n");
  return code;
}
