#include "qjulia/grid/sample.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/Composite.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <stdexcept>

#include "grid/grid_impl.h"
#include "qjulia/field/classify.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

using detail::pack;
using detail::unpack;
using openvdb::Coord;

// A cell is refined when its sampled values do not change sign but their smallest magnitude is
// below kRoughness times their spread: the field may cross zero between the samples.
constexpr float kRoughness = 1.0f;

// Adds point (i, j, k) unless it lies below the grid (such points are outside the box and never
// evaluated).
void push_point(std::vector<std::uint64_t>& keys, int i, int j, int k) {
  if (i >= 0 && j >= 0 && k >= 0) keys.push_back(pack(i, j, k));
}

// The vectors one after the other.
std::vector<std::uint64_t> concatenate(std::vector<std::vector<std::uint64_t>>& parts) {
  std::size_t total = 0;
  for (const auto& part : parts) total += part.size();
  std::vector<std::uint64_t> out;
  out.reserve(total);
  for (auto& part : parts) {
    out.insert(out.end(), part.begin(), part.end());
    std::vector<std::uint64_t>().swap(part);
  }
  return out;
}

// Adds cell (i, j, k) unless it lies wholly below the grid.
void push_cell(std::vector<std::uint64_t>& cells, int i, int j, int k) {
  if (i >= -1 && j >= -1 && k >= -1) cells.push_back(pack(i, j, k));
}

// Samples the solid on the grid: evaluates points, keeps them in the VDB grid.
class Sampler {
 public:
  Sampler(const Params& params, const SampleOptions& opts)
      : solid_(params), geo_(grid_geometry(params)), opts_(opts) {
    grid_ = openvdb::FloatGrid::create(background());
  }

  float background() const {
    return static_cast<float>(solid_.classifier().params().iterations + 1);
  }

  std::array<double, 3> position(int i, int j, int k) const {
    return {geo_.origin[0] + i * geo_.voxel, geo_.origin[1] + j * geo_.voxel,
            geo_.origin[2] + k * geo_.voxel};
  }

  bool is_virtual(int i, int j, int k, float* value) const {
    return detail::virtual_value(geo_, solid_, i, j, k, value);
  }

