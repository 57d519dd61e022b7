#include "pipeline/dust.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace qjulia::detail {

namespace {

constexpr std::size_t kBlock = std::size_t{1} << 16;  // items a task compacts

// Keeps the items i of [0, n) that keep(i) keeps, in order, at the front: move(from, to) moves
// item `from` to `to` (never behind it), slide(from, to, count) the run of `count` items at `from`
// to `to` (to <= from; the two may overlap). Each block of kBlock items is compacted within itself
// in parallel, then the blocks' runs slide to their places in order (serial: they may overlap;
// a run is one copy of each array, not an item at a time).
// Returns where each block's kept items start in the result, and the kept count last.
template <class Keep, class Move, class Slide>
std::vector<std::size_t> compact(std::size_t n, const Keep& keep, const Move& move,
                                 const Slide& slide) {
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<std::size_t> start(blocks + 1, 0);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t b) {
    const std::size_t first = b * kBlock, last = std::min(n, first + kBlock);
    std::size_t to = first;
    for (std::size_t i = first; i < last; ++i)
      if (keep(i)) move(i, to++);
    start[b + 1] = to - first;
  });
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t count = start[b + 1];
    start[b + 1] = start[b] + count;
    if (start[b] != b * kBlock && count > 0) slide(b * kBlock, start[b], count);
  }
  return start;
}

// Moves the run of `count` items of v at `from` to `to` (to <= from).
template <class T>
void slide(std::vector<T>& v, std::size_t from, std::size_t to, std::size_t count) {
  std::copy(v.begin() + from, v.begin() + from + count, v.begin() + to);
}

// Which components are dust; the largest of them in the report.
std::vector<char> dust_of(const MeshMeasure& m, double min_volume, CleanReport& rep) {
  std::vector<char> drop(m.components.size(), 0);
  for (std::size_t c = 0; c < m.components.size(); ++c) {
    const double volume = std::abs(m.components[c].volume);
    if (volume < min_volume) {
      drop[c] = 1;
      rep.largest_removed_volume = std::max(rep.largest_removed_volume, volume);
    }
  }
  return drop;
}

// The measures without the dropped components, from the component measures (no pass over the
// mesh), with the mesh's new vertex and face counts.
void update_measures(ExtractStats& stats, const std::vector<char>& drop, std::size_t vertices,
                     std::size_t faces, CleanReport& rep) {
  MeshMeasure& m = stats.measure;
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, stats.face_component.size(), kBlock),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f)
                        stats.face_component[f] = new_index[stats.face_component[f]];
                    });
  m.components = std::move(kept);
  stats.component_bbox = std::move(kept_box);
  m.vertices = vertices;
  m.faces = faces;
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
}

// Moves the vertices `keep(v)` keeps (with their normals and colours) to the front, in order,
// and drops the rest; returns where each block of kBlock vertices' kept ones start (compact()).
template <class Keep>
std::vector<std::size_t> compact_vertices(TriMesh& mesh, const Keep& keep) {
  const std::vector<std::size_t> start = compact(
      mesh.positions.size(), keep,
      [&](std::size_t from, std::size_t to) {
        mesh.positions[to] = mesh.positions[from];
        if (!mesh.normals.empty()) mesh.normals[to] = mesh.normals[from];
        if (!mesh.colors.empty()) mesh.colors[to] = mesh.colors[from];
      },
      [&](std::size_t from, std::size_t to, std::size_t count) {
        slide(mesh.positions, from, to, count);
        if (!mesh.normals.empty()) slide(mesh.normals, from, to, count);
        if (!mesh.colors.empty()) slide(mesh.colors, from, to, count);
      });
  mesh.positions.resize(start.back());
  if (!mesh.normals.empty()) mesh.normals.resize(start.back());
  if (!mesh.colors.empty()) mesh.colors.resize(start.back());
  return start;
}

}  // namespace

