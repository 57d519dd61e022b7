#include "qjulia/base/mesh.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "base/first_touch.h"
#include "base/geometry.h"
#include "base/mesh_check.h"
#include "base/threads.h"
#include "base/union_find.h"
#include "qjulia/base/progress.h"
#include "qjulia/base/validate.h"

namespace qjulia {
namespace {

using detail::Vec3d;

constexpr std::size_t kCancelStride = 1 << 16;  // loop iterations between cancellation checks

void check_cancel(std::size_t i, const CancelToken* cancel) {
  if (i % kCancelStride == 0) throw_if_cancelled(cancel);
}

/// Per vertex: referenced by a face (it has a face in `vf`).
std::vector<char> referenced_vertices(const detail::VertexFaces& vf) {
  std::vector<char> used(vf.offsets.size() - 1);
  for (std::size_t v = 0; v < used.size(); ++v) used[v] = vf.offsets[v + 1] > vf.offsets[v];
  return used;
}

/// The bounding box of the referenced vertices.
void measure_bbox(const TriMesh& mesh, const std::vector<char>& used, MeshMeasure& m) {
  const auto& o = mesh.positions[mesh.triangles[0][0]];
  m.bbox_min = {o[0], o[1], o[2]};
  m.bbox_max = m.bbox_min;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v])
      for (int a = 0; a < 3; ++a) {
        m.bbox_min[a] = std::min<double>(m.bbox_min[a], mesh.positions[v][a]);
        m.bbox_max[a] = std::max<double>(m.bbox_max[a], mesh.positions[v][a]);
      }
}

/// The area of every face; counts the degenerate faces (a repeated index or zero area).
std::vector<double> face_areas(const TriMesh& mesh, MeshMeasure& m, const CancelToken* cancel) {
  const std::size_t nf = mesh.triangles.size();
  std::vector<double> area(nf);
  tbb::enumerable_thread_specific<std::size_t> degenerate(0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, kCancelStride / 16),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      throw_if_cancelled(cancel);
                      std::size_t& d = degenerate.local();
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        const auto& t = mesh.triangles[f];
                        area[f] = detail::triangle_area(detail::to_vec3d(mesh.positions[t[0]]),
                                                        detail::to_vec3d(mesh.positions[t[1]]),
                                                        detail::to_vec3d(mesh.positions[t[2]]));
                        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area[f] == 0) ++d;
                      }
                    });
  for (std::size_t d : degenerate) m.degenerate_faces += d;
  return area;
}

/// Vertex-connected components (faces sharing a vertex belong together), sorted by decreasing
/// face count.
/// A component's signed volume is taken relative to its own first vertex (a small component far
/// from the mesh's first vertex would otherwise sum terms of the size of that distance squared,
/// which cancel), then moved to the mesh's first vertex exactly: det(a + t, b + t, c + t) =
/// det(a, b, c) + t . (b - a) x (c - a), so an open component keeps the volume it has relative
/// to that point.
std::vector<ComponentMeasure> components(const TriMesh& mesh, const std::vector<char>& used,
                                         const std::vector<double>& area,
                                         const detail::EdgeScan& edges, const CancelToken* cancel) {
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  detail::UnionFind vuf(nv);
  for (const auto& t : mesh.triangles) {
    vuf.unite(t[0], t[1]);
    vuf.unite(t[1], t[2]);
  }
  throw_if_cancelled(cancel);
  std::vector<std::int64_t> id(nv, -1);
  std::vector<ComponentMeasure> comps;
  std::vector<std::int64_t> comp_vertices, comp_edges;
  std::vector<Vec3d> base, normal_sum;  // per component: its first vertex, its faces' normals
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    const auto r = vuf.find(static_cast<std::uint32_t>(v));
    if (id[r] < 0) {
      id[r] = static_cast<std::int64_t>(comps.size());
      comps.emplace_back();
      comps.back().closed = true;
      comp_vertices.push_back(0);
      comp_edges.push_back(0);
      base.push_back(detail::to_vec3d(mesh.positions[v]));
      normal_sum.push_back({0, 0, 0});
    }
    ++comp_vertices[id[r]];
  }
  for (std::size_t f = 0; f < nf; ++f) {
    check_cancel(f, cancel);
    const auto& t = mesh.triangles[f];
    const auto i = static_cast<std::size_t>(id[vuf.find(t[0])]);
    auto& c = comps[i];
    ++c.faces;
    const Vec3d a = detail::to_vec3d(mesh.positions[t[0]]) - base[i],
                b = detail::to_vec3d(mesh.positions[t[1]]) - base[i],
                d = detail::to_vec3d(mesh.positions[t[2]]) - base[i];
    c.volume += detail::tetra_volume(a, b, d);
    normal_sum[i] = normal_sum[i] + detail::cross(b - a, d - a);
    c.area += area[f];
  }
  for (std::uint32_t f : edges.open_faces) comps[id[vuf.find(mesh.triangles[f][0])]].closed = false;
  const Vec3d origin = detail::to_vec3d(mesh.positions[mesh.triangles[0][0]]);
  for (std::size_t i = 0; i < comps.size(); ++i)
    comps[i].volume += detail::dot(base[i] - origin, normal_sum[i]) / 6.0;
  // An edge is in the component of its ends.
  for (std::size_t v = 0; v < nv; ++v)
    if (edges.edges_at[v] != 0)
      comp_edges[id[vuf.find(static_cast<std::uint32_t>(v))]] += edges.edges_at[v];
  for (std::size_t c = 0; c < comps.size(); ++c) {
    comps[c].euler = comp_vertices[c] - comp_edges[c] + static_cast<std::int64_t>(comps[c].faces);
    comps[c].genus = comps[c].closed ? (2 - comps[c].euler) / 2 : -1;
  }
  std::stable_sort(
      comps.begin(), comps.end(),
      [](const ComponentMeasure& a, const ComponentMeasure& b) { return a.faces > b.faces; });
  return comps;
}

}  // namespace

