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

double longest_side(const TriMesh& mesh) {
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
  if (mesh.triangles.empty()) return 0;
  return std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

double scale_to_longest_side(TriMesh& mesh, double length) {
  if (!(length > 0) || !std::isfinite(length))
    throw InvalidInput("print: size must be a positive length, got " + std::to_string(length));
  validate_mesh(mesh, "print");
  if (mesh.positions.empty() || mesh.triangles.empty())
    throw InvalidInput("print: cannot scale an empty mesh");
  const double longest = longest_side(mesh);
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
  const MeshMeasure m = measure(mesh, opts.cancel);
  const bool repeated_index =
      std::any_of(mesh.triangles.begin(), mesh.triangles.end(),
                  [](const auto& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; });
  r.boundary_edges = m.boundary_edges;
  r.nonmanifold_edges = m.nonmanifold_edges;
  r.nonmanifold_vertices = m.nonmanifold_vertices;
  r.closed = m.closed && !repeated_index;
  r.manifold = m.manifold;
  r.oriented = m.oriented;
  r.components = m.components.size();
  r.volume = m.volume;
  r.outward = r.volume > 0;
  if (opts.millimetres) r.volume_cm3 = r.volume / 1000.0;
  r.area = m.area;
  r.bbox_min = m.bbox_min;
  r.bbox_max = m.bbox_max;
  for (int k = 0; k < 3; ++k) r.size[k] = r.bbox_max[k] - r.bbox_min[k];
  throw_if_cancelled(opts.cancel);
  if (opts.check_self_intersections) r.self_intersections = count_self_intersections(mesh);
  return r;
}

}  // namespace qjulia
