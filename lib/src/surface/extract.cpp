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
  std::vector<std::uint32_t> owned_comp;  // per owned edge vertex
  struct Comp {
    std::size_t faces = 0, vertices = 0;
    double area = 0, volume = 0;
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  };
  std::vector<Comp> comps;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;  // (foreign vertex, local comp)
};

// The vertices and faces of one brick in the mesh: edge vertices [edge, edge + edges), centre
// vertices [centre, centre + centres), faces [face, face + faces).
struct BrickRange {
  std::size_t edge = 0, edges = 0, centre = 0, centres = 0, face = 0, faces = 0;
  bool owns(std::uint32_t v) const {
    return (v >= edge && v < edge + edges) || (v >= centre && v < centre + centres);
  }
  std::uint32_t local(std::uint32_t v) const {
    return static_cast<std::uint32_t>(v >= edge && v < edge + edges ? v - edge
                                                                    : edges + (v - centre));
  }
};

// Measures a brick's faces (written in `mesh` at r.face): area and signed volume relative to
// `origin`, components within the brick, and the pairing of the half-edges inside the brick
// (those on the brick's faces, `border`, pair with the neighbours'). Writes each face's local
// component to face_comp.
BrickMeasure measure_brick(const TriMesh& mesh, const BrickRange& r,
                           const std::vector<std::array<std::uint32_t, 2>>* border,
                           const std::array<double, 3>& origin, std::uint32_t* face_comp) {
  BrickMeasure bm;
  const std::size_t owned = r.edges + r.centres;
  const auto* tri = mesh.triangles.data() + r.face;
  // Local slots: owned vertices, then foreign ones.
  std::vector<std::uint32_t> foreign;
  for (std::size_t f = 0; f < r.faces; ++f)
    for (std::uint32_t v : tri[f])
      if (!r.owns(v)) foreign.push_back(v);
  std::sort(foreign.begin(), foreign.end());
  foreign.erase(std::unique(foreign.begin(), foreign.end()), foreign.end());
  auto slot = [&](std::uint32_t v) -> std::uint32_t {
    if (r.owns(v)) return r.local(v);
    return static_cast<std::uint32_t>(
        owned + (std::lower_bound(foreign.begin(), foreign.end(), v) - foreign.begin()));
  };
  UnionFind uf(owned + foreign.size());
  for (std::size_t f = 0; f < r.faces; ++f) {
    const std::uint32_t a = slot(tri[f][0]), b = slot(tri[f][1]), c = slot(tri[f][2]);
    uf.unite(a, b);
    uf.unite(b, c);
  }
  std::vector<std::uint32_t> comp_of(owned + foreign.size(), UINT32_MAX);
  for (std::size_t s = 0; s < comp_of.size(); ++s) {
    const std::uint32_t root = uf.find(static_cast<std::uint32_t>(s));
    if (comp_of[root] == UINT32_MAX) {
      comp_of[root] = static_cast<std::uint32_t>(bm.comps.size());
      bm.comps.emplace_back();
    }
    comp_of[s] = comp_of[root];
  }
  bm.owned_comp.assign(comp_of.begin(), comp_of.begin() + r.edges);
  for (std::size_t v = 0; v < owned; ++v) {
    BrickMeasure::Comp& c = bm.comps[comp_of[v]];
    ++c.vertices;
    const auto& p = mesh.positions[v < r.edges ? r.edge + v : r.centre + (v - r.edges)];
    for (int a = 0; a < 3; ++a) {
      c.lo[a] = std::min<double>(c.lo[a], p[a]);
      c.hi[a] = std::max<double>(c.hi[a], p[a]);
    }
  }
  for (std::size_t f = 0; f < foreign.size(); ++f)
    bm.links.emplace_back(foreign[f], comp_of[owned + f]);
  for (std::size_t f = 0; f < r.faces; ++f) {
    const auto& t = tri[f];
    const std::uint32_t c = comp_of[slot(t[0])];
    face_comp[f] = c;
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a)
        p[k][a] = static_cast<double>(mesh.positions[t[k]][a]) - origin[a];
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
  // The half-edges, paired in a hash table by their edge: each edge inside the brick has its
  // two half-edges here, opposite; one alone must be on a brick face (`border`, in the same
  // direction), paired with the neighbour's later.
  struct Slot {
    std::uint64_t key;                               // (smaller index << 32 | larger) + 1; 0: empty
    std::uint16_t up, down, border_up, border_down;  // half-edges smaller -> larger and back
  };
  thread_local std::vector<Slot> table;
  thread_local std::vector<std::uint32_t> used;
  std::size_t n_border = 0;
  for (int d = 0; d < 6; ++d) n_border += border[d].size();
  std::size_t size = 64;
  while (size < 2 * (3 * r.faces + n_border)) size *= 2;
  if (table.size() < size) table.resize(size);
  used.clear();
  const std::size_t mask = size - 1;
  auto slot_of = [&](std::uint32_t a, std::uint32_t b) -> Slot& {
    const std::uint64_t key = ((std::uint64_t{std::min(a, b)} << 32) | std::max(a, b)) + 1;
    std::size_t h = (key * 0x9E3779B97F4A7C15ull) >> 20;
    for (;; ++h) {
      Slot& s = table[h & mask];
      if (s.key == key) return s;
      if (s.key == 0) {
        s = {key, 0, 0, 0, 0};
        used.push_back(static_cast<std::uint32_t>(h & mask));
        return s;
      }
    }
  };
  for (std::size_t f = 0; f < r.faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = tri[f][k], b = tri[f][(k + 1) % 3];
      Slot& s = slot_of(a, b);
      ++(a < b ? s.up : s.down);
    }
  for (int d = 0; d < 6; ++d)
    for (const auto& e : border[d]) {
      Slot& s = slot_of(e[0], e[1]);
      ++(e[0] < e[1] ? s.border_up : s.border_down);
    }
  for (std::uint32_t u : used) {
    Slot& s = table[u];
    const int count = s.up + s.down;
    if (count == 2 && s.up == 1 && s.border_up + s.border_down == 0) {
      ++bm.edges;
    } else if (count == 1 && s.border_up == s.up && s.border_down == s.down) {
      // a border half-edge
    } else {
      bm.problems += static_cast<std::size_t>(count > 0 ? count : 1);
    }
    s.key = 0;  // the table is left empty for the next brick
  }
  return bm;
}