  // Evaluates every non-virtual point of `keys` not yet in the grid; keys are sorted/unique.
  void evaluate(std::vector<std::uint64_t>& keys) {
    // Mark what needs evaluating (in parallel: the grid is only read here).
    std::vector<float> values(keys.size());
    std::vector<char> todo(keys.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keys.size(), 1024),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        auto acc = grid_->getConstAccessor();
                        for (std::size_t n = r.begin(); n != r.end(); ++n) {
                          const Coord c = unpack(keys[n]);
                          float v;
                          if (is_virtual(c.x(), c.y(), c.z(), &v) || acc.isValueOn(c)) continue;
                          todo[n] = 1;
                          const auto p = position(c.x(), c.y(), c.z());
                          values[n] = solid_.field(p[0], p[1], p[2]);
                        }
                      });
    auto acc = grid_->getAccessor();
    std::size_t count = 0;
    for (std::size_t n = 0; n < keys.size(); ++n)
      if (todo[n]) {
        acc.setValueOn(unpack(keys[n]), values[n]);
        ++count;
      }
    evaluations_ += count;
  }

  // The value at a point that was evaluated (or is virtual).
  template <typename Accessor>
  float value(const Accessor& acc, int i, int j, int k) const {
    return detail::point_value(geo_, solid_, acc, i, j, k);
  }

  void report(double fraction) {
    if (opts_.progress && !opts_.progress(std::min(1.0, fraction))) throw Cancelled();
  }

  // Cells at stride s covering points -1 .. points: cell c spans points [c*s, (c+1)*s].
  std::array<int, 3> cell_hi(int s) const {
    std::array<int, 3> hi;
    for (int a = 0; a < 3; ++a) hi[a] = (geo_.points[a] - 1) / s;  // floor, points >= 1
    return hi;
  }

  void run_sparse() {
    int s = opts_.coarse_block;
    const auto hi = cell_hi(s);
    // 1. The coarse lattice and the centre of every coarse cell.
    std::vector<std::uint64_t> keys;
    for (int i = -1; i <= hi[0] + 1; ++i)
      for (int j = -1; j <= hi[1] + 1; ++j)
        for (int k = -1; k <= hi[2] + 1; ++k) {
          push_point(keys, i * s, j * s, k * s);
          if (i <= hi[0] && j <= hi[1] && k <= hi[2])
            push_point(keys, i * s + s / 2, j * s + s / 2, k * s + s / 2);
        }
    std::sort(keys.begin(), keys.end());
    evaluate(keys);
    report(0.1);
    std::vector<std::uint64_t> cells;
    for (int i = -1; i <= hi[0]; ++i)
      for (int j = -1; j <= hi[1]; ++j)
        for (int k = -1; k <= hi[2]; ++k) cells.push_back(pack(i, j, k));
    cells = flag(cells, s, true);
    cells = dilate(cells);
    top_cells_ = cells;
    // 2. Refine flagged cells level by level down to single voxels.
    while (s > 1) {
      const int half = s / 2;
      // Per chunk of cells, in parallel; concatenated in chunk order (deterministic).
      constexpr std::size_t kChunk = 4096;
      std::vector<std::vector<std::uint64_t>> chunk_keys((cells.size() + kChunk - 1) / kChunk),
          chunk_children(chunk_keys.size());
      tbb::parallel_for(std::size_t{0}, chunk_keys.size(), [&](std::size_t chunk) {
        auto& out_keys = chunk_keys[chunk];
        auto& out_children = chunk_children[chunk];
        for (std::size_t n = chunk * kChunk; n < std::min(cells.size(), (chunk + 1) * kChunk);
             ++n) {
          const Coord c = unpack(cells[n]);
          // The 27 points of the cell at the finer stride; a point on the far side of an axis
          // is left to the flagged neighbour that has it as its near corner (fewer duplicates
          // to sort away).
          bool neighbour[8];
          for (int q = 1; q < 8; ++q)
            neighbour[q] =
                std::binary_search(cells.begin(), cells.end(),
                                   pack(c.x() + (q & 1), c.y() + ((q >> 1) & 1), c.z() + (q >> 2)));
          for (int di = 0; di <= 2; ++di)
            for (int dj = 0; dj <= 2; ++dj)
              for (int dk = 0; dk <= 2; ++dk) {
                const int q = (di == 2) | ((dj == 2) << 1) | ((dk == 2) << 2);
                if (q && neighbour[q]) continue;
                push_point(out_keys, c.x() * s + di * half, c.y() * s + dj * half,
                           c.z() * s + dk * half);
              }
          for (int d = 0; d < 8; ++d)
            push_cell(out_children, 2 * c.x() + (d & 1), 2 * c.y() + ((d >> 1) & 1),
                      2 * c.z() + (d >> 2));
        }
      });
      keys = concatenate(chunk_keys);
      std::vector<std::uint64_t> children = concatenate(chunk_children);
      tbb::parallel_sort(keys.begin(), keys.end());
      keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
      evaluate(keys);
      tbb::parallel_sort(children.begin(), children.end());
      children.erase(std::unique(children.begin(), children.end()), children.end());
      s = half;
      cells = flag(children, s, false);
      if (s >= 4) cells = dilate(cells);
      report(0.1 + 0.8 * (1.0 - std::log2(s) / std::log2(opts_.coarse_block)));
    }
    // 3. Close the surface: a crossing voxel whose face has a sign change continues into the
    // neighbour across that face, which must be a crossing voxel too.
    close_surface(cells);
  }

  // Cells (stride s) among `cells` that the surface may cross: corners (and centre at the
  // coarse level) differ in sign, or a corner is near zero.
  std::vector<std::uint64_t> flag(const std::vector<std::uint64_t>& cells, int s, bool coarse) {
    std::vector<char> keep(cells.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 1024),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        auto acc = grid_->getConstAccessor();
                        for (std::size_t n = r.begin(); n != r.end(); ++n) {
                          const Coord c = unpack(cells[n]);
                          int inside = 0, total = 0;
                          // Range of the sampled (not virtual) values.
                          float lo = std::numeric_limits<float>::max(), hi = -lo;
                          auto visit = [&](int i, int j, int k) {
                            float v;
                            const bool virt = is_virtual(i, j, k, &v);
                            if (!virt) {
                              v = acc.getValue(Coord(i, j, k));
                              lo = std::min(lo, v);
                              hi = std::max(hi, v);
                            }
                            inside += v <= 0;
                            ++total;
                          };
                          for (int d = 0; d < 8; ++d)
                            visit((c.x() + (d & 1)) * s, (c.y() + ((d >> 1) & 1)) * s,
                                  (c.z() + (d >> 2)) * s);
                          if (coarse)
                            visit(c.x() * s + s / 2, c.y() * s + s / 2, c.z() * s + s / 2);
                          bool rough = false;
                          if (s > 1 && lo <= hi) {
                            // The field may reach zero inside the cell when it varies across the
                            // cell by more than its smallest magnitude (a thin feature between
                            // samples), or is close to zero anyway.
                            const float m = lo > 0 ? lo : -hi;
                            rough = m < kRoughness * (hi - lo);
                          }
                          keep[n] = (inside != 0 && inside != total) || rough;
                        }
                      });
    std::vector<std::uint64_t> out;
    for (std::size_t n = 0; n < cells.size(); ++n)
      if (keep[n]) out.push_back(cells[n]);
    return out;
  }

  // The cells and their 26 neighbours.
  static std::vector<std::uint64_t> dilate(const std::vector<std::uint64_t>& cells) {
    std::vector<std::uint64_t> out;
    out.reserve(cells.size() * 8);
    for (std::uint64_t key : cells) {
      const Coord c = unpack(key);
      for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
          for (int dk = -1; dk <= 1; ++dk) {
            if (c.x() + di < -1 || c.y() + dj < -1 || c.z() + dk < -1) continue;
            out.push_back(pack(c.x() + di, c.y() + dj, c.z() + dk));
          }
    }
    tbb::parallel_sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  void close_surface(std::vector<std::uint64_t> frontier) {
    std::vector<std::uint64_t> crossing;
    std::vector<std::uint64_t> seen = frontier;  // sorted
    bool corners_known = true;                   // the first frontier is the refined voxels
    while (!frontier.empty()) {
      // Evaluate the corners of new frontier cells.
      if (!corners_known) {
        std::vector<std::uint64_t> keys;
        for (std::uint64_t key : frontier) {
          const Coord c = unpack(key);
          for (int d = 0; d < 8; ++d)
            push_point(keys, c.x() + (d & 1), c.y() + ((d >> 1) & 1), c.z() + (d >> 2));
        }
        tbb::parallel_sort(keys.begin(), keys.end());
        keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
        evaluate(keys);
      }
      corners_known = false;
      // Per chunk of frontier cells, in parallel; concatenated in chunk order.
      constexpr std::size_t kChunk = 4096;
      const std::size_t chunks = (frontier.size() + kChunk - 1) / kChunk;
      std::vector<std::vector<std::uint64_t>> chunk_next(chunks), chunk_crossing(chunks);
      tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
        auto acc = grid_->getConstAccessor();
        for (std::size_t n = chunk * kChunk; n < std::min(frontier.size(), (chunk + 1) * kChunk);
             ++n) {
          const Coord c = unpack(frontier[n]);
          float v[8];
          int inside = 0;
          for (int d = 0; d < 8; ++d) {
            v[d] = value(acc, c.x() + (d & 1), c.y() + ((d >> 1) & 1), c.z() + (d >> 2));
            inside += v[d] <= 0;
          }
          if (inside == 0 || inside == 8) continue;
          chunk_crossing[chunk].push_back(frontier[n]);
          // Faces: axis a, side t (corner bit a equals t).
          for (int a = 0; a < 3; ++a)
            for (int t = 0; t < 2; ++t) {
              int face_inside = 0;
              for (int d = 0; d < 8; ++d)
                if (((d >> a) & 1) == t) face_inside += v[d] <= 0;
              if (face_inside == 0 || face_inside == 4) continue;
              Coord nb = c;
              nb[a] += t ? 1 : -1;
              if (nb[a] < -1 || nb[a] >= geo_.points[a]) continue;
              const std::uint64_t nk = pack(nb.x(), nb.y(), nb.z());
              if (!std::binary_search(seen.begin(), seen.end(), nk))
                chunk_next[chunk].push_back(nk);
            }
        }
      });
      std::vector<std::uint64_t> next = concatenate(chunk_next);
      const auto found = concatenate(chunk_crossing);
      crossing.insert(crossing.end(), found.begin(), found.end());
      tbb::parallel_sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      if (!next.empty()) {
        std::vector<std::uint64_t> merged;
        merged.reserve(seen.size() + next.size());
        std::merge(seen.begin(), seen.end(), next.begin(), next.end(), std::back_inserter(merged));
        seen.swap(merged);
        closure_cells_ += next.size();
      }
      frontier.swap(next);
    }
    tbb::parallel_sort(crossing.begin(), crossing.end());
    crossing_ = std::move(crossing);
  }

  void run_dense() {
    const auto& pts = geo_.points;
    const std::size_t plane = static_cast<std::size_t>(pts[1]) * pts[2];
    std::vector<float> dense(static_cast<std::size_t>(pts[0]) * plane);
    std::atomic<int> rows_done{0};
    tbb::parallel_for(0, pts[0], [&](int i) {
      for (int j = 0; j < pts[1]; ++j)
        for (int k = 0; k < pts[2]; ++k) {
          float v;
          if (!is_virtual(i, j, k, &v)) {
            const auto p = position(i, j, k);
            v = solid_.field(p[0], p[1], p[2]);
          }
          dense[i * plane + static_cast<std::size_t>(j) * pts[2] + k] = v;
        }
      ++rows_done;
    });
    report(0.8);
    std::size_t count = 0;
    float v;
    {
      auto acc = grid_->getAccessor();
      for (int i = 0; i < pts[0]; ++i)
        for (int j = 0; j < pts[1]; ++j)
          for (int k = 0; k < pts[2]; ++k)
            if (!is_virtual(i, j, k, &v)) {
              acc.setValueOn(Coord(i, j, k),
                             dense[i * plane + static_cast<std::size_t>(j) * pts[2] + k]);
              ++count;
            }
    }
    evaluations_ += count;
    // Every cell with a sign change, walls included.
    std::vector<std::vector<std::uint64_t>> per_slab(pts[0] + 1);
    tbb::parallel_for(-1, pts[0], [&](int i) {
      auto acc = grid_->getConstAccessor();
      auto& out = per_slab[i + 1];
      for (int j = -1; j < pts[1]; ++j)
        for (int k = -1; k < pts[2]; ++k) {
          int inside = 0;
          for (int d = 0; d < 8; ++d)
            inside += value(acc, i + (d & 1), j + ((d >> 1) & 1), k + (d >> 2)) <= 0;
          if (inside != 0 && inside != 8) out.push_back(pack(i, j, k));
        }
    });
    for (auto& slab : per_slab) crossing_.insert(crossing_.end(), slab.begin(), slab.end());
  }

  // Inactive tiles of -background in coarse blocks whose samples were all inside.
  void add_interior_tiles() {
    if (opts_.dense) return;
    const int s = opts_.coarse_block;
    const auto hi = cell_hi(s);
    auto tiles = openvdb::FloatGrid::create(background());
    auto acc = grid_->getConstAccessor();
    std::vector<std::uint64_t> all;
    for (int i = 0; i <= hi[0]; ++i)
      for (int j = 0; j <= hi[1]; ++j)
        for (int k = 0; k <= hi[2]; ++k) {
          if (std::binary_search(top_cells_.begin(), top_cells_.end(), pack(i, j, k))) continue;
          bool inside = true;
          for (int d = 0; d < 8 && inside; ++d)
            inside =
                value(acc, (i + (d & 1)) * s, (j + ((d >> 1) & 1)) * s, (k + (d >> 2)) * s) <= 0;
          if (inside)
            tiles->tree().fill(
                openvdb::CoordBBox(Coord(i * s, j * s, k * s),
                                   Coord(i * s + s - 1, j * s + s - 1, k * s + s - 1)),
                -background(), false);
        }
    openvdb::tools::compReplace(*tiles, *grid_);
    grid_ = tiles;
  }

  SampledGrid finish(const Params& params) {
    add_interior_tiles();
    SampledGrid out;
    auto& impl = out.impl();
    impl.params = params;
    impl.geometry = geo_;
    impl.grid = grid_;
    impl.grid->setName("F");
    impl.grid->setTransform(openvdb::math::Transform::createLinearTransform(geo_.voxel));
    impl.grid->transform().postTranslate(
        openvdb::Vec3d(geo_.origin[0], geo_.origin[1], geo_.origin[2]));
    impl.crossing = std::move(crossing_);
    impl.evaluations = evaluations_;
    impl.dense_evaluations =
        static_cast<std::uint64_t>(geo_.points[0]) * geo_.points[1] * geo_.points[2];
    report(1.0);
    return out;
  }

  Solid solid_;
  GridGeometry geo_;
  SampleOptions opts_;
  openvdb::FloatGrid::Ptr grid_;
  std::vector<std::uint64_t> crossing_;
  std::vector<std::uint64_t> top_cells_;
  std::uint64_t evaluations_ = 0;
  std::uint64_t closure_cells_ = 0;
};

