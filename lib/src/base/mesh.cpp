#include "qjulia/base/mesh.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace qjulia {
namespace {

struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

struct HalfEdge {
  std::uint32_t lo, hi;  // undirected key
  std::uint32_t face;
  bool forward;  // lo -> hi in the face
  bool operator<(const HalfEdge& o) const {
    return lo != o.lo ? lo < o.lo : hi != o.hi ? hi < o.hi : face < o.face;
  }
};

}  // namespace

MeshMeasure measure(const TriMesh& mesh) {
  MeshMeasure m;
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  m.faces = nf;
  if (nf == 0) return m;
  std::vector<char> used(nv, 0);
  for (const auto& t : mesh.triangles)
    for (auto v : t) used[v] = 1;
  m.vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));

  // Geometry, relative to the first vertex for precision.
  const auto& o = mesh.positions[mesh.triangles[0][0]];
  m.bbox_min = {o[0], o[1], o[2]};
  m.bbox_max = m.bbox_min;
  for (std::size_t v = 0; v < nv; ++v)
    if (used[v])
      for (int a = 0; a < 3; ++a) {
        m.bbox_min[a] = std::min<double>(m.bbox_min[a], mesh.positions[v][a]);
        m.bbox_max[a] = std::max<double>(m.bbox_max[a], mesh.positions[v][a]);
      }
  std::vector<double> face_volume(nf), face_area(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) p[k][a] = static_cast<double>(mesh.positions[t[k]][a]) - o[a];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    face_area[f] = 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    face_volume[f] = (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                      p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                      p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) /
                     6.0;
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || face_area[f] == 0) ++m.degenerate_faces;
  }

  // Edges.
  std::vector<HalfEdge> half(3 * nf);
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = mesh.triangles[f][k], b = mesh.triangles[f][(k + 1) % 3];
      half[3 * f + k] = {std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(f), a < b};
    }
  tbb::parallel_sort(half.begin(), half.end());
  std::vector<char> face_open(nf, 0);
  UnionFind faces_uf(nf);
  std::vector<std::size_t> component_edges_key;  // filled later per component
  std::vector<std::uint32_t> edge_face;          // one face per edge, for per-component counts
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    while (j < half.size() && half[j].lo == half[i].lo && half[j].hi == half[i].hi) ++j;
    const std::size_t count = j - i;
    ++m.edges;
    edge_face.push_back(half[i].face);
    if (count == 1) ++m.boundary_edges;
    if (count > 2) ++m.nonmanifold_edges;
    if (count == 2 && half[i].forward == half[i + 1].forward) ++m.misoriented_edges;
    if (count != 2)
      for (std::size_t k = i; k < j; ++k) face_open[half[k].face] = 1;
    for (std::size_t k = i + 1; k < j; ++k) faces_uf.unite(half[i].face, half[k].face);
    i = j;
  }

  // Non-manifold vertices: the faces around a vertex must form one fan (connected link).
  {
    std::vector<std::uint32_t> start(nv + 1, 0);
    for (const auto& t : mesh.triangles)
      for (auto v : t) ++start[v + 1];
    for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
    std::vector<std::uint32_t> incident(3 * nf), fill(start.begin(), start.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (auto v : mesh.triangles[f]) incident[fill[v]++] = static_cast<std::uint32_t>(f);
    std::vector<std::uint32_t> link, parent;
    for (std::size_t v = 0; v < nv; ++v) {
      if (start[v + 1] - start[v] < 2) continue;
      link.clear();
      for (std::uint32_t n = start[v]; n < start[v + 1]; ++n)
        for (auto w : mesh.triangles[incident[n]])
          if (w != v) link.push_back(w);
      std::sort(link.begin(), link.end());
      link.erase(std::unique(link.begin(), link.end()), link.end());
      parent.resize(link.size());
      std::iota(parent.begin(), parent.end(), 0u);
      auto find = [&](std::uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
      };
      std::size_t groups = link.size();
      for (std::uint32_t n = start[v]; n < start[v + 1]; ++n) {
        std::uint32_t others[2], k = 0;
        for (auto w : mesh.triangles[incident[n]])
          if (w != v && k < 2) others[k++] = w;
        if (k < 2) continue;
        const auto a = find(static_cast<std::uint32_t>(
            std::lower_bound(link.begin(), link.end(), others[0]) - link.begin()));
        const auto b = find(static_cast<std::uint32_t>(
            std::lower_bound(link.begin(), link.end(), others[1]) - link.begin()));
        if (a != b) {
          parent[std::max(a, b)] = std::min(a, b);
          --groups;
        }
      }
      if (groups > 1) ++m.nonmanifold_vertices;
    }
  }

  // Vertex-connected components (faces sharing a vertex belong together).
  {
    UnionFind vuf(nv);
    for (const auto& t : mesh.triangles) {
      vuf.unite(t[0], t[1]);
      vuf.unite(t[1], t[2]);
    }
    std::vector<std::int64_t> id(nv, -1);
    std::vector<ComponentMeasure> comps;
    std::vector<std::int64_t> comp_vertices, comp_edges;
    for (std::size_t v = 0; v < nv; ++v) {
      if (!used[v]) continue;
      const auto r = vuf.find(static_cast<std::uint32_t>(v));
      if (id[r] < 0) {
        id[r] = static_cast<std::int64_t>(comps.size());
        comps.emplace_back();
        comps.back().closed = true;
        comp_vertices.push_back(0);
        comp_edges.push_back(0);
      }
      ++comp_vertices[id[r]];
    }
    for (std::size_t f = 0; f < nf; ++f) {
      auto& c = comps[id[vuf.find(mesh.triangles[f][0])]];
      ++c.faces;
      c.volume += face_volume[f];
      c.area += face_area[f];
      if (face_open[f]) c.closed = false;
    }
    for (auto f : edge_face) ++comp_edges[id[vuf.find(mesh.triangles[f][0])]];
    for (std::size_t c = 0; c < comps.size(); ++c) {
      comps[c].euler = comp_vertices[c] - comp_edges[c] + static_cast<std::int64_t>(comps[c].faces);
      comps[c].genus = comps[c].closed ? (2 - comps[c].euler) / 2 : -1;
    }
    std::stable_sort(
        comps.begin(), comps.end(),
        [](const ComponentMeasure& a, const ComponentMeasure& b) { return a.faces > b.faces; });
    m.components = std::move(comps);
  }
  for (const auto& c : m.components) {
    m.volume += c.volume;
    m.area += c.area;
  }
  m.euler = static_cast<long long>(m.vertices) - static_cast<long long>(m.edges) +
            static_cast<long long>(nf);
  m.closed = m.boundary_edges == 0 && m.nonmanifold_edges == 0;
  m.manifold = m.nonmanifold_edges == 0 && m.nonmanifold_vertices == 0;
  m.oriented = m.misoriented_edges == 0;
  return m;
}

std::vector<std::array<float, 3>> area_weighted_normals(const TriMesh& mesh) {
  std::vector<std::array<double, 3>> acc(mesh.positions.size(), {0, 0, 0});
  for (const auto& t : mesh.triangles) {
    const auto &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};  // |n| = 2 * area: area weighting
    for (auto v : t)
      for (int k = 0; k < 3; ++k) acc[v][k] += n[k];
  }
  std::vector<std::array<float, 3>> normals(acc.size());
  for (std::size_t v = 0; v < acc.size(); ++v) {
    const double len =
        std::sqrt(acc[v][0] * acc[v][0] + acc[v][1] * acc[v][1] + acc[v][2] * acc[v][2]);
    if (len > 0 && std::isfinite(len))
      normals[v] = {float(acc[v][0] / len), float(acc[v][1] / len), float(acc[v][2] / len)};
    else
      normals[v] = {0, 0, 1};
  }
  return normals;
}

void compute_normals(TriMesh& mesh) { mesh.normals = area_weighted_normals(mesh); }

}  // namespace qjulia
