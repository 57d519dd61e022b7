#include "qjulia/surface/extract.h"

#include <malloc.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "base/distribution.h"
#include "base/first_touch.h"
#include "base/geometry.h"
#include "base/stage_progress.h"
#include "base/union_find.h"
#include "grid/brick_pool.h"
#include "grid/grid_impl.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "surface/brick_mesh.h"
#include "surface/color.h"
#include "surface/pairing.h"
#include "surface/part.h"

namespace qjulia {
namespace {

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
    std::array<double, 3> normal_sum{0, 0, 0};  // of its faces' (b - a) x (c - a)
  };
  std::vector<Comp> comps;
  // (foreign vertex, local comp); link_components() makes them pairs of whole-mesh components.
  std::vector<std::array<std::uint32_t, 2>> links;
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

// Each face of a brick (tri[0 .. faces), corner: each face corner's local slot): its local
// component (that of its first corner's slot, written to face_comp), its area, its signed volume
// relative to the brick's base point and its (b - a) x (c - a) (added to its component's), and
// whether it is degenerate. `at`: each slot's position relative to the base point.
void measure_faces(const std::array<std::uint32_t, 3>* tri, std::size_t faces,
                   const std::uint32_t* corner, const std::vector<std::uint32_t>& comp_of,
                   const std::array<double, 3>* at, std::uint32_t* face_comp, BrickMeasure& bm) {
  for (std::size_t f = 0; f < faces; ++f) {
    const auto& t = tri[f];
    const std::uint32_t c = comp_of[corner[3 * f]];
    face_comp[f] = c;
    const std::array<double, 3>& p0 = at[corner[3 * f]];
    const std::array<double, 3>& p1 = at[corner[3 * f + 1]];
    const std::array<double, 3>& p2 = at[corner[3 * f + 2]];
    const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    const double area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double volume =
        (p0[0] * (p1[1] * p2[2] - p1[2] * p2[1]) - p0[1] * (p1[0] * p2[2] - p1[2] * p2[0]) +
         p0[2] * (p1[0] * p2[1] - p1[1] * p2[0])) /
        6.0;
    BrickMeasure::Comp& cm = bm.comps[c];
    ++cm.faces;
    cm.area += area;
    cm.volume += volume;
    for (int a = 0; a < 3; ++a) cm.normal_sum[a] += n[a];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area == 0) ++bm.degenerate;
  }
}

