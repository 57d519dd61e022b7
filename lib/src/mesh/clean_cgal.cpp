// count_self_intersections lives apart from clean.cpp: CGAL headers are slow to compile.
#ifndef CGAL_LINKED_WITH_TBB
#define CGAL_LINKED_WITH_TBB
#endif
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <iterator>
#include <vector>

#include "base/mesh_check.h"
#include "qjulia/base/validate.h"
#include "qjulia/mesh/clean.h"

namespace qjulia {

namespace {
/// Counts the pairs written without storing them.
struct CountingOutput {
  std::size_t* count;
  using iterator_category = std::output_iterator_tag;
  using value_type = void;
  using difference_type = std::ptrdiff_t;
  using pointer = void;
  using reference = void;
  CountingOutput& operator*() { return *this; }
  CountingOutput& operator++() { return *this; }
  CountingOutput operator++(int) { return *this; }
  template <class T>
  CountingOutput& operator=(const T&) {
    ++*count;
    return *this;
  }
};
}  // namespace

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Surface = CGAL::Surface_mesh<Kernel::Point_3>;

/// A Surface_mesh of the faces it can hold; face_of[i] is the TriMesh face of CGAL face i.
Surface to_surface(const TriMesh& mesh, std::vector<uint32_t>& face_of) {
  Surface sm;
  std::vector<Surface::Vertex_index> v;
  v.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions)
    v.push_back(sm.add_vertex(Kernel::Point_3(p[0], p[1], p[2])));
  for (uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    if (sm.add_face(v[t[0]], v[t[1]], v[t[2]]) != Surface::null_face()) face_of.push_back(f);
  }
  return sm;
}
}  // namespace

std::vector<std::pair<uint32_t, uint32_t>> detail::self_intersecting_face_pairs(
    const TriMesh& mesh) {
  std::vector<uint32_t> face_of;
  Surface sm = to_surface(mesh, face_of);
  using Face = boost::graph_traits<Surface>::face_descriptor;
  std::vector<std::pair<Face, Face>> pairs;
  CGAL::Polygon_mesh_processing::self_intersections<CGAL::Parallel_if_available_tag>(
      sm, std::back_inserter(pairs));
  std::vector<std::pair<uint32_t, uint32_t>> out;
  out.reserve(pairs.size());
  for (const auto& [a, b] : pairs)
    out.emplace_back(face_of[std::size_t(a)], face_of[std::size_t(b)]);
  return out;
}

std::size_t count_self_intersections(const TriMesh& mesh) {
  validate_mesh(mesh, "self-intersections");
  std::vector<uint32_t> face_of;
  Surface sm = to_surface(mesh, face_of);
  std::size_t count = 0;
  CGAL::Polygon_mesh_processing::self_intersections<CGAL::Parallel_if_available_tag>(
      sm, CountingOutput{&count});
  return count;
}

}  // namespace qjulia