MeshMeasure measure(const TriMesh& mesh, const CancelToken* cancel) {
  validate_mesh(mesh, "measure");
  MeshMeasure m;
  m.faces = mesh.triangles.size();
  if (m.faces == 0) return m;
  const std::vector<double> area = face_areas(mesh, m, cancel);
  std::vector<char> used;
  detail::EdgeScan edges;
  {
    const detail::VertexFaces vf(mesh);
    throw_if_cancelled(cancel);
    used = referenced_vertices(vf);
    m.vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
    measure_bbox(mesh, used, m);
    edges = detail::scan_edges(mesh, vf, /*skip_degenerate=*/false, cancel);
    m.edges = edges.edges;
    m.boundary_edges = edges.boundary_edges;
    m.nonmanifold_edges = edges.nonmanifold_edges;
    m.misoriented_edges = edges.misoriented_edges;
    const auto pinched = detail::pinched_vertices(mesh, vf);
    m.nonmanifold_vertices = static_cast<std::size_t>(
        std::count(pinched.begin(), pinched.end(), static_cast<std::uint8_t>(1)));
  }
  throw_if_cancelled(cancel);
  m.components = components(mesh, used, area, edges, cancel);
  for (const auto& c : m.components) {
    m.volume += c.volume;
    m.area += c.area;
  }
  m.euler = static_cast<long long>(m.vertices) - static_cast<long long>(m.edges) +
            static_cast<long long>(m.faces);
  m.closed = m.boundary_edges == 0 && m.nonmanifold_edges == 0;
  m.manifold = m.nonmanifold_edges == 0 && m.nonmanifold_vertices == 0;
  m.oriented = m.misoriented_edges == 0;
  return m;
}

std::vector<std::uint32_t> face_components(const TriMesh& mesh) {
  validate_mesh(mesh, "face_components");
  std::vector<std::uint32_t> out;
  detail::face_components(mesh, out);
  return out;
}

std::vector<std::array<float, 3>> area_weighted_normals(const TriMesh& mesh) {
  validate_mesh(mesh, "normals");
  // Summed in the output itself (float: a vertex has a few faces, and a unit normal needs no
  // more), each vertex's faces in face order, so the result does not depend on threads: each
  // thread owns a contiguous range of vertices, scans the faces in order and adds their normals
  // to its own vertices. The faces are scanned in blocks whose smallest and largest corner are
  // found first: a thread skips the blocks with no corner in its range. An extracted mesh's faces
  // follow its vertices (brick by brick), so each thread reads about its share of the faces; a
  // face with corners in two ranges has its normal made by each of their threads.
  std::vector<std::array<float, 3>> normals;
  detail::resize_first_touched(normals, mesh.positions.size());
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  auto position = [&](std::uint32_t v) -> const auto& { return mesh.positions[v]; };
  constexpr std::size_t kLeast = std::size_t{1} << 14;  // vertices a thread's range has at least
  const std::size_t lanes =
      std::max<std::size_t>(1, std::min(detail::threads_that_may_run(), nv / kLeast));
  // Adds the normals of faces [first, last) to the vertices in [lo, hi).
  struct Faces {
    const std::array<std::uint32_t, 3>* first;
    const std::array<std::uint32_t, 3>* last;
    auto begin() const { return first; }
    auto end() const { return last; }
  };
  auto add = [&](std::size_t first, std::size_t last, std::uint32_t lo, std::uint32_t hi) {
    const auto* t = mesh.triangles.data();
    detail::add_area_normals(Faces{t + first, t + last}, position, [&](std::uint32_t v) {
      return v - lo < hi - lo ? &normals[v] : nullptr;
    });
  };
  if (lanes == 1) {
    add(0, nf, 0, static_cast<std::uint32_t>(nv));
  } else {
    constexpr std::size_t kFaces = 4096;  // faces per block
    const std::size_t blocks = (nf + kFaces - 1) / kFaces;
    std::vector<std::array<std::uint32_t, 2>> span(blocks);  // each block's corners' range
    tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t b) {
      std::uint32_t lo = UINT32_MAX, hi = 0;
      for (std::size_t f = b * kFaces; f < std::min(nf, (b + 1) * kFaces); ++f)
        for (std::uint32_t v : mesh.triangles[f]) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      span[b] = {lo, hi};
    });
    tbb::parallel_for(std::size_t{0}, lanes, [&](std::size_t lane) {
      const auto lo = static_cast<std::uint32_t>(nv * lane / lanes);
      const auto hi = static_cast<std::uint32_t>(nv * (lane + 1) / lanes);
      for (std::size_t b = 0; b < blocks; ++b)
        if (span[b][1] >= lo && span[b][0] < hi)
          add(b * kFaces, std::min(nf, (b + 1) * kFaces), lo, hi);
    });
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, normals.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end(); ++v)
                        detail::normalize_sum(normals[v]);
                    });
  return normals;
}

void compute_normals(TriMesh& mesh) {
  // The normals it has (of any count) are replaced, so they are not checked; on a failure they
  // stay.
  std::vector<std::array<float, 3>> old = std::move(mesh.normals);
  mesh.normals.clear();
  try {
    mesh.normals = area_weighted_normals(mesh);
  } catch (...) {
    mesh.normals = std::move(old);
    throw;
  }
}

}  // namespace qjulia