// Measures a brick's faces (written in `mesh` at r.face): area and signed volume relative to
// `origin` (computed relative to a point of the brick, to the precision of the brick's small
// coordinates, then moved to `origin`), components within the brick, and the pairing of the
// half-edges inside the brick (those on the brick's faces, `border`, pair with the neighbours').
// Writes each face's local component to face_comp.
template <class PositionOf>
BrickMeasure measure_brick(const TriMesh& mesh, const PositionOf& position_of, const BrickRange& r,
                           const std::vector<std::array<std::uint32_t, 2>>* border,
                           const std::array<double, 3>& origin, std::uint32_t* face_comp) {
  BrickMeasure bm;
  const std::size_t owned = r.edges + r.centres;
  const auto* tri = mesh.triangles.data() + r.face;
  // Local slots: owned vertices, then foreign ones (in index order); each face corner's slot,
  // found once. The foreign vertices are found in a small hash table (most corners are owned;
  // a foreign vertex is a corner of about six faces).
  thread_local std::vector<std::uint32_t> foreign, corner, comp_of;
  thread_local std::vector<std::array<std::uint32_t, 2>> table;  // {vertex + 1, slot}; 0: empty
  thread_local std::vector<std::array<double, 3>> local_at;
  thread_local std::vector<std::size_t> taken;                   // its entries in use
  thread_local detail::UnionFind uf;
  // The entries the last brick filled are emptied first (also after an exception left them),
  // and each entry is recorded in `taken` before it is filled.
  for (std::size_t h : taken) table[h] = {0, 0};
  taken.clear();
  std::size_t size = 64;
  while (size < 6 * r.faces) size *= 2;
  if (table.size() < size) table.assign(size, {0, 0});
  const std::size_t mask = size - 1;
  auto find = [&](std::uint32_t v) -> std::array<std::uint32_t, 2>& {
    for (std::size_t h = (v * 0x9E3779B1u) & mask;; h = (h + 1) & mask)
      if (table[h][0] == v + 1 || table[h][0] == 0) return table[h];
  };
  // Each corner's slot: an owned vertex's at once, a foreign one's table entry (marked by the
  // top bit) until the foreign vertices are numbered in index order.
  constexpr std::uint32_t kEntry = 0x80000000u;
  foreign.clear();
  corner.resize(3 * r.faces);
  std::size_t foreign_corners = 0;
  for (std::size_t f = 0; f < r.faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = tri[f][k];
      std::uint32_t s;
      if (r.owns(v)) {
        s = r.local(v);
      } else {
        auto& e = find(v);
        const std::size_t h = static_cast<std::size_t>(&e - table.data());
        if (e[0] == 0) {
          taken.push_back(h);
          foreign.push_back(v);
          e[0] = v + 1;
        }
        s = kEntry | static_cast<std::uint32_t>(h);
        ++foreign_corners;
      }
      corner[3 * f + k] = s;
    }
  std::sort(foreign.begin(), foreign.end());
  for (std::size_t k = 0; k < foreign.size(); ++k)
    find(foreign[k])[1] = static_cast<std::uint32_t>(owned + k);
  if (foreign_corners > 0)
    for (std::uint32_t& s : corner)
      if (s & kEntry) s = table[s & ~kEntry][1];
  auto slot = [&](std::uint32_t v) -> std::uint32_t { return r.owns(v) ? r.local(v) : find(v)[1]; };
  const std::size_t slots = owned + foreign.size();
  uf.reset(slots);
  for (std::size_t f = 0; f < r.faces; ++f) {
    uf.unite(corner[3 * f], corner[3 * f + 1]);
    uf.unite(corner[3 * f + 1], corner[3 * f + 2]);
  }
  bm.comps.resize(uf.labels(comp_of));
  bm.owned_comp.assign(comp_of.begin(), comp_of.begin() + r.edges);
  // Each slot's position relative to the base point (the first face's first corner), converted
  // once (a vertex is a corner of about six faces).
  std::array<double, 3> base = origin;
  if (r.faces > 0) {
    const auto& p = position_of(tri[0][0]);
    base = {p[0], p[1], p[2]};
  }
  local_at.resize(slots);
  for (std::size_t v = 0; v < owned; ++v) {
    BrickMeasure::Comp& c = bm.comps[comp_of[v]];
    ++c.vertices;
    const auto& p = position_of(v < r.edges ? r.edge + v : r.centre + (v - r.edges));
    for (int a = 0; a < 3; ++a) {
      c.lo[a] = std::min<double>(c.lo[a], p[a]);
      c.hi[a] = std::max<double>(c.hi[a], p[a]);
      local_at[v][a] = static_cast<double>(p[a]) - base[a];
    }
  }
  bm.links.reserve(foreign.size());
  for (std::size_t f = 0; f < foreign.size(); ++f) {
    bm.links.push_back({foreign[f], comp_of[owned + f]});
    const auto& p = position_of(foreign[f]);
    for (int a = 0; a < 3; ++a) local_at[owned + f][a] = static_cast<double>(p[a]) - base[a];
  }
  measure_faces(tri, r.faces, corner.data(), comp_of, local_at.data(), face_comp, bm);
  // Relative to `origin`: det(a + t, b + t, c + t) = det(a, b, c) + t . (b - a) x (c - a) for the
  // shift t from `origin` to the base point.
  const std::array<double, 3> t{base[0] - origin[0], base[1] - origin[1], base[2] - origin[2]};
  for (BrickMeasure::Comp& c : bm.comps)
    c.volume += (t[0] * c.normal_sum[0] + t[1] * c.normal_sum[1] + t[2] * c.normal_sum[2]) / 6.0;
  // The half-edges: each edge inside the brick has its two half-edges here, opposite; one
  // alone must be on a brick face (`border`, in the same direction), paired with the
  // neighbour's later.
  thread_local std::vector<std::array<std::uint32_t, 2>> listed;
  listed.clear();
  for (int d = 0; d < 6; ++d)
    for (const auto& e : border[d]) listed.push_back({slot(e[0]), slot(e[1])});
  const detail::HalfEdgePairing pairing =
      detail::pair_half_edges(corner.data(), r.faces, slots, listed.data(), listed.size());
  bm.edges += pairing.edges;
  bm.problems += pairing.problems;
  return bm;
}

// The components of the whole mesh from the bricks' local components (in whole-mesh order)
// joined in `uf` through the vertices they share: their totals, each local component's final index
// (components by decreasing face count), and the measures that follow from them.
struct Components {
  std::vector<std::uint32_t> final_index;  // per local component
  std::vector<ComponentMeasure> measures;
  std::vector<std::array<double, 6>> boxes;
  double volume = 0, area = 0;
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
};

Components resolve_components(const std::vector<BrickMeasure::Comp>& comps, detail::UnionFind& uf,
                              bool closed) {
  struct Total {
    ComponentMeasure c;
    std::size_t vertices = 0;
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  };
  Components out;
  // Each local component's joined one, in the order of their first local components.
  std::vector<Total> totals(uf.labels(out.final_index));
  for (std::size_t i = 0; i < comps.size(); ++i) {
    Total& t = totals[out.final_index[i]];
    const auto& lc = comps[i];
    t.c.faces += lc.faces;
    t.c.area += lc.area;
    t.c.volume += lc.volume;
    t.vertices += lc.vertices;
    for (int a = 0; a < 3; ++a) {
      t.lo[a] = std::min(t.lo[a], lc.lo[a]);
      t.hi[a] = std::max(t.hi[a], lc.hi[a]);
    }
  }
  // Closed by construction, which the pairing checked: then every vertex's faces form one fan
  // (each grid edge's vertex lies in one loop of each cell around the edge, and the loops of
  // neighbouring cells share their segments), Euler per component is V - F / 2, and the
  // components are listed by decreasing face count.
  std::vector<std::uint32_t> order(totals.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return totals[a].c.faces > totals[b].c.faces;
  });
  std::vector<std::uint32_t> rank(order.size());
  for (std::size_t r = 0; r < order.size(); ++r) rank[order[r]] = static_cast<std::uint32_t>(r);
  for (auto& c : out.final_index) c = rank[c];
  bool first_box = true;
  for (std::uint32_t o : order) {
    Total& t = totals[o];
    t.c.closed = closed;
    t.c.euler = static_cast<long long>(t.vertices) - static_cast<long long>(t.c.faces) / 2;
    t.c.genus = t.c.closed ? (2 - t.c.euler) / 2 : -1;
    out.volume += t.c.volume;
    out.area += t.c.area;
    for (int a = 0; a < 3; ++a) {
      out.lo[a] = first_box ? t.lo[a] : std::min(out.lo[a], t.lo[a]);
      out.hi[a] = first_box ? t.hi[a] : std::max(out.hi[a], t.hi[a]);
    }
    first_box = false;
    out.boxes.push_back({t.lo[0], t.lo[1], t.lo[2], t.hi[0], t.hi[1], t.hi[2]});
    out.measures.push_back(t.c);
  }
  return out;
}