std::once_flag g_openvdb_init;

}  // namespace

GridGeometry grid_geometry(const Params& params) {
  GridGeometry g;
  double longest = 0;
  for (int a = 0; a < 3; ++a)
    longest = std::max(longest, params.bounds.max[a] - params.bounds.min[a]);
  g.voxel = longest / params.resolution;
  for (int a = 0; a < 3; ++a) {
    // Points sit at the centres of the voxels, so no point lies on a wall of the box and caps
    // never pass through grid points.
    g.origin[a] = params.bounds.min[a] + 0.5 * g.voxel;
    const double cells = (params.bounds.max[a] - params.bounds.min[a]) / g.voxel;
    // Points strictly inside the box: (i + 1/2) * voxel < extent.
    g.points[a] = std::max(1, static_cast<int>(std::ceil(cells - 0.5 - 1e-9)));
  }
  return g;
}

SampledGrid::SampledGrid() : impl_(std::make_unique<Impl>()) {}
SampledGrid::~SampledGrid() = default;
SampledGrid::SampledGrid(SampledGrid&&) noexcept = default;
SampledGrid& SampledGrid::operator=(SampledGrid&&) noexcept = default;

double SampledGrid::voxel_size() const { return impl_->geometry.voxel; }
std::array<double, 3> SampledGrid::origin() const { return impl_->geometry.origin; }
std::array<int, 3> SampledGrid::points() const { return impl_->geometry.points; }
std::uint64_t SampledGrid::evaluations() const { return impl_->evaluations; }
std::uint64_t SampledGrid::dense_evaluations() const { return impl_->dense_evaluations; }
std::uint64_t SampledGrid::crossing_cells() const { return impl_->crossing.size(); }
std::uint64_t SampledGrid::active_voxels() const {
  return impl_->grid ? impl_->grid->activeVoxelCount() : 0;
}