CleanReport remove_dust(TriMesh& mesh, ExtractStats& stats, double min_volume) {
  MeshMeasure& m = stats.measure;
  CleanReport rep;
  rep.components_before = m.components.size();
  rep.min_component_volume = min_volume;
  const std::vector<char> drop = dust_of(m, min_volume, rep);
  if (std::find(drop.begin(), drop.end(), 1) == drop.end()) {
    rep.components_after = rep.components_before;
    return rep;
  }
  // Faces of kept components, in order, and the vertices they use (a flag many faces may set
  // at once).
  const std::size_t nv = mesh.positions.size();
  const std::unique_ptr<std::atomic<std::uint8_t>[]> used(new std::atomic<std::uint8_t>[nv]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kBlock),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end(); ++v)
                        used[v].store(0, std::memory_order_relaxed);
                    });
  auto& comp = stats.face_component;
  auto kept = [&](std::size_t f) {
    if (drop[comp[f]]) return false;
    for (std::uint32_t v : mesh.triangles[f]) used[v].store(1, std::memory_order_relaxed);
    return true;
  };
  auto move_face = [&](std::size_t from, std::size_t to) {
    mesh.triangles[to] = mesh.triangles[from];
    comp[to] = comp[from];
  };
  auto slide_faces = [&](std::size_t from, std::size_t to, std::size_t count) {
    slide(mesh.triangles, from, to, count);
    slide(comp, from, to, count);
  };
  const std::size_t kept_faces =
      compact(mesh.triangles.size(), kept, move_face, slide_faces).back();
  rep.removed_faces = mesh.triangles.size() - kept_faces;
  mesh.triangles.resize(kept_faces);
  comp.resize(kept_faces);
  // The used vertices (with their normals and colours), in order; then their new numbers.
  auto is_used = [&](std::size_t v) { return used[v].load(std::memory_order_relaxed) != 0; };
  const std::vector<std::size_t> start = compact_vertices(mesh, is_used);
  // Written (and faulted in) in parallel: only the used vertices' numbers are read.
  const std::unique_ptr<std::uint32_t[]> renumber(new std::uint32_t[nv]);
  tbb::parallel_for(std::size_t{0}, start.size() - 1, [&](std::size_t b) {
    auto next = static_cast<std::uint32_t>(start[b]);
    for (std::size_t v = b * kBlock; v < std::min(nv, (b + 1) * kBlock); ++v)
      if (is_used(v)) renumber[v] = next++;
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, kept_faces, kBlock),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f)
                        for (auto& v : mesh.triangles[f]) v = renumber[v];
                    });
  update_measures(stats, drop, mesh.positions.size(), mesh.triangles.size(), rep);
  return rep;
}

