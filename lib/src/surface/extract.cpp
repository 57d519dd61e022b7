#include "qjulia/surface/extract.h"

#include <malloc.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "grid/grid_impl.h"
#include "qjulia/base/error.h"
#include "surface/brick_mesh.h"
#include "surface/color.h"

namespace qjulia {
namespace {

using detail::BrickMesh;

// A small union-find over indices.
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

// What one brick contributes to the measures of the mesh.
struct BrickMeasure {
  std::size_t edges = 0;       // undirected edges inside the brick (both faces here)
  std::size_t problems = 0;    // half-edges inside the brick that do not pair up
  std::size_t degenerate = 0;  // faces with a repeated corner or no area
  // Local components (vertex-connected within the brick).
  std::vector<std::uint32_t> owned_comp;  // per owned vertex
  struct Comp {
    std::size_t faces = 0, vertices = 0;
    double area = 0, volume = 0;
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  };
  std::vector<Comp> comps;
  std::vector<std::uint32_t> face_comp;                        // per face, local component
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;  // (foreign vertex, local comp)
};

// The measures of a brick's faces (global vertex ids), relative to `origin` for precision.
template <class Position>
BrickMeasure measure_brick(const BrickMesh& m, std::size_t first,
                           const std::array<double, 3>& origin, const Position& foreign_position) {
  BrickMeasure bm;
  const std::size_t owned = m.positions.size();
  // Local slots: owned vertices, then foreign ones in order of appearance.
  std::vector<std::uint32_t> foreign;  // sorted unique global ids of foreign corners
  for (const auto& t : m.triangles)
    for (std::uint32_t v : t)
      if (v < first || v >= first + owned) foreign.push_back(v);
  std::sort(foreign.begin(), foreign.end());
  foreign.erase(std::unique(foreign.begin(), foreign.end()), foreign.end());
  auto slot = [&](std::uint32_t v) -> std::uint32_t {
    if (v >= first && v < first + owned) return static_cast<std::uint32_t>(v - first);
    return static_cast<std::uint32_t>(
        owned + (std::lower_bound(foreign.begin(), foreign.end(), v) - foreign.begin()));
  };
  UnionFind uf(owned + foreign.size());
  for (const auto& t : m.triangles) {
    const std::uint32_t a = slot(t[0]), b = slot(t[1]), c = slot(t[2]);
    uf.unite(a, b);
    uf.unite(b, c);
  }
  // Components numbered by their smallest slot.
  std::vector<std::uint32_t> comp_of(owned + foreign.size(), UINT32_MAX);
  for (std::size_t s = 0; s < comp_of.size(); ++s) {
    const std::uint32_t r = uf.find(static_cast<std::uint32_t>(s));
    if (comp_of[r] == UINT32_MAX) {
      comp_of[r] = static_cast<std::uint32_t>(bm.comps.size());
      bm.comps.emplace_back();
    }
    comp_of[s] = comp_of[r];
  }
  bm.owned_comp.assign(comp_of.begin(), comp_of.begin() + owned);
  for (std::size_t v = 0; v < owned; ++v) {
    BrickMeasure::Comp& c = bm.comps[bm.owned_comp[v]];
    ++c.vertices;
    for (int a = 0; a < 3; ++a) {
      c.lo[a] = std::min<double>(c.lo[a], m.positions[v][a]);
      c.hi[a] = std::max<double>(c.hi[a], m.positions[v][a]);
    }
  }
  for (std::size_t f = 0; f < foreign.size(); ++f)
    bm.links.emplace_back(foreign[f], comp_of[owned + f]);
  // Area and signed volume per face.
  bm.face_comp.resize(m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const auto& t = m.triangles[f];
    const std::uint32_t c = comp_of[slot(t[0])];
    bm.face_comp[f] = c;
    double p[3][3];
    for (int k = 0; k < 3; ++k) {
      const auto& q = t[k] >= first && t[k] < first + owned ? m.positions[t[k] - first]
                                                            : foreign_position(t[k]);
      for (int a = 0; a < 3; ++a) p[k][a] = static_cast<double>(q[a]) - origin[a];
    }
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    const double area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double volume = (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                           p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                           p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) /
                          6.0;
    BrickMeasure::Comp& cm = bm.comps[c];
    ++cm.faces;
    cm.area += area;
    cm.volume += volume;
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area == 0) ++bm.degenerate;
  }
  // Half-edges: those inside the brick pair up here; those on the brick's faces are the
  // border lists, matched with the neighbours.
  struct Half {
    std::uint32_t lo, hi;
    bool forward;
    bool operator<(const Half& o) const {
      return lo != o.lo ? lo < o.lo : hi != o.hi ? hi < o.hi : forward < o.forward;
    }
  };
  std::vector<Half> half;
  half.reserve(3 * m.triangles.size());
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      half.push_back({std::min(a, b), std::max(a, b), a < b});
    }
  std::vector<Half> border;
  for (const auto& list : m.border)
    for (const auto& e : list)
      border.push_back({std::min(e[0], e[1]), std::max(e[0], e[1]), e[0] < e[1]});
  std::sort(half.begin(), half.end());
  std::sort(border.begin(), border.end());
  std::size_t bi = 0;
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    while (j < half.size() && half[j].lo == half[i].lo && half[j].hi == half[i].hi) ++j;
    const std::size_t count = j - i;
    if (count == 2 && half[i].forward != half[i + 1].forward) {
      ++bm.edges;
    } else if (count == 1) {
      // Must be a border half-edge (matched with the neighbour later).
      while (bi < border.size() && border[bi] < half[i]) ++bi;
      if (!(bi < border.size() && border[bi].lo == half[i].lo && border[bi].hi == half[i].hi &&
            border[bi].forward == half[i].forward))
        ++bm.problems;
    } else {
      bm.problems += count;
    }
    i = j;
  }
  return bm;
}

