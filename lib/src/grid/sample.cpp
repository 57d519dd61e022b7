#include "qjulia/grid/sample.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "grid/grid_impl.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/field/classify.h"
#include "base/vdb_module.h"

namespace qjulia {
SampledGrid::SampledGrid() : impl_(std::make_unique<Impl>()) {}
SampledGrid::~SampledGrid() = default;
SampledGrid::SampledGrid(SampledGrid&&) noexcept = default;
SampledGrid& SampledGrid::operator=(SampledGrid&&) noexcept = default;

double SampledGrid::voxel_size() const { return impl_->geometry.voxel; }
std::array<double, 3> SampledGrid::origin() const { return impl_->geometry.origin; }
std::array<int, 3> SampledGrid::points() const { return impl_->geometry.points; }
std::uint64_t SampledGrid::evaluations() const { return impl_->evaluations; }
std::uint64_t SampledGrid::dense_evaluations() const { return impl_->dense_evaluations; }
std::size_t SampledGrid::bricks() const { return impl_->bricks.size(); }
const Params& SampledGrid::params() const { return impl_->params; }
const Solid& SampledGrid::solid() const { return *impl_->solid; }

std::uint64_t SampledGrid::crossing_cells() const {
  std::uint64_t n = 0;
  for (const auto& b : impl_->bricks) n += b->surface.count();
  return n;
}

namespace {

// Calls f(global i, j, k, value) for every evaluated point a brick owns (its lower 8^3 points
// that lie in the grid).
template <class F>
void each_owned_point(const detail::Brick& b, const GridGeometry& geo, F&& f) {
  using detail::kBrick;
  for (int i = 0; i < kBrick; ++i)
    for (int j = 0; j < kBrick; ++j)
      for (int k = 0; k < kBrick; ++k) {
        const int p = detail::point_index(i, j, k);
        if (!b.known.test(p)) continue;
        const int g[3] = {b.at.x * kBrick + i, b.at.y * kBrick + j, b.at.z * kBrick + k};
        if (g[0] < 0 || g[1] < 0 || g[2] < 0 || g[0] >= geo.points[0] || g[1] >= geo.points[1] ||
            g[2] >= geo.points[2])
          continue;
        f(g[0], g[1], g[2], b.get(p));
      }
}

}  // namespace

std::uint64_t SampledGrid::active_voxels() const {
  std::uint64_t n = 0;
  for (const auto& b : impl_->bricks)
    each_owned_point(*b, impl_->geometry, [&](int, int, int, float) { ++n; });
  return n;
}

void SampledGrid::write_vdb(const std::string& path, const std::string& params_json) const {
  const detail::VdbApi& vdb = detail::vdb_api();
  const GridGeometry& geo = impl_->geometry;
  detail::VdbGrid grid;
  grid.name = "F";
  grid.voxel = geo.voxel;
  grid.origin = geo.origin;
  grid.background = static_cast<float>(impl_->params.iterations + 1);
  grid.block = 16;
  grid.interior = impl_->interior;
  grid.source = this;
  grid.each_value = [](const void* source, detail::VdbEmit emit, void* sink) {
    const SampledGrid& self = *static_cast<const SampledGrid*>(source);
    for (const auto& b : self.impl_->bricks)
      each_owned_point(*b, self.impl_->geometry,
                       [&](int i, int j, int k, float v) { emit(sink, i, j, k, v); });
  };
  grid.metadata = {
      {"qjulia_parameters", params_json},
      {"qjulia_field",
       "F: continuous escape/cut-off field of the qjulia design; F <= 0 in the solid, > 0 "
       "outside; zero level = classification boundary; units: iterations (not a distance). "
       "Inactive values: -background inside uniform blocks, background outside."},
      {"qjulia_method", to_string(impl_->params.method)}};
  AtomicFile file(path);
  file.close_for_external();
  try {
    vdb.write_grid(file.temp_path(), grid);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot write the grid: " + e.what());
  }
  file.commit();
}

SampledGrid sample(const Params& params, const SampleOptions& opts) {
  const Solid solid(params);  // validates
  return sample(solid, opts);
}

SampledGrid sample(const Solid& solid, const SampleOptions& opts) {
  SampledGrid out;
  auto& impl = out.impl();
  impl.params = solid.classifier().params();
  impl.geometry = grid_geometry(impl.params);
  impl.solid = std::make_unique<Solid>(solid);
  detail::BrickSampler sampler(*impl.solid, impl.geometry, opts);
  impl.bricks = sampler.run();
  impl.interior = sampler.interior_blocks();
  impl.evaluations = sampler.evaluations();
  impl.distribution = opts.distribution;
  const auto& p = impl.geometry.points;
  impl.dense_evaluations = static_cast<std::uint64_t>(p[0]) * p[1] * p[2];
  if (opts.progress && !opts.progress(1.0)) throw Cancelled();
  return out;
}

}  // namespace qjulia
