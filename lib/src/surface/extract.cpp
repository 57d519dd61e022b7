#include "qjulia/surface/extract.h"

#include <malloc.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <stdexcept>
#include <unordered_map>

#include "grid/grid_impl.h"
#include "qjulia/base/error.h"
#include "surface/brick_mesh.h"
#include "surface/color.h"

namespace qjulia {
namespace {

using detail::BrickMesh;
using detail::kBrick;

// Meshes every brick (in parallel, any order), then joins them in key order: vertices numbered
// brick after brick, corners on a neighbour's edge resolved through the neighbour's sorted edge
// codes. With `release`, each brick's values go as soon as it is meshed and each brick's mesh
// as soon as it is joined, so memory holds about one copy of the mesh.
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
          report(0.8 * k / nb);
        }
      });
  if (release) {
    impl.bricks.clear();
    impl.bricks.shrink_to_fit();
  }
  // Vertex numbers: brick after brick.
  std::vector<std::size_t> first(nb + 1, 0);
  std::size_t faces = 0;
  std::uint64_t evaluations = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    first[i + 1] = first[i] + meshes[i].positions.size();
    faces += meshes[i].triangles.size();
    evaluations += meshes[i].evaluations;
  }
  if (first[nb] > 0xffffffffu)
    throw TooLarge("the mesh has " + std::to_string(first[nb]) +
                   " vertices; 32-bit indices hold at most 4294967295");
  std::unordered_map<std::uint64_t, std::size_t> index;
  index.reserve(nb * 2);
  for (std::size_t i = 0; i < nb; ++i) index.emplace(meshes[i].key, i);
  // Resolve the corners on neighbours' edges (in parallel, in place).
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t i) {
    BrickMesh& m = meshes[i];
    const detail::BrickCoord at = detail::brick_of_key(m.key);
    for (auto& tri : m.triangles)
      for (std::uint32_t& v : tri) {
        if (!(v & detail::kForeign)) {
          v = static_cast<std::uint32_t>(first[i] + v);
          continue;
        }
        const int dir = (v >> 12) & 7, code = v & 0xfff;
        const auto it = index.find(
            detail::brick_key(at.x + (dir & 1), at.y + ((dir >> 1) & 1), at.z + (dir >> 2)));
        if (it == index.end()) throw std::logic_error("extract: a neighbour brick is missing");
        const BrickMesh& n = meshes[it->second];
        const auto c = std::lower_bound(n.codes.begin(), n.codes.end(), code);
        if (c == n.codes.end() || *c != code)
          throw std::logic_error("extract: a neighbour brick lacks a shared vertex");
        v = static_cast<std::uint32_t>(first[it->second] + (c - n.codes.begin()));
      }
  });
  report(0.85);
  // Join, freeing each brick's part as it is copied.
  TriMesh mesh;
  mesh.positions.reserve(first[nb]);
  mesh.triangles.reserve(faces);
  std::size_t freed = 0;
  for (std::size_t i = 0; i < nb; ++i) {
    BrickMesh& m = meshes[i];
    mesh.positions.insert(mesh.positions.end(), m.positions.begin(), m.positions.end());
    mesh.triangles.insert(mesh.triangles.end(), m.triangles.begin(), m.triangles.end());
    freed += m.positions.size() * 12 + m.triangles.size() * 12;
    std::vector<std::array<float, 3>>().swap(m.positions);
    std::vector<std::array<std::uint32_t, 3>>().swap(m.triangles);
    if (release && freed > (std::size_t{64} << 20)) {
      malloc_trim(0);  // return the freed pages now: the copy grows as the parts shrink
      freed = 0;
    }
  }
  meshes.clear();
  meshes.shrink_to_fit();
  if (release) malloc_trim(0);
  compute_normals(mesh);
  if (opts.color != ColorMode::kNone)
    evaluations += detail::colorize(mesh, *impl.solid, impl.geometry.voxel, opts.color);
  if (stats) stats->evaluations = evaluations;
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
