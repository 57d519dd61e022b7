// count_self_intersections lives apart from clean.cpp: CGAL headers are slow to compile.
#ifndef CGAL_LINKED_WITH_TBB
#define CGAL_LINKED_WITH_TBB
#endif
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <iterator>
#include <vector>

#include "qjulia/clean.h"

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

std::size_t count_self_intersections(const TriMesh& mesh) {
  using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Surface = CGAL::Surface_mesh<Kernel::Point_3>;
  // Faces that cannot be added to a halfedge mesh (non-manifold configurations) are skipped.
  Surface sm;
  std::vector<Surface::Vertex_index> v;
  v.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions)
    v.push_back(sm.add_vertex(Kernel::Point_3(p[0], p[1], p[2])));
  for (const auto& t : mesh.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    sm.add_face(v[t[0]], v[t[1]], v[t[2]]);
  }
  std::size_t count = 0;
  CGAL::Polygon_mesh_processing::self_intersections<CGAL::Parallel_if_available_tag>(
      sm, CountingOutput{&count});
  return count;
}

}  // namespace qjulia