CleanReport remove_dust_part(TriMesh& mesh, ExtractStats& stats, double min_volume,
                             MeshPart& part) {
  Comm& comm = *part.comm;
  CleanReport rep;
  rep.min_component_volume = min_volume;
  // Rank 0 knows the components; every rank learns which go.
  std::string flags;
  if (comm.rank() == 0) {
    const std::vector<char> drop = dust_of(stats.measure, min_volume, rep);
    flags.assign(drop.begin(), drop.end());
    rep.components_before = rep.components_after = stats.measure.components.size();
  }
  comm.broadcast(flags);
  if (flags.find('\1') == std::string::npos) return rep;
  const std::vector<char> drop(flags.begin(), flags.end());
  // This rank's faces of kept components, and the vertices they use (its own and ghosts).
  const std::size_t own = mesh.positions.size();
  std::vector<char> used(own, 0), ghost_used(part.ghost_positions.size(), 0);
  std::size_t kept_faces = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (drop[stats.face_component[f]]) continue;
    for (std::uint32_t v : mesh.triangles[f]) {
      const std::uint64_t l = part.local(v);
      (l != UINT64_MAX ? used[l] : ghost_used[part.ghost(v)]) = 1;
    }
    mesh.triangles[kept_faces] = mesh.triangles[f];
    ++kept_faces;
  }
  const std::size_t removed = mesh.triangles.size() - kept_faces;
  mesh.triangles.resize(kept_faces);
  std::vector<std::uint32_t>().swap(stats.face_component);  // not needed after the dust
  // The down rank's faces use this rank's shared vertices.
  Packer to_up;
  to_up.put_vector(ghost_used);
  const std::string from_down = part.swap("", std::move(to_up.data)).first;
  if (!from_down.empty()) {
    const auto flags_down = Unpacker(from_down).get_vector<char>();
    std::size_t at = 0;
    for (const VertexRun& run : part.shared)
      for (std::uint64_t k = 0; k < run.count && at < flags_down.size(); ++k)
        used[run.first + k] |= flags_down[at++];
  }
  // The numbering of one process: kept vertices in order (edge vertices of every rank, then
  // centre vertices).
  std::uint64_t kept_edges = 0, kept_centres = 0;
  for (std::size_t l = 0; l < own; ++l) (l < part.edges ? kept_edges : kept_centres) += used[l];
  const std::uint64_t edge_first = comm.exclusive_sum(kept_edges);
  const std::uint64_t edges_total = comm.sum(kept_edges);
  const std::uint64_t centre_first = edges_total + comm.exclusive_sum(kept_centres);
  const std::uint64_t vertices_total = edges_total + comm.sum(kept_centres);
  std::vector<std::uint32_t> renumber(own, UINT32_MAX);
  for (std::uint64_t l = 0, e = edge_first, c = centre_first; l < own; ++l)
    if (used[l]) renumber[l] = static_cast<std::uint32_t>(l < part.edges ? e++ : c++);
  // The up rank's new numbers of the ghosts.
  Packer to_down;
  for (const VertexRun& run : part.shared)
    for (std::uint64_t k = 0; k < run.count; ++k) to_down.put(renumber[run.first + k]);
  const std::string from_up = part.swap(std::move(to_down.data), "").second;
  std::vector<std::uint32_t> ghost_renumber(part.ghost_positions.size(), UINT32_MAX);
  if (!from_up.empty()) {
    Unpacker u(from_up);
    for (auto& g : ghost_renumber) g = u.get<std::uint32_t>();
  }
  for (auto& t : mesh.triangles)
    for (auto& v : t) {
      const std::uint64_t l = part.local(v);
      v = l != UINT64_MAX ? renumber[l] : ghost_renumber[part.ghost(v)];
    }
  // The vertices, compacted; the runs follow (what is kept of a run stays contiguous).
  compact_vertices(mesh, [&](std::size_t l) { return used[l] != 0; });
  for (VertexRun& run : part.shared) {
    std::uint64_t first = UINT64_MAX, count = 0;
    for (std::uint64_t k = 0; k < run.count; ++k)
      if (renumber[run.first + k] != UINT32_MAX) {
        if (first == UINT64_MAX) first = renumber[run.first + k] - edge_first;
        ++count;
      }
    run = {first == UINT64_MAX ? 0 : first, count, 0};
  }
  std::vector<std::array<float, 3>> ghost_positions;
  for (VertexRun& run : part.ghosts) {
    std::uint64_t first = UINT64_MAX, count = 0;
    const std::uint64_t at = ghost_positions.size();
    for (std::uint64_t k = 0; k < run.count; ++k)
      if (ghost_renumber[run.at + k] != UINT32_MAX) {
        if (first == UINT64_MAX) first = ghost_renumber[run.at + k];
        ghost_positions.push_back(part.ghost_positions[run.at + k]);
        ++count;
      }
    run = {first == UINT64_MAX ? 0 : first, count, at};
  }
  part.ghosts.erase(std::remove_if(part.ghosts.begin(), part.ghosts.end(),
                                   [](const VertexRun& r) { return r.count == 0; }),
                    part.ghosts.end());
  part.ghost_positions = std::move(ghost_positions);
  part.edge_first = edge_first;
  part.edges = kept_edges;
  part.centre_first = centre_first;
  part.centres = kept_centres;
  part.vertices_total = vertices_total;
  part.face_first = comm.exclusive_sum(kept_faces);
  part.faces_total = comm.sum(kept_faces);
  const std::uint64_t removed_total = comm.sum(removed);
  if (comm.rank() == 0) {
    rep.removed_faces = removed_total;
    update_measures(stats, drop, vertices_total, part.faces_total, rep);
  }
  return rep;
}

}  // namespace qjulia::detail