// The ranks next to this one: `up` owns the plane of bricks after this rank's last, `down` the
// one before its first (ranks without bricks are skipped).
void find_neighbour_ranks(const detail::Distribution& d, detail::MeshPart& part) {
  const int r = d.comm->rank();
  const int x0 = d.first[r], x1 = d.first[r + 1];
  part.comm = d.comm;
  part.up = part.down = -1;
  if (x0 == x1) return;
  if (x1 < d.first.back()) part.up = d.rank_of(x1);
  if (x0 > d.first.front()) part.down = d.rank_of(x0 - 1);
}

// The resident memory an extraction keeps within when it hands freed memory back
// (return_free_memory): twice the mesh it makes (12 bytes a vertex and a face) + 150 MB, the
// bound this project keeps to, or the memory the run may use when that is less.
std::size_t memory_budget(const ExtractOptions& opts, std::size_t vertices, std::size_t faces) {
  const std::size_t bound = 2 * 12 * (vertices + faces) + std::size_t{150} * 1000 * 1000;
  return opts.memory_limit ? std::min(bound, opts.memory_limit) : bound;
}

// Hands the memory freed between passes back to the system (malloc_trim) when the resident
// memory, `coming` (what the next pass allocates) and a margin for the rest would pass `budget`
// (always when it is 0, not known yet, or the resident memory is not known). A trim costs one
// madvise per free run of pages, serial, and the pages are faulted in again when reused:
// newton-cubic at 512 on two threads trimmed 826 MB in 21,000 calls after every pass.
void give_back_memory(const ExtractOptions& opts, std::size_t budget, std::size_t coming) {
  if (!opts.return_free_memory) return;
  const std::size_t margin = std::max<std::size_t>(std::size_t{64} << 20, budget / 8);
  if (budget) {
    const std::size_t resident = current_rss_bytes();  // 0 when unknown: trim
    if (resident > 0 && resident + coming + margin <= budget) return;
  }
  malloc_trim(0);
}

// Meshes the bricks in three parallel passes and measures the mesh as it is made. Pass one:
// each brick's edge vertices. Pass two: each cell's plan (and the centre vertices). Then the
// vertices are numbered (edge vertices brick after brick in key order, then the centre
// vertices) and pass three writes each brick's triangles in place (corners on a neighbour's
// edges found through the neighbour's sorted edge codes) and measures them; the half-edges on
// brick faces pair with the neighbour's across; components merge through the shared vertices.
// With `release`, each brick's values go once its edge vertices are made, so the grid and the mesh
// are never both whole in memory. With `part` (a distributed run), this rank meshes its own bricks
// and the up rank's first plane of bricks is known by its vertices only; the numbering, the
// pairing across ranks, the components and the normals are agreed with the other ranks, so the
// ranks' parts in rank order are the mesh of one process. run() takes the steps in order; what
// one step leaves for the next is kept in the members.
struct BrickMesher {
  SampledGrid::Impl& impl;
  const bool release;
  const ExtractOptions& opts;
  ExtractStats* const stats;
  detail::MeshPart* const part;
  Comm* const comm;
  std::size_t nb = 0;  // own bricks
  std::size_t nv = 0;  // own bricks, then the up rank's first plane
  detail::BrickMeshOptions bopts;
  detail::RisingProgress progress;  // reported from run() and from the parallel passes
  // Per brick: its edge vertices (pass one), its plan (pass two), its vertices and faces in the
  // mesh (the numbering), its border half-edges (pass three) and its measures.
  std::vector<detail::BrickVertices> verts;
  std::unordered_map<std::uint64_t, std::size_t> index;  // by key
  std::vector<detail::BrickPlan> plans;
  std::vector<BrickRange> range;
  std::vector<detail::BrickFaces> faces;
  std::vector<BrickMeasure> bm;
  std::vector<std::size_t> border_edges, border_problems;
  // Across ranks.
  std::vector<std::size_t> first_plane;     // own bricks in the first plane
  std::unordered_set<std::uint64_t> below;  // the down rank's last plane
  // The numbering: this rank's counts, and where its vertices and faces start.
  std::size_t edges_local = 0, centres_local = 0, faces_local = 0, unmended = 0;
  std::uint64_t evaluations = 0;
  std::uint64_t edge_first = 0, edges_total = 0, centre_first = 0, centres_total = 0,
                face_first = 0, faces_total = 0;
  TriMesh mesh;
  // The components: each brick's first local component, each face's component, and the up
  // rank's first plane's (its first component, its vertices' components).
  std::vector<std::size_t> comp_first;
  std::uint64_t comp_before = 0;
  std::vector<std::uint32_t> face_component;
  std::vector<std::uint64_t> ghost_comp_first;
  std::vector<std::vector<std::uint32_t>> ghost_owned_comp;
  std::vector<std::array<std::uint32_t, 2>> links;
  std::vector<BrickMeasure::Comp> comps;
  detail::UnionFind uf;
  Components resolved;
  std::vector<std::uint32_t> final_index;  // per local component of this rank
  // The measures.
  MeshMeasure m;
  std::size_t problems = 0, degenerate = 0;
  bool closed = false;
  // The resident memory the passes keep within (see memory_budget()); 0 until the vertices are
  // numbered.
  std::size_t budget = 0;

