#include "qjulia/mesh/print.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "base/mesh_check.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "qjulia/mesh/clean.h"

namespace qjulia {

double scale_to_longest_side(TriMesh& mesh, double length) {
  if (!(length > 0) || !std::isfinite(length))
    throw InvalidInput("print: size must be a positive length, got " + std::to_string(length));
  if (mesh.positions.empty() || mesh.triangles.empty())
    throw InvalidInput("print: cannot scale an empty mesh");
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::max();
    hi[k] = -std::numeric_limits<double>::max();
  }
  for (const auto& t : mesh.triangles)
    for (uint32_t v : t)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], double(mesh.positions[v][k]));
        hi[k] = std::max(hi[k], double(mesh.positions[v][k]));
      }
  const double longest = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  if (!(longest > 0))
    throw InvalidInput("print: cannot scale a mesh with a zero-size bounding box");
  const double s = length / longest;
  for (auto& p : mesh.positions)
    for (auto& c : p) c = static_cast<float>(c * s);
  return s;
}

PrintabilityReport printability(const TriMesh& mesh, const PrintabilityOptions& opts) {
  validate_mesh(mesh, "printability");
  PrintabilityReport r;
  const auto topo = detail::check_topology(mesh);
  r.boundary_edges = topo.boundary_edges;
  r.nonmanifold_edges = topo.nonmanifold_edges;
  r.nonmanifold_vertices = topo.nonmanifold_vertices;
  r.closed = topo.closed() && topo.degenerate_faces == 0;
  r.manifold = topo.manifold();
  r.oriented = topo.oriented();
  std::vector<uint32_t> comp;
  r.components = detail::face_components(mesh, comp);
  r.volume = detail::signed_volume(mesh);
  r.outward = r.volume > 0;
  if (opts.millimetres) r.volume_cm3 = r.volume / 1000.0;
  bool any = false;
  for (const auto& t : mesh.triangles) {
    const auto &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(b[k]) - a[k];
      v[k] = double(c[k]) - a[k];
    }
    const double n0 = u[1] * v[2] - u[2] * v[1], n1 = u[2] * v[0] - u[0] * v[2],
                 n2 = u[0] * v[1] - u[1] * v[0];
    r.area += 0.5 * std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    for (uint32_t i : t)
      for (int k = 0; k < 3; ++k) {
        const double x = mesh.positions[i][k];
        r.bbox_min[k] = any ? std::min(r.bbox_min[k], x) : x;
        r.bbox_max[k] = any ? std::max(r.bbox_max[k], x) : x;
      }
    any = true;
  }
  for (int k = 0; k < 3; ++k) r.size[k] = r.bbox_max[k] - r.bbox_min[k];
  if (opts.check_self_intersections) r.self_intersections = count_self_intersections(mesh);
  return r;
}

}  // namespace qjulia