void SampledGrid::write_vdb(const std::string& path, const std::string& params_json) const {
  std::call_once(g_openvdb_init, [] { openvdb::initialize(); });
  auto grid = impl_->grid->deepCopy();
  grid->insertMeta("qjulia_parameters", openvdb::StringMetadata(params_json));
  grid->insertMeta("qjulia_field",
                   openvdb::StringMetadata(
                       "F: continuous escape/cut-off field of the qjulia design; F <= 0 in the "
                       "solid, > 0 outside; zero level = classification boundary; units: "
                       "iterations (not a distance). Inactive values: -background inside "
                       "uniform blocks, background outside."));
  grid->insertMeta("qjulia_method", openvdb::StringMetadata(to_string(impl_->params.method)));
  const std::string tmp = path + ".tmp";
  try {
    openvdb::io::File file(tmp);
    openvdb::GridPtrVec grids{grid};
    file.write(grids);
    file.close();
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot write the grid: " + e.what());
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot write the grid");
  }
}

SampledGrid sample(const Params& params, const SampleOptions& opts) {
  validate(params);
  if (opts.coarse_block < 2 || opts.coarse_block > 64 ||
      (opts.coarse_block & (opts.coarse_block - 1)) != 0)
    throw InvalidInput("sample: coarse_block must be a power of two in 2..64");
  std::call_once(g_openvdb_init, [] { openvdb::initialize(); });
  Sampler sampler(params, opts);
  if (opts.dense)
    sampler.run_dense();
  else
    sampler.run_sparse();
  return sampler.finish(params);
}

}  // namespace qjulia