  BrickMesher(SampledGrid::Impl& impl, bool release, const ExtractOptions& opts,
              ExtractStats* stats, detail::MeshPart* part)
      : impl(impl),
        release(release),
        opts(opts),
        stats(stats),
        part(part),
        comm(part ? part->comm : nullptr),
        progress(opts.progress, opts.cancel) {
    bopts.tolerance = opts.tolerance;
    bopts.max_refine_steps = opts.max_refine_steps;
  }

  TriMesh run();

  // With return_free_memory, hands the memory the passes freed back to the system when the
  // resident memory and `coming`, what the next pass allocates, would pass the budget (always
  // before the budget is known).
  void give_back(std::size_t coming) const { give_back_memory(opts, budget, coming); }

  // Throws Cancelled when asked to stop; reports progress f (from any thread).
  void report(double f) { progress.report(f); }

  // Runs f(i) for each own brick in parallel, reporting progress from `from` to `to`.
  template <class F>
  void each_brick(double from, double to, F&& f) {
    std::atomic<std::size_t> done{0};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nb, 4),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        if (opts.cancel && opts.cancel->requested()) throw Cancelled();
                        for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
                        const std::size_t k = done += r.size();
                        if ((k / 64) != ((k - r.size()) / 64))
                          report(from + (to - from) * k / std::max<std::size_t>(nb, 1));
                      });
  }

  // Bricks without surface cells are not needed any more (with `release`): they go in parallel
  // (a serial free of each took 0.02 s at 512^3 on two threads). Their memory is not
  // trimmed here: the next passes reuse it, and a malloc_trim() (one madvise per free run of
  // pages, serial) took 0.035 s at 512^3 on an idle machine and up to 2 s at 1024^3 on a busy
  // one, without lowering the peak at either (the trims after the next passes do).
  void drop_empty_bricks() {
    tbb::parallel_for(std::size_t{0}, impl.bricks.size(), [&](std::size_t i) {
      if (!impl.bricks[i]->surface.any()) impl.bricks[i].reset();
    });
    impl.bricks.erase(std::remove(impl.bricks.begin(), impl.bricks.end(), nullptr),
                      impl.bricks.end());
  }

  // Pass one: the edge vertices, refined in groups of bricks that share their evaluations.
  void edge_vertices() {
    verts.resize(nb);
    constexpr std::size_t kGroup = 16;
    std::atomic<std::size_t> done{0};
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, nb, kGroup),
        [&](const tbb::blocked_range<std::size_t>& r) {
          if (opts.cancel && opts.cancel->requested()) throw Cancelled();
          for (std::size_t i = r.begin(); i < r.end(); i += kGroup) {
            const std::size_t n = std::min(kGroup, r.end() - i);
            const detail::Brick* group[kGroup];
            for (std::size_t k = 0; k < n; ++k) group[k] = impl.bricks[i + k].get();
            detail::brick_vertices(group, n, *impl.solid, impl.geometry, bopts, &verts[i]);
            // The vertices and the cells' cases hold what is left to do with the values.
            if (release)
              for (std::size_t k = 0; k < n; ++k) impl.bricks[i + k].reset();
          }
          const std::size_t k = done += r.size();
          if ((k / 64) != ((k - r.size()) / 64)) report(0.35 * k / std::max<std::size_t>(nb, 1));
        },
        tbb::simple_partitioner());
    if (release) {
      impl.bricks.clear();
      impl.bricks.shrink_to_fit();
    }
  }

  // What this rank's first plane of bricks sends the down rank: put(packer, brick) for each.
  template <class Put>
  std::string send_first_plane(Put&& put) const {
    Packer to_down;
    for (std::size_t i : first_plane) put(to_down, i);
    return std::move(to_down.data);
  }

  // Across ranks: the vertices of this rank's first plane go to the down rank (its faces use
  // them) and the keys of its last plane to the up rank (whose -x faces close against them).
  // The up rank's first plane joins `verts`, after the own bricks.
  void exchange_first_plane() {
    const detail::Distribution& d = *impl.distribution;
    const int x0 = d.first[comm->rank()], x1 = d.first[comm->rank() + 1];
    std::vector<std::uint64_t> last_plane;
    for (std::size_t i = 0; i < nb; ++i) {
      const int bx = detail::brick_of_key(verts[i].key).x;
      if (bx == x0) first_plane.push_back(i);
      if (bx == x1 - 1) last_plane.push_back(verts[i].key);
    }
    Packer to_up;
    to_up.put_vector(last_plane);
    auto [from_down, from_up] = part->swap(send_first_plane([&](Packer& p, std::size_t i) {
                                             p.put(verts[i].key);
                                             p.put_vector(verts[i].codes);
                                             p.put_vector(verts[i].positions);
                                           }),
                                           std::move(to_up.data));
    if (!from_down.empty())
      for (std::uint64_t k : Unpacker(from_down).get_vector<std::uint64_t>()) below.insert(k);
    Unpacker u(from_up);
    while (!u.done()) {
      detail::BrickVertices g;
      g.key = u.get<std::uint64_t>();
      g.codes = u.get_vector<std::uint16_t>();
      g.positions = u.get_vector<std::array<float, 3>>();
      verts.push_back(std::move(g));
    }
  }

  // The bricks by key, so that a brick finds its neighbours.
  void index_bricks() {
    nv = verts.size();
    index.reserve(nv * 2);
    for (std::size_t i = 0; i < nv; ++i) index.emplace(verts[i].key, i);
    range.resize(nv);
  }

  // The brick next to brick i by (dx, dy, dz), or -1.
  std::ptrdiff_t neighbour(std::size_t i, int dx, int dy, int dz) const {
    const detail::BrickCoord at = detail::brick_of_key(verts[i].key);
    const auto it = index.find(detail::brick_key(at.x + dx, at.y + dy, at.z + dz));
    return it == index.end() ? -1 : static_cast<std::ptrdiff_t>(it->second);
  }

  // The vertices around brick i: its own and its +x, +y, +z neighbours'.
  detail::BrickNeighbours around(std::size_t i, bool positions) const {
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
  }

  // Pass two: how each cell is triangulated, and the centre vertices.
  void plan_cells() {
    plans.resize(nb);
    each_brick(0.35, 0.5, [&](std::size_t i) {
      plans[i] = detail::plan_brick(detail::brick_of_key(verts[i].key), std::move(verts[i].cells),
                                    *impl.solid, impl.geometry, bopts, around(i, true));
    });
  }

  // The numbering: this rank's edge vertices after the lower ranks', its centre vertices after
  // every edge vertex and the lower ranks' centre vertices.
  void number_vertices() {
    for (std::size_t i = 0; i < nb; ++i) {
      range[i].edges = verts[i].positions.size();
      range[i].face = faces_local;
      range[i].faces = plans[i].triangles;
      range[i].centres = plans[i].centres.size();
      edges_local += range[i].edges;
      faces_local += range[i].faces;
      centres_local += range[i].centres;
      evaluations += verts[i].evaluations + plans[i].evaluations;
      unmended += plans[i].unmended;
    }
    std::uint64_t centre_before = 0;
    edges_total = edges_local;
    centres_total = centres_local;
    faces_total = faces_local;
    if (comm) {
      edge_first = comm->exclusive_sum(edges_local);
      edges_total = comm->sum(edges_local);
      centre_before = comm->exclusive_sum(centres_local);
      centres_total = comm->sum(centres_local);
      face_first = comm->exclusive_sum(faces_local);
      faces_total = comm->sum(faces_local);
    }
    centre_first = edges_total + centre_before;
    for (std::size_t i = 0, e = edge_first, c = centre_first; i < nb; ++i) {
      range[i].edge = e;
      range[i].centre = c;
      e += range[i].edges;
      c += range[i].centres;
    }
    if (edges_total + centres_total > 0xffffffffu)
      throw TooLarge("the mesh has " + std::to_string(edges_total + centres_total) +
                     " vertices; 32-bit indices hold at most 4294967295");
    // A rank of a distributed run keeps to the same bound for its part (its own vertices and
    // faces; the ghosts are a plane of vertices).
    budget = memory_budget(opts, edges_local + centres_local, faces_local);
  }

  // The mesh's vertices: each brick's edge and centre vertices moved to their numbers.
  void place_positions() {
    detail::resize_first_touched(mesh.positions, edges_local + centres_local);
    detail::resize_first_touched(mesh.triangles, faces_local);
    tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
      std::copy(verts[i].positions.begin(), verts[i].positions.end(),
                mesh.positions.begin() + (range[i].edge - edge_first));
      std::copy(plans[i].centres.begin(), plans[i].centres.end(),
                mesh.positions.begin() + edges_local + (range[i].centre - centre_first));
      std::vector<std::array<float, 3>>().swap(verts[i].positions);
      std::vector<std::array<float, 3>>().swap(plans[i].centres);
    });
    // Next: each face's component, each owned vertex's.
    give_back(4 * (faces_local + edges_local));
  }

  // The part's numbers, the runs of vertices the down rank uses, and the up rank's first plane:
  // where its vertices are numbered, and their positions (the ghosts).
  void number_part() {
    part->edge_first = edge_first;
    part->edges = edges_local;
    part->centre_first = centre_first;
    part->centres = centres_local;
    part->face_first = face_first;
    part->vertices_total = edges_total + centres_total;
    part->faces_total = faces_total;
    part->shared.clear();
    for (std::size_t i : first_plane)
      part->shared.push_back({range[i].edge - edge_first, range[i].edges, 0});
    // The up rank's first plane: where its vertices are numbered.
    const std::string from_up = part->swap(send_first_plane([&](Packer& p, std::size_t i) {
                                             p.put<std::uint64_t>(range[i].edge);
                                           }),
                                           "")
                                    .second;
    Unpacker u(from_up);
    part->ghosts.clear();
    part->ghost_positions.clear();
    for (std::size_t g = nb; g < nv; ++g) {
      range[g].edge = u.get<std::uint64_t>();
      range[g].edges = verts[g].positions.size();
      part->ghosts.push_back({range[g].edge, range[g].edges, part->ghost_positions.size()});
      part->ghost_positions.insert(part->ghost_positions.end(), verts[g].positions.begin(),
                                   verts[g].positions.end());
      std::vector<std::array<float, 3>>().swap(verts[g].positions);
    }
  }

  // The position of whole-mesh vertex v: owned, or (in a distributed run) a ghost.
  const std::array<float, 3>& position_of(std::uint64_t v) const {
    return part ? part->position(mesh, v) : mesh.positions[v];
  }

  // Pass three: the triangles, with the measures of each brick.
  void write_triangles() {
    const std::array<double, 3> origin = impl.geometry.origin;
    auto position = [this](std::uint64_t v) -> const std::array<float, 3>& {
      return position_of(v);
    };
    faces.resize(nv);
    bm.resize(nb);
    detail::resize_first_touched(face_component, faces_local);
    each_brick(0.5, 0.9, [&](std::size_t i) {
      detail::MeshTarget target;
      target.triangles = mesh.triangles.data();
      target.centre_base = range[i].centre;
      target.face_base = range[i].face;
      target.around = around(i, false);
      faces[i] = detail::brick_triangles(plans[i], target);
      std::vector<std::uint32_t>().swap(plans[i].cells);
      bm[i] = measure_brick(mesh, position, range[i], faces[i].border, origin,
                            face_component.data() + range[i].face);
    });
    plans.clear();
    plans.shrink_to_fit();
    give_back(0);  // the plans' cells, freed brick by brick
  }

  // The components of this rank's bricks, numbered after the lower ranks'.
  void number_components() {
    comp_first.assign(nv + 1, 0);
    for (std::size_t i = 0; i < nb; ++i) comp_first[i + 1] = comp_first[i] + bm[i].comps.size();
    comp_before = comm ? comm->exclusive_sum(comp_first[nb]) : 0;
    ghost_comp_first.assign(nv, 0);
    ghost_owned_comp.resize(nv);
  }

  // The up rank's first plane: its -x border and the components of its vertices.
  void receive_ghost_borders() {
    const std::string from_up = part->swap(send_first_plane([&](Packer& p, std::size_t i) {
                                             p.put_vector(faces[i].border[0]);
                                             p.put<std::uint64_t>(comp_before + comp_first[i]);
                                             p.put_vector(bm[i].owned_comp);
                                           }),
                                           "")
                                    .second;
    Unpacker u(from_up);
    for (std::size_t g = nb; g < nv; ++g) {
      faces[g].border[0] = u.get_vector<std::array<std::uint32_t, 2>>();
      ghost_comp_first[g] = u.get<std::uint64_t>();
      ghost_owned_comp[g] = u.get_vector<std::uint32_t>();
    }
  }

  // The half-edges on brick faces: each brick's +x, +y, +z lists against the neighbour's -x,
  // -y, -z lists, reversed.
  void pair_borders() {
    border_edges.assign(nb, 0);
    border_problems.assign(nb, 0);
    tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
      for (int axis = 0; axis < 3; ++axis) {
        auto key = [](const std::array<std::uint32_t, 2>& e) {
          return std::make_pair(std::min(e[0], e[1]), std::max(e[0], e[1]));
        };
        // Each list is paired once (this brick's +axis one with its neighbour's -axis one), so
        // both are sorted in place.
        std::vector<std::array<std::uint32_t, 2>>& up = faces[i].border[2 * axis + 1];
        const std::ptrdiff_t n = neighbour(i, axis == 0, axis == 1, axis == 2);
        std::vector<std::array<std::uint32_t, 2>> no_list;
        std::vector<std::array<std::uint32_t, 2>>& down =
            n >= 0 ? faces[n].border[2 * axis] : no_list;
        auto less = [&](const auto& a, const auto& b) { return key(a) < key(b); };
        std::sort(up.begin(), up.end(), less);
        std::sort(down.begin(), down.end(), less);
        std::size_t j = 0;
        for (const auto& e : up) {
          while (j < down.size() && less(down[j], e)) {
            ++border_problems[i];
            ++j;
          }
          if (j < down.size() && key(down[j]) == key(e) && down[j][0] == e[1] &&
              down[j][1] == e[0]) {
            ++border_edges[i];
            ++j;
          } else {
            ++border_problems[i];
          }
        }
        border_problems[i] += down.size() - std::min(j, down.size());
      }
      // A -x, -y, -z face with no neighbour leaves its border open.
      for (int axis = 0; axis < 3; ++axis) {
        if (neighbour(i, -(axis == 0), -(axis == 1), -(axis == 2)) >= 0) continue;
        if (axis == 0) {
          const detail::BrickCoord at = detail::brick_of_key(verts[i].key);
          if (below.count(detail::brick_key(at.x - 1, at.y, at.z))) continue;
        }
        border_problems[i] += faces[i].border[2 * axis].size();
      }
    });
    tbb::parallel_for(std::size_t{0}, nv, [&](std::size_t i) { faces[i] = detail::BrickFaces(); });
    faces.clear();
    faces.shrink_to_fit();
    give_back(0);  // the many small border lists
  }

  // The links between local components (whole-mesh numbers): through the vertices they share.
  // The owner of a shared vertex is the brick whose edge vertices hold it (centre vertices are
  // never shared); the bricks are in the order of their edge vertices. One process joins the
  // components at once (in `uf`); the ranks keep their links for rank 0. Also the bricks'
  // measures, summed over the ranks.
  void link_components() {
    verts.clear();  // the keys and codes: nothing looks for a neighbour any more
    verts.shrink_to_fit();
    std::vector<std::uint64_t> edge_start(nv);
    for (std::size_t i = 0; i < nv; ++i) edge_start[i] = range[i].edge;
    comps.resize(comp_first[nb]);
    uf.reset(comm ? 0 : comp_first[nb]);
    // In parallel, each brick's links become pairs of whole-mesh components (the component of
    // the shared vertex in place of the vertex), each pair once (many shared vertices join the
    // same two components), and its components go to their place in `comps`.
    tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
      auto& own = bm[i].links;
      for (auto& link : own) {
        const std::uint32_t v = link[0];
        const std::size_t owner =
            std::upper_bound(edge_start.begin(), edge_start.end(), v) - edge_start.begin() - 1;
        const std::uint64_t other =
            owner < nb
                ? comp_before + comp_first[owner] + bm[owner].owned_comp[v - range[owner].edge]
                : ghost_comp_first[owner] + ghost_owned_comp[owner][v - range[owner].edge];
        link = {static_cast<std::uint32_t>(comp_before + comp_first[i] + link[1]),
                static_cast<std::uint32_t>(other)};
      }
      std::sort(own.begin(), own.end());
      own.erase(std::unique(own.begin(), own.end()), own.end());
      std::copy(bm[i].comps.begin(), bm[i].comps.end(), comps.begin() + comp_first[i]);
    });
    // Joined in order (one process), or kept for rank 0.
    if (comm) {
      std::size_t n = 0;
      for (std::size_t i = 0; i < nb; ++i) n += bm[i].links.size();
      links.reserve(n);
    }
    for (std::size_t i = 0; i < nb; ++i) {
      for (const auto& link : bm[i].links)
        if (comm)
          links.push_back(link);
        else
          uf.unite(link[0], link[1]);
      m.edges += bm[i].edges + border_edges[i];
      problems += bm[i].problems + border_problems[i];
      degenerate += bm[i].degenerate;
    }
    tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) { bm[i] = BrickMeasure(); });
    bm.clear();
    bm.shrink_to_fit();
    give_back(12 * (edges_local + centres_local));  // next: the normals, if made here
    if (comm) {
      m.edges = comm->sum(m.edges);
      problems = comm->sum(problems);
      degenerate = comm->sum(degenerate);
    }
    closed = problems == 0;
  }

  // The components, resolved where every rank's are known: rank 0, which sends each rank the
  // final index of its local components.
  void resolve() {
    if (!comm) {
      resolved = resolve_components(comps, uf, closed);
      final_index = std::move(resolved.final_index);
    } else {
      resolve_on_rank_0();
    }
    std::vector<BrickMeasure::Comp>().swap(comps);
    std::vector<std::array<std::uint32_t, 2>>().swap(links);
    give_back(12 * (edges_local + centres_local));  // next: the normals, if made here
  }

  // Every rank's local components and links go to rank 0, which joins and resolves them and
  // sends each rank back the final indices of its own.
  void resolve_on_rank_0() {
    Packer mine;
    mine.put_vector(comps);
    mine.put_vector(links);
    std::vector<std::string> to(comm->size());
    to[0] = std::move(mine.data);
    const std::vector<std::string> from = comm->exchange(to);
    std::vector<std::string> back(comm->size());
    if (comm->rank() == 0) {
      std::vector<BrickMeasure::Comp> all;
      std::vector<std::array<std::uint32_t, 2>> all_links;
      std::vector<std::size_t> count(comm->size());
      for (int r = 0; r < comm->size(); ++r) {
        Unpacker u(from[r]);
        const auto c = u.get_vector<BrickMeasure::Comp>();
        const auto l = u.get_vector<std::array<std::uint32_t, 2>>();
        count[r] = c.size();
        all.insert(all.end(), c.begin(), c.end());
        all_links.insert(all_links.end(), l.begin(), l.end());
      }
      detail::UnionFind all_uf(all.size());
      for (const auto& l : all_links) all_uf.unite(l[0], l[1]);
      resolved = resolve_components(all, all_uf, closed);
      for (int r = 0, at = 0; r < comm->size(); at += static_cast<int>(count[r]), ++r) {
        Packer p;
        p.put_vector(std::vector<std::uint32_t>(resolved.final_index.begin() + at,
                                                resolved.final_index.begin() + at + count[r]));
        back[r] = std::move(p.data);
      }
    }
    final_index = Unpacker(comm->exchange(back)[0]).get_vector<std::uint32_t>();
  }

  // Each face's component: its brick's local component, resolved.
  void resolve_face_components() {
    tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
      for (std::size_t f = range[i].face; f < range[i].face + range[i].faces; ++f)
        face_component[f] = final_index[comp_first[i] + face_component[f]];
    });
  }

  // The mesh's measures from the counts and the resolved components.
  void complete_measure() {
    m.vertices = edges_total + centres_total;
    m.faces = faces_total;
    m.degenerate_faces = degenerate;
    m.boundary_edges = problems;
    m.closed = m.manifold = m.oriented = closed;
    m.volume = resolved.volume;
    m.area = resolved.area;
    m.bbox_min = resolved.lo;
    m.bbox_max = resolved.hi;
    m.components = std::move(resolved.measures);
    m.euler = static_cast<long long>(m.vertices) - static_cast<long long>(m.edges) +
              static_cast<long long>(m.faces);
  }

  // The normals of a distributed run. The sums of this rank's faces at the up rank's vertices
  // go to the up rank, which adds its own faces to them: the order of one process (the lower
  // rank's faces come first).
  void normals_across_ranks() {
    auto position = [this](std::uint64_t v) -> const std::array<float, 3>& {
      return position_of(v);
    };
    std::vector<std::array<float, 3>> ghost_sums(part->ghost_positions.size(), {0, 0, 0});
    detail::add_area_normals(mesh.triangles, position, [&](std::uint64_t v) {
      return part->local(v) == UINT64_MAX ? &ghost_sums[part->ghost(v)] : nullptr;
    });
    Packer to_up;
    to_up.put_vector(ghost_sums);
    const std::string from_down = part->swap("", std::move(to_up.data)).first;
    mesh.normals.assign(mesh.positions.size(), {0, 0, 0});
    if (!from_down.empty()) {
      const auto sums = Unpacker(from_down).get_vector<std::array<float, 3>>();
      std::size_t at = 0;
      for (const detail::VertexRun& run : part->shared)
        for (std::uint64_t k = 0; k < run.count && at < sums.size(); ++k)
          mesh.normals[run.first + k] = sums[at++];
    }
    detail::add_area_normals(mesh.triangles, position, [&](std::uint64_t v) {
      const std::uint64_t l = part->local(v);
      return l == UINT64_MAX ? nullptr : &mesh.normals[l];
    });
    for (auto& n : mesh.normals) detail::normalize_sum(n);
  }

  // What the extraction tells its caller besides the mesh.
  void fill_stats() {
    stats->evaluations = evaluations;
    stats->unembedded_cells = comm ? comm->sum(unmended) : unmended;
    stats->measure_valid = closed && degenerate == 0;
    stats->measure = std::move(m);
    stats->face_component = std::move(face_component);
    stats->component_bbox = std::move(resolved.boxes);
  }
};

