#include "qjulia/extract.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "qjulia/classify.h"
#include "qjulia/pipeline.h"
#include "qjulia/sample.h"

namespace qjulia {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Meshed {
  TriMesh mesh;
  MeshMeasure measure;
  double voxel = 0;
  std::uint64_t evaluations = 0, dense_evaluations = 0;
};

Meshed mesh_of(const Params& p, bool dense = false) {
  SampleOptions so;
  so.dense = dense;
  const SampledGrid grid = sample(p, so);
  ExtractStats es;
  Meshed out;
  out.mesh = extract(grid, p, {}, &es);
  out.measure = measure(out.mesh);
  out.voxel = grid.voxel_size();
  out.evaluations = grid.evaluations() + es.evaluations;
  out.dense_evaluations = grid.dense_evaluations();
  return out;
}

void expect_watertight(const MeshMeasure& m) {
  EXPECT_GT(m.faces, 0u);
  EXPECT_TRUE(m.closed) << m.boundary_edges << " boundary, " << m.nonmanifold_edges
                        << " non-manifold edges";
  EXPECT_TRUE(m.manifold) << m.nonmanifold_vertices << " non-manifold vertices";
  EXPECT_TRUE(m.oriented) << m.misoriented_edges << " misoriented edges";
  EXPECT_GT(m.volume, 0);
}

TEST(Extract, UnitBallIsClosedAndHasTheRightVolumeAreaAndRadius) {
  Params p = preset("unit-ball");
  p.resolution = 128;
  p.bounds = {{-1.5, -1.5, -1.5}, {1.5, 1.5, 1.5}};
  const Meshed m = mesh_of(p);
  expect_watertight(m.measure);
  EXPECT_NEAR(m.measure.volume, 4.0 / 3.0 * kPi, 0.003 * 4.0 / 3.0 * kPi);
  EXPECT_NEAR(m.measure.area, 4.0 * kPi, 0.01 * 4.0 * kPi);
  double worst = 0;
  for (const auto& v : m.mesh.positions)
    worst = std::max(worst, std::abs(std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] +
                                               double(v[2]) * v[2]) - 1.0));
  EXPECT_LT(worst, 0.05 * m.voxel);
  EXPECT_EQ(m.measure.components.size(), 1u);
  EXPECT_EQ(m.measure.components[0].genus, 0);
}

TEST(Extract, BoxWallsCloseASolidThatFillsTheBoxWithFlatCaps) {
  // h^2 with R = 1 in a box inside the ball: the solid is the whole box. Marching cubes
  // chamfers the box's edges (at most h/2 by h/2) but the caps lie exactly on the walls.
  Params p = preset("unit-ball");
  p.resolution = 16;
  p.bounds = {{-0.5, -0.4, -0.3}, {0.5, 0.4, 0.3}};
  const Meshed m = mesh_of(p);
  expect_watertight(m.measure);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(m.measure.bbox_min[a], p.bounds.min[a], 1e-6);
    EXPECT_NEAR(m.measure.bbox_max[a], p.bounds.max[a], 1e-6);
  }
  const double h = m.voxel, edges = 4 * (1.0 + 0.8 + 0.6);
  EXPECT_LE(m.measure.volume, 0.48 + 1e-9);
  EXPECT_GE(m.measure.volume, 0.48 - edges * h * h / 8 - 8 * h * h * h);
}

TEST(Extract, ClipPlaneGivesAFlatCapAndKeepsTheSolidClosed) {
  Params p = preset("unit-ball");
  p.resolution = 128;
  p.mesh.clip.push_back({{0, 0, 1}, 0.25});
  const Meshed m = mesh_of(p);
  expect_watertight(m.measure);
  double top = -1;
  for (const auto& v : m.mesh.positions) top = std::max(top, double(v[2]));
  EXPECT_NEAR(top, 0.25, 1e-6);
  // A ball cut at height a keeps pi (2/3 + a - a^3/3); marching cubes loses a little at the
  // sphere (inscribed) and at the rim of the cap (chamfered).
  const double a = 0.25;
  EXPECT_NEAR(m.measure.volume, kPi * (2.0 / 3.0 + a - a * a * a / 3.0), 0.005);
  std::size_t on_cap = 0;
  for (const auto& v : m.mesh.positions) on_cap += std::abs(v[2] - 0.25) < 1e-6;
  EXPECT_GT(on_cap, 100u);
}

// Components of at least `min_volume`, as (faces, volume), largest first.
std::vector<std::pair<std::size_t, double>> big_components(const MeshMeasure& m, double min_volume) {
  std::vector<std::pair<std::size_t, double>> out;
  for (const auto& c : m.components)
    if (std::abs(c.volume) >= min_volume) out.emplace_back(c.faces, c.volume);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Extract, SparseAndDenseSamplingGiveTheSameSurfaceOnEveryPreset) {
  // The same surface: every component of more than two voxels of volume is identical (sub-voxel
  // specks between coarse samples are what the clean stage removes as dust).
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    Params p = preset(name);
    p.resolution = 96;
    const Meshed sparse = mesh_of(p, false), dense = mesh_of(p, true);
    expect_watertight(sparse.measure);
    EXPECT_LT(sparse.evaluations, dense.evaluations);
    const double speck = 2 * std::pow(dense.voxel, 3);
    const auto a = big_components(sparse.measure, speck), b = big_components(dense.measure, speck);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].first, b[i].first);
      EXPECT_NEAR(a[i].second, b[i].second, 1e-9 * std::abs(b[i].second));
    }
  }
}

TEST(Extract, UnitBallAt512CostsAtMostThreePercentOfADenseGrid) {
  Params p = preset("unit-ball");
  p.resolution = 512;
  const SampledGrid grid = sample(p);
  EXPECT_LE(static_cast<double>(grid.evaluations()), 0.03 * grid.dense_evaluations());
}

}  // namespace
}  // namespace qjulia
