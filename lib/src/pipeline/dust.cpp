#include "pipeline/dust.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace qjulia::detail {

CleanReport remove_dust(TriMesh& mesh, ExtractStats& stats, double min_volume) {
  MeshMeasure& m = stats.measure;
  CleanReport rep;
  rep.components_before = m.components.size();
  rep.min_component_volume = min_volume;
  std::vector<char> drop(m.components.size(), 0);
  bool any = false;
  for (std::size_t c = 0; c < m.components.size(); ++c)
    if (std::abs(m.components[c].volume) < min_volume) drop[c] = 1, any = true;
  if (!any) {
    rep.components_after = rep.components_before;
    return rep;
  }
  // Faces of kept components; vertices renumbered in order.
  std::vector<std::uint32_t> renumber(mesh.positions.size(), UINT32_MAX);
  std::size_t kept_faces = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (drop[stats.face_component[f]]) continue;
    for (std::uint32_t v : mesh.triangles[f]) renumber[v] = 0;
    mesh.triangles[kept_faces] = mesh.triangles[f];
    stats.face_component[kept_faces] = stats.face_component[f];
    ++kept_faces;
  }
  rep.removed_faces = mesh.triangles.size() - kept_faces;
  mesh.triangles.resize(kept_faces);
  stats.face_component.resize(kept_faces);
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    if (renumber[v] == UINT32_MAX) continue;
    renumber[v] = next;
    mesh.positions[next] = mesh.positions[v];
    if (!mesh.normals.empty()) mesh.normals[next] = mesh.normals[v];
    if (!mesh.colors.empty()) mesh.colors[next] = mesh.colors[v];
    ++next;
  }
  mesh.positions.resize(next);
  if (!mesh.normals.empty()) mesh.normals.resize(next);
  if (!mesh.colors.empty()) mesh.colors.resize(next);
  for (auto& t : mesh.triangles)
    for (auto& v : t) v = renumber[v];
  // The measures without the removed components (a closed component has 3F/2 edges).
  std::vector<std::uint32_t> new_index(m.components.size(), UINT32_MAX);
  std::vector<ComponentMeasure> kept;
  std::vector<std::array<double, 6>> kept_box;
  m.volume = m.area = 0;
  long long euler = 0;
  std::size_t edges = 0;
  for (std::size_t c = 0; c < m.components.size(); ++c) {
    const ComponentMeasure& cm = m.components[c];
    if (drop[c]) {
      ++rep.removed_components;
      continue;
    }
    new_index[c] = static_cast<std::uint32_t>(kept.size());
    kept.push_back(cm);
    kept_box.push_back(stats.component_bbox[c]);
    m.volume += cm.volume;
    m.area += cm.area;
    euler += cm.euler;
    edges += 3 * cm.faces / 2;
  }
  for (auto& c : stats.face_component) c = new_index[c];
  m.components = std::move(kept);
  stats.component_bbox = std::move(kept_box);
  m.vertices = mesh.positions.size();
  m.faces = mesh.triangles.size();
  m.edges = edges;
  m.euler = euler;
  for (std::size_t c = 0; c < stats.component_bbox.size(); ++c)
    for (int a = 0; a < 3; ++a) {
      m.bbox_min[a] =
          c == 0 ? stats.component_bbox[c][a] : std::min(m.bbox_min[a], stats.component_bbox[c][a]);
      m.bbox_max[a] = c == 0 ? stats.component_bbox[c][3 + a]
                             : std::max(m.bbox_max[a], stats.component_bbox[c][3 + a]);
    }
  if (m.components.empty()) m.bbox_min = m.bbox_max = {0, 0, 0};
  rep.components_after = m.components.size();
  return rep;
}

}  // namespace qjulia::detail