TriMesh BrickMesher::run() {
  if (release) {
    // The bricks go from here on, and no brick is made: their slabs go to the system as they
    // empty (brick_pool.h), for the mesh's arrays to take.
    detail::pool_drain();
    drop_empty_bricks();
  }
  nb = impl.bricks.size();
  edge_vertices();  // pass one
  if (part) exchange_first_plane();
  index_bricks();
  plan_cells();  // pass two
  number_vertices();
  // The bricks' memory, freed; next: the mesh's vertices and faces.
  if (release) give_back(12 * (edges_local + centres_local + faces_local));
  place_positions();
  if (part) number_part();
  write_triangles();  // pass three
  number_components();
  if (part) receive_ghost_borders();
  pair_borders();
  link_components();
  resolve();
  report(0.95);
  resolve_face_components();
  complete_measure();
  if (part)
    normals_across_ranks();
  else if (opts.normals || opts.color != ColorMode::kNone)
    compute_normals(mesh);
  if (opts.color != ColorMode::kNone)
    evaluations += detail::colorize(mesh, *impl.solid, impl.geometry.voxel, opts.color);
  if (stats) fill_stats();
  report(1.0);
  return std::move(mesh);
}

// The mesh of the grid's bricks (see BrickMesher).
// `budget`, when given, receives the extraction's memory budget.
TriMesh extract_bricks(SampledGrid::Impl& impl, bool release, const ExtractOptions& opts,
                       ExtractStats* stats, detail::MeshPart* part, std::size_t* budget = nullptr) {
  BrickMesher mesher(impl, release, opts, stats, part);
  TriMesh mesh = mesher.run();
  if (budget) *budget = mesher.budget;
  return mesh;
}

}  // namespace