// Meshes the bricks in two parallel passes and measures the mesh as it is made. Pass one: each
// brick's vertices (numbered brick after brick in key order, then the centre vertices) and
// counts. Pass two: each brick writes its triangles in place (corners on a neighbour's edges
// found through the neighbour's sorted edge codes) and measures them; the half-edges on brick
// faces pair with the neighbour's across; components merge through the shared vertices. With
// `release`, each brick's values go once it is meshed, so the grid and the mesh are never both
// whole in memory.
TriMesh extract_bricks(SampledGrid::Impl& impl, bool release, const ExtractOptions& opts,
                       ExtractStats* stats) {
  auto report = [&](double f) {
    if (opts.cancel && opts.cancel->requested()) throw Cancelled();
    if (opts.progress && !opts.progress(f)) throw Cancelled();
  };
  if (release) {  // bricks without surface cells are not needed any more
    impl.bricks.erase(
        std::remove_if(impl.bricks.begin(), impl.bricks.end(),
                       [](const std::unique_ptr<detail::Brick>& b) { return !b->surface.any(); }),
        impl.bricks.end());
    malloc_trim(0);
  }
  const std::size_t nb = impl.bricks.size();
  detail::BrickMeshOptions bopts;
  bopts.tolerance = opts.tolerance;
  bopts.max_refine_steps = opts.max_refine_steps;
  std::mutex report_mutex;
  auto each_brick = [&](double from, double to, auto&& f) {
    std::atomic<std::size_t> done{0};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nb, 4),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        if (opts.cancel && opts.cancel->requested()) throw Cancelled();
                        for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
                        const std::size_t k = done += r.size();
                        if ((k / 64) != ((k - r.size()) / 64)) {
                          std::lock_guard<std::mutex> lock(report_mutex);
                          report(from + (to - from) * k / nb);
                        }
                      });
  };
  // Pass one: the edge vertices.
  std::vector<detail::BrickVertices> verts(nb);
  each_brick(0.0, 0.35, [&](std::size_t i) {
    verts[i] = detail::brick_vertices(*impl.bricks[i], *impl.solid, impl.geometry, bopts);
  });
  std::unordered_map<std::uint64_t, std::size_t> index;
  index.reserve(nb * 2);
  for (std::size_t i = 0; i < nb; ++i) index.emplace(verts[i].key, i);
  auto neighbour = [&](std::size_t i, int dx, int dy, int dz) -> std::ptrdiff_t {
    const detail::BrickCoord at = detail::brick_of_key(verts[i].key);
    const auto it = index.find(detail::brick_key(at.x + dx, at.y + dy, at.z + dz));
    return it == index.end() ? -1 : static_cast<std::ptrdiff_t>(it->second);
  };
  std::vector<BrickRange> range(nb);
  // The vertices around brick i: its own and its +x, +y, +z neighbours'.
  auto around = [&](std::size_t i, bool positions) {
    detail::BrickNeighbours a;
    for (int dir = 0; dir < 8; ++dir) {
      const std::ptrdiff_t n = dir == 0 ? static_cast<std::ptrdiff_t>(i)
                                        : neighbour(i, dir & 1, (dir >> 1) & 1, dir >> 2);
      if (n < 0) continue;
      a.codes[dir] = &verts[n].codes;
      if (positions) a.positions[dir] = verts[n].positions.data();
      a.base[dir] = range[n].edge;
    }
    return a;
  };
  // Pass two: how each cell is triangulated, and the centre vertices.
  std::vector<detail::BrickPlan> plans(nb);
  each_brick(0.35, 0.5, [&](std::size_t i) {
    plans[i] =
        detail::plan_brick(*impl.bricks[i], *impl.solid, impl.geometry, bopts, around(i, true));
    if (release) impl.bricks[i].reset();  // the plan holds what is left to do with its values
  });
  if (release) {
    impl.bricks.clear();
    impl.bricks.shrink_to_fit();
    malloc_trim(0);
  }
  std::size_t edges_total = 0, centres_total = 0, faces_total = 0, unmended = 0;
  std::uint64_t evaluations = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    range[i].edge = edges_total;
    range[i].edges = verts[i].positions.size();
    range[i].face = faces_total;
    range[i].faces = plans[i].triangles;
    range[i].centres = plans[i].centres.size();
    edges_total += range[i].edges;
    faces_total += range[i].faces;
    centres_total += range[i].centres;
    evaluations += verts[i].evaluations + plans[i].evaluations;
    unmended += plans[i].unmended;
  }
  for (std::size_t i = 0, c = edges_total; i < nb; ++i) {
    range[i].centre = c;
    c += range[i].centres;
  }
  if (edges_total + centres_total > 0xffffffffu)
    throw TooLarge("the mesh has " + std::to_string(edges_total + centres_total) +
                   " vertices; 32-bit indices hold at most 4294967295");
  TriMesh mesh;
  mesh.positions.resize(edges_total + centres_total);
  mesh.triangles.resize(faces_total);
  for (std::size_t i = 0; i < nb; ++i) {
    std::copy(verts[i].positions.begin(), verts[i].positions.end(),
              mesh.positions.begin() + range[i].edge);
    std::copy(plans[i].centres.begin(), plans[i].centres.end(),
              mesh.positions.begin() + range[i].centre);
    std::vector<std::array<float, 3>>().swap(verts[i].positions);
    std::vector<std::array<float, 3>>().swap(plans[i].centres);
  }
  malloc_trim(0);
  // Pass three: the triangles, with the measures of each brick.
  const std::array<double, 3> origin = impl.geometry.origin;
  std::vector<detail::BrickFaces> faces(nb);
  std::vector<BrickMeasure> bm(nb);
  std::vector<std::uint32_t> face_component(faces_total);
  each_brick(0.5, 0.9, [&](std::size_t i) {
    detail::MeshTarget target;
    target.triangles = mesh.triangles.data();
    target.centre_base = range[i].centre;
    target.face_base = range[i].face;
    target.around = around(i, false);
    faces[i] = detail::brick_triangles(plans[i], target);
    std::vector<std::uint32_t>().swap(plans[i].cells);
    bm[i] = measure_brick(mesh, range[i], faces[i].border, origin,
                          face_component.data() + range[i].face);
  });
  // The half-edges on brick faces: each brick's +x, +y, +z lists against the neighbour's -x,
  // -y, -z lists, reversed.
  std::vector<std::size_t> border_edges(nb, 0), border_problems(nb, 0);
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    for (int axis = 0; axis < 3; ++axis) {
      auto key = [](const std::array<std::uint32_t, 2>& e) {
        return std::make_pair(std::min(e[0], e[1]), std::max(e[0], e[1]));
      };
      std::vector<std::array<std::uint32_t, 2>> up = faces[i].border[2 * axis + 1];
      const std::ptrdiff_t n = neighbour(i, axis == 0, axis == 1, axis == 2);
      std::vector<std::array<std::uint32_t, 2>> down;
      if (n >= 0) down = faces[n].border[2 * axis];
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
        border_problems[i] += faces[i].border[2 * axis].size();
  });
  // Components across bricks: local components joined through the vertices they share.
  std::vector<std::size_t> comp_first(nb + 1, 0);
  for (std::size_t i = 0; i < nb; ++i) comp_first[i + 1] = comp_first[i] + bm[i].comps.size();
  UnionFind uf(comp_first[nb]);
  // The owner of a shared vertex: the brick whose edge vertices hold it (centre vertices are
  // never shared).
  std::vector<std::size_t> edge_first(nb);
  for (std::size_t i = 0; i < nb; ++i) edge_first[i] = range[i].edge;
  for (std::size_t i = 0; i < nb; ++i)
    for (const auto& [v, c] : bm[i].links) {
      const std::size_t owner =
          std::upper_bound(edge_first.begin(), edge_first.end(), v) - edge_first.begin() - 1;
      uf.unite(static_cast<std::uint32_t>(comp_first[i] + c),
               static_cast<std::uint32_t>(comp_first[owner] +
                                          bm[owner].owned_comp[v - range[owner].edge]));
    }
  faces.clear();
  faces.shrink_to_fit();
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
  report(0.95);
  // Each face's component: its brick's local component, merged.
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    for (std::size_t f = range[i].face; f < range[i].face + range[i].faces; ++f)
      face_component[f] =
          root_index[uf.find(static_cast<std::uint32_t>(comp_first[i] + face_component[f]))];
  });
  verts.clear();
  verts.shrink_to_fit();
  bm.clear();
  bm.shrink_to_fit();
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
    stats->unembedded_cells = unmended;
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
  TriMesh mesh = extract_bricks(grid.impl(), true, opts, stats);
  malloc_trim(0);  // the many small blocks of the bricks' passes, free now
  return mesh;
}

}  // namespace qjulia