// Meshes every brick (in parallel, any order), then joins them in key order: vertices numbered
// brick after brick, corners on a neighbour's edge resolved through the neighbour's sorted edge
// codes. The measures come out of the bricks: each measures its faces and pairs the half-edges
// inside it; the half-edges on a brick face pair with the neighbour's across it; components
// merge through the shared vertices. With `release`, each brick's values go as soon as it is
// meshed and each brick's mesh as soon as it is joined, so memory holds about one copy of the
// mesh.
TriMesh extract_bricks(SampledGrid::Impl& impl, bool release, const ExtractOptions& opts,
                       ExtractStats* stats) {
  auto report = [&](double f) {
    if (opts.cancel && opts.cancel->requested()) throw Cancelled();
    if (opts.progress && !opts.progress(f)) throw Cancelled();
  };
  const std::size_t nb = impl.bricks.size();
  std::vector<BrickMesh> meshes(nb);
  detail::BrickMeshOptions bopts;
  bopts.tolerance = opts.tolerance;
  bopts.max_refine_steps = opts.max_refine_steps;
  std::atomic<std::size_t> done{0};
  std::mutex report_mutex;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, nb, 4), [&](const tbb::blocked_range<std::size_t>& r) {
        if (opts.cancel && opts.cancel->requested()) throw Cancelled();
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          meshes[i] = detail::mesh_brick(*impl.bricks[i], *impl.solid, impl.geometry, bopts);
          if (release) impl.bricks[i].reset();
        }
        const std::size_t k = done += r.size();
        if ((k / 64) != ((k - r.size()) / 64)) {
          std::lock_guard<std::mutex> lock(report_mutex);
          report(0.7 * k / nb);
        }
      });
  if (release) {
    impl.bricks.clear();
    impl.bricks.shrink_to_fit();
  }
  // Vertex numbers: brick after brick.
  std::vector<std::size_t> first(nb + 1, 0), first_face(nb + 1, 0);
  std::uint64_t evaluations = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    first[i + 1] = first[i] + meshes[i].positions.size();
    first_face[i + 1] = first_face[i] + meshes[i].triangles.size();
    evaluations += meshes[i].evaluations;
  }
  if (first[nb] > 0xffffffffu)
    throw TooLarge("the mesh has " + std::to_string(first[nb]) +
                   " vertices; 32-bit indices hold at most 4294967295");
  std::unordered_map<std::uint64_t, std::size_t> index;
  index.reserve(nb * 2);
  for (std::size_t i = 0; i < nb; ++i) index.emplace(meshes[i].key, i);
  auto neighbour = [&](std::size_t i, int dx, int dy, int dz) -> std::ptrdiff_t {
    const detail::BrickCoord at = detail::brick_of_key(meshes[i].key);
    const auto it = index.find(detail::brick_key(at.x + dx, at.y + dy, at.z + dz));
    return it == index.end() ? -1 : static_cast<std::ptrdiff_t>(it->second);
  };
  // Resolve the corners on neighbours' edges (in parallel, in place).
  auto resolve = [&](std::size_t i, std::uint32_t v) -> std::uint32_t {
    if (!(v & detail::kForeign)) return static_cast<std::uint32_t>(first[i] + v);
    const int dir = (v >> 12) & 7, code = v & 0xfff;
    const std::ptrdiff_t n = neighbour(i, dir & 1, (dir >> 1) & 1, dir >> 2);
    if (n < 0) throw std::logic_error("extract: a neighbour brick is missing");
    const BrickMesh& m = meshes[n];
    const auto c = std::lower_bound(m.codes.begin(), m.codes.end(), code);
    if (c == m.codes.end() || *c != code)
      throw std::logic_error("extract: a neighbour brick lacks a shared vertex");
    return static_cast<std::uint32_t>(first[n] + (c - m.codes.begin()));
  };
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    for (auto& tri : meshes[i].triangles)
      for (std::uint32_t& v : tri) v = resolve(i, v);
    for (auto& list : meshes[i].border)
      for (auto& e : list) {
        e[0] = resolve(i, e[0]);
        e[1] = resolve(i, e[1]);
      }
  });
  // Measures per brick.
  auto position_of = [&](std::uint32_t v) -> const std::array<float, 3>& {
    const std::size_t b = std::upper_bound(first.begin(), first.end(), v) - first.begin() - 1;
    return meshes[b].positions[v - first[b]];
  };
  const std::array<double, 3> origin = impl.geometry.origin;
  std::vector<BrickMeasure> bm(nb);
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    bm[i] = measure_brick(meshes[i], first[i], origin, position_of);
  });
  // The half-edges on brick faces: each brick's +x, +y, +z lists against the neighbour's -x,
  // -y, -z lists, reversed.
  std::vector<std::size_t> border_edges(nb, 0), border_problems(nb, 0);
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    for (int axis = 0; axis < 3; ++axis) {
      auto key = [](const std::array<std::uint32_t, 2>& e) {
        return std::make_pair(std::min(e[0], e[1]), std::max(e[0], e[1]));
      };
      std::vector<std::array<std::uint32_t, 2>> up = meshes[i].border[2 * axis + 1];
      const std::ptrdiff_t n = neighbour(i, axis == 0, axis == 1, axis == 2);
      std::vector<std::array<std::uint32_t, 2>> down;
      if (n >= 0) down = meshes[n].border[2 * axis];
      auto less = [&](const auto& a, const auto& b) { return key(a) < key(b); };
      std::sort(up.begin(), up.end(), less);
      std::sort(down.begin(), down.end(), less);
      std::size_t j = 0;
      for (const auto& e : up) {
        while (j < down.size() && less(down[j], e)) {
          ++border_problems[i];
          ++j;
        }
        if (j < down.size() && key(down[j]) == key(e) && down[j][0] == e[1] && down[j][1] == e[0]) {
          ++border_edges[i];
          ++j;
        } else {
          ++border_problems[i];
        }
      }
      border_problems[i] += down.size() - std::min(j, down.size());
    }
    // A -x, -y, -z face with no neighbour leaves its border open.
    for (int axis = 0; axis < 3; ++axis)
      if (neighbour(i, -(axis == 0), -(axis == 1), -(axis == 2)) < 0)
        border_problems[i] += meshes[i].border[2 * axis].size();
  });
  // Components across bricks: local components joined through the vertices they share.
  std::vector<std::size_t> comp_first(nb + 1, 0);
  for (std::size_t i = 0; i < nb; ++i) comp_first[i + 1] = comp_first[i] + bm[i].comps.size();
  UnionFind uf(comp_first[nb]);
  for (std::size_t i = 0; i < nb; ++i)
    for (const auto& [v, c] : bm[i].links) {
      const std::size_t owner = std::upper_bound(first.begin(), first.end(), v) - first.begin() - 1;
      uf.unite(
          static_cast<std::uint32_t>(comp_first[i] + c),
          static_cast<std::uint32_t>(comp_first[owner] + bm[owner].owned_comp[v - first[owner]]));
    }
  MeshMeasure m;
  std::size_t problems = 0, degenerate = 0;
  std::vector<std::uint32_t> root_index(comp_first[nb], UINT32_MAX);
  struct Total {
    ComponentMeasure c;
    std::size_t vertices = 0;
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    std::uint32_t order = 0;  // first vertex, for a stable order
  };
  std::vector<Total> totals;
  for (std::size_t i = 0; i < nb; ++i) {
    m.edges += bm[i].edges + border_edges[i];
    problems += bm[i].problems + border_problems[i];
    degenerate += bm[i].degenerate;
    for (std::size_t c = 0; c < bm[i].comps.size(); ++c) {
      const std::uint32_t r = uf.find(static_cast<std::uint32_t>(comp_first[i] + c));
      if (root_index[r] == UINT32_MAX) {
        root_index[r] = static_cast<std::uint32_t>(totals.size());
        totals.emplace_back();
        totals.back().order = static_cast<std::uint32_t>(totals.size() - 1);
      }
      Total& t = totals[root_index[r]];
      const auto& lc = bm[i].comps[c];
      t.c.faces += lc.faces;
      t.c.area += lc.area;
      t.c.volume += lc.volume;
      t.vertices += lc.vertices;
      for (int a = 0; a < 3; ++a) {
        t.lo[a] = std::min(t.lo[a], lc.lo[a]);
        t.hi[a] = std::max(t.hi[a], lc.hi[a]);
      }
    }
  }
  report(0.8);
  // Join, freeing each brick's part as it is copied; each face gets its component.
  TriMesh mesh;
  mesh.positions.reserve(first[nb]);
  mesh.triangles.reserve(first_face[nb]);
  std::vector<std::uint32_t> face_component;
  face_component.reserve(first_face[nb]);
  std::size_t freed = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    BrickMesh& bmesh = meshes[i];
    mesh.positions.insert(mesh.positions.end(), bmesh.positions.begin(), bmesh.positions.end());
    mesh.triangles.insert(mesh.triangles.end(), bmesh.triangles.begin(), bmesh.triangles.end());
    for (std::uint32_t c : bm[i].face_comp)
      face_component.push_back(root_index[uf.find(static_cast<std::uint32_t>(comp_first[i] + c))]);
    freed += bmesh.positions.size() * 12 + bmesh.triangles.size() * 12;
    std::vector<std::array<float, 3>>().swap(bmesh.positions);
    std::vector<std::array<std::uint32_t, 3>>().swap(bmesh.triangles);
    for (auto& list : bmesh.border) std::vector<std::array<std::uint32_t, 2>>().swap(list);
    std::vector<std::uint32_t>().swap(bm[i].face_comp);
    if (release && freed > (std::size_t{64} << 20)) {
      malloc_trim(0);  // return the freed pages now: the copy grows as the parts shrink
      freed = 0;
    }
  }
  meshes.clear();
  meshes.shrink_to_fit();
  bm.clear();
  bm.shrink_to_fit();
  if (release) malloc_trim(0);
  // The measures. Closed by construction, which the pairing checked: then every vertex's
  // faces form one fan (each grid edge's vertex lies in one loop of each cell around the edge,
  // and the loops of neighbouring cells share their segments), Euler per component is
  // V - F / 2, and the components are listed by decreasing face count.
  m.vertices = mesh.positions.size();
  m.faces = mesh.triangles.size();
  m.degenerate_faces = degenerate;
  m.boundary_edges = problems;
  m.closed = problems == 0;
  m.manifold = problems == 0;
  m.oriented = problems == 0;
  std::vector<std::uint32_t> order(totals.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return totals[a].c.faces > totals[b].c.faces;
  });
  std::vector<std::uint32_t> rank(order.size());
  for (std::size_t r = 0; r < order.size(); ++r) rank[order[r]] = static_cast<std::uint32_t>(r);
  for (auto& c : face_component) c = rank[c];
  std::vector<std::array<double, 6>> component_bbox;
  bool first_box = true;
  for (std::uint32_t o : order) {
    Total& t = totals[o];
    t.c.closed = m.closed;
    t.c.euler = static_cast<long long>(t.vertices) - static_cast<long long>(t.c.faces) / 2;
    t.c.genus = t.c.closed ? (2 - t.c.euler) / 2 : -1;
    m.volume += t.c.volume;
    m.area += t.c.area;
    for (int a = 0; a < 3; ++a) {
      m.bbox_min[a] = first_box ? t.lo[a] : std::min(m.bbox_min[a], t.lo[a]);
      m.bbox_max[a] = first_box ? t.hi[a] : std::max(m.bbox_max[a], t.hi[a]);
    }
    first_box = false;
    component_bbox.push_back({t.lo[0], t.lo[1], t.lo[2], t.hi[0], t.hi[1], t.hi[2]});
    m.components.push_back(t.c);
  }
  m.euler = static_cast<long long>(m.vertices) - static_cast<long long>(m.edges) +
            static_cast<long long>(m.faces);
  compute_normals(mesh);
  if (opts.color != ColorMode::kNone)
    evaluations += detail::colorize(mesh, *impl.solid, impl.geometry.voxel, opts.color);
  if (stats) {
    stats->evaluations = evaluations;
    stats->measure_valid = m.closed && degenerate == 0;
    stats->measure = std::move(m);
    stats->face_component = std::move(face_component);
    stats->component_bbox = std::move(component_bbox);
  }
  report(1.0);
  return mesh;
}

}  // namespace

TriMesh extract(const SampledGrid& grid, const ExtractOptions& opts, ExtractStats* stats) {
  return extract_bricks(const_cast<SampledGrid::Impl&>(grid.impl()), false, opts, stats);
}

TriMesh extract(SampledGrid&& grid, const ExtractOptions& opts, ExtractStats* stats) {
  return extract_bricks(grid.impl(), true, opts, stats);
}

}  // namespace qjulia
