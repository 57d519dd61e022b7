#include "qjulia/grid/sample.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Composite.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <stdexcept>

#include "grid/grid_impl.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/field/classify.h"

namespace qjulia {
namespace {

std::once_flag g_openvdb_init;

}  // namespace

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
  std::call_once(g_openvdb_init, [] { openvdb::initialize(); });
  const GridGeometry& geo = impl_->geometry;
  const float background = static_cast<float>(impl_->params.iterations + 1);
  auto grid = openvdb::FloatGrid::create(background);
  {
    // Uniform interior blocks first, as inactive tiles; the evaluated points then override.
    constexpr int s = 16;
    for (const auto& c : impl_->interior)
      grid->tree().fill(
          openvdb::CoordBBox(openvdb::Coord(c[0] * s, c[1] * s, c[2] * s),
                             openvdb::Coord(c[0] * s + s - 1, c[1] * s + s - 1, c[2] * s + s - 1)),
          -background, false);
    auto acc = grid->getAccessor();
    for (const auto& b : impl_->bricks)
      each_owned_point(*b, geo, [&](int i, int j, int k, float v) {
        acc.setValueOn(openvdb::Coord(i, j, k), v);
      });
  }
  grid->setName("F");
  grid->setTransform(openvdb::math::Transform::createLinearTransform(geo.voxel));
  grid->transform().postTranslate(openvdb::Vec3d(geo.origin[0], geo.origin[1], geo.origin[2]));
  grid->insertMeta("qjulia_parameters", openvdb::StringMetadata(params_json));
  grid->insertMeta("qjulia_field",
                   openvdb::StringMetadata(
                       "F: continuous escape/cut-off field of the qjulia design; F <= 0 in the "
                       "solid, > 0 outside; zero level = classification boundary; units: "
                       "iterations (not a distance). Inactive values: -background inside "
                       "uniform blocks, background outside."));
  grid->insertMeta("qjulia_method", openvdb::StringMetadata(to_string(impl_->params.method)));
  AtomicFile file(path);
  file.close_for_external();
  try {
    openvdb::io::File out(file.temp_path());
    openvdb::GridPtrVec grids{grid};
    out.write(grids);
    out.close();
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
  std::call_once(g_openvdb_init, [] { openvdb::initialize(); });
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