TriMesh extract(const SampledGrid& grid, const ExtractOptions& opts, ExtractStats* stats) {
  return extract_bricks(const_cast<SampledGrid::Impl&>(grid.impl()), false, opts, stats, nullptr);
}

TriMesh extract(SampledGrid&& grid, const ExtractOptions& opts, ExtractStats* stats) {
  std::size_t budget = 0;
  TriMesh mesh = extract_bricks(grid.impl(), true, opts, stats, nullptr, &budget);
  give_back_memory(opts, budget, 0);  // the many small blocks of the bricks' passes, free now
  return mesh;
}

namespace detail {

std::size_t MeshPart::ghost(std::uint64_t v) const {
  auto it = std::upper_bound(ghosts.begin(), ghosts.end(), v,
                             [](std::uint64_t x, const VertexRun& r) { return x < r.first; });
  if (it != ghosts.begin()) {
    const VertexRun& r = *(it - 1);
    if (v - r.first < r.count) return r.at + (v - r.first);
  }
  throw std::logic_error("vertex " + std::to_string(v) + " is neither owned nor a ghost");
}

std::pair<std::string, std::string> MeshPart::swap(std::string to_down, std::string to_up) const {
  std::vector<std::string> to(comm->size());
  if (down >= 0) to[down] = std::move(to_down);
  if (up >= 0) to[up] = std::move(to_up);
  std::vector<std::string> from = comm->exchange(to);
  return {down >= 0 ? std::move(from[down]) : std::string(),
          up >= 0 ? std::move(from[up]) : std::string()};
}

TriMesh extract_part(SampledGrid&& grid, const ExtractOptions& opts, ExtractStats& stats,
                     MeshPart& part) {
  SampledGrid::Impl& impl = grid.impl();
  if (!impl.distribution || !impl.distribution->comm)
    throw std::logic_error("extract_part: the grid was not sampled with a distribution");
  find_neighbour_ranks(*impl.distribution, part);
  std::size_t budget = 0;
  TriMesh mesh = extract_bricks(impl, true, opts, &stats, &part, &budget);
  give_back_memory(opts, budget, 0);
  return mesh;
}

}  // namespace detail

}  // namespace qjulia
