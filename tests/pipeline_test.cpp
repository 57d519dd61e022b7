#include "qjulia/pipeline/pipeline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <set>

#include "qjulia/base/mesh.h"
#include "qjulia/mesh/clean.h"

namespace qjulia {
namespace {

using Cx = std::complex<double>;

bool newton_cutoff_inside(Cx z, int n, double r) {
  for (int k = 1; k <= n; ++k) {
    const Cx next = (2.0 * z * z * z + 1.0) / (3.0 * z * z);
    if (!std::isfinite(next.real()) || !std::isfinite(next.imag())) return true;
    if (std::abs(next - z) < r) return false;
    z = next;
  }
  return true;
}

TEST(Pipeline, NewtonCubicClippedAtZEqualsZeroHasAFlatCapWhoseOutlineIsTheComplexPicture) {
  Params p = preset("newton-cubic");
  p.resolution = 96;
  p.mesh.clip.push_back({{0, 0, 1}, 0.0});
  const PipelineResult r = run_pipeline(p);
  const MeshMeasure& m = r.stats.measure;
  EXPECT_TRUE(m.closed);
  EXPECT_TRUE(m.manifold);
  EXPECT_TRUE(m.oriented);
  EXPECT_GT(m.volume, 0);
  const TriMesh& mesh = r.mesh;
  for (const auto& v : mesh.positions) EXPECT_LE(v[2], 1e-6) << "a vertex above the plane";
  // Cap triangles: all three vertices on the plane. Their outline: edges of a cap triangle that
  // only one cap triangle has.
  auto on_plane = [&](std::uint32_t v) { return std::abs(mesh.positions[v][2]) <= 1e-6; };
  std::multiset<std::pair<std::uint32_t, std::uint32_t>> cap_edges;
  std::size_t cap = 0;
  for (const auto& t : mesh.triangles) {
    if (!on_plane(t[0]) || !on_plane(t[1]) || !on_plane(t[2])) continue;
    ++cap;
    for (int e = 0; e < 3; ++e) cap_edges.insert(std::minmax(t[e], t[(e + 1) % 3]));
  }
  EXPECT_GT(cap, 100u);
  std::set<std::uint32_t> outline;
  for (const auto& e : cap_edges)
    if (cap_edges.count(e) == 1) {
      outline.insert(e.first);
      outline.insert(e.second);
    }
  ASSERT_GT(outline.size(), 100u);
  // Outline vertices away from the box walls lie on the complex boundary (the section z = 0 of a
  // real-coefficient map is the complex picture). Marching cubes chamfers the rim of a cap (no
  // sharp features): the outline runs through the grid columns inside the picture that border
  // columns outside it, so the classification changes within one cell of each outline vertex
  // (one voxel along x or y, sqrt(2) along a diagonal) in the plane or half a voxel below it.
  const double h = r.stats.voxel_size;
  auto inside3 = [&](double x, double y, double z) {
    return newton_cutoff_inside(Cx(x, std::hypot(y, z)), p.iterations, p.bailout);
  };
  std::size_t checked = 0, far = 0;
  for (std::uint32_t v : outline) {
    const auto& q = mesh.positions[v];
    // Next to a wall of the box the outline is the wall's.
    if (std::abs(q[0]) > 2 - h || std::abs(q[1]) > 2 - h) continue;
    ++checked;
    // Along x, y and the diagonals in the plane and half a voxel below it (where the grid
    // columns are sampled): the outline of a rim cell may turn at its far corner.
    bool found = false;
    for (double z : {0.0, -0.5 * h}) {
      const bool c = inside3(q[0], q[1], z);
      for (int k = -400; k <= 400 && !found; ++k) {
        const double t = k * h / 400;
        found = inside3(q[0] + t, q[1], z) != c || inside3(q[0], q[1] + t, z) != c ||
                inside3(q[0] + t, q[1] + t, z) != c || inside3(q[0] + t, q[1] - t, z) != c;
      }
    }
    far += !found;
  }
  EXPECT_GT(checked, 100u);
  EXPECT_EQ(far, 0u) << "of " << checked << " outline vertices";
}

TEST(Pipeline, SizeScalesTheLongestSideToTheGivenMillimetres) {
  Params p = preset("classic-julia");
  p.resolution = 64;
  p.print.size_mm = 80;
  const PipelineResult r = run_pipeline(p);
  const MeshMeasure& m = r.stats.measure;
  const double longest = std::max({m.bbox_max[0] - m.bbox_min[0], m.bbox_max[1] - m.bbox_min[1],
                                   m.bbox_max[2] - m.bbox_min[2]});
  EXPECT_NEAR(longest, 80.0, 0.05);
  EXPECT_TRUE(m.closed);
  EXPECT_TRUE(m.manifold);
  EXPECT_EQ(r.stats.unit, "mm");
}

TEST(Pipeline, DustRemovalRemovesOnlyComponentsBelowTheThreshold) {
  Params p = preset("newton-cubic");
  p.resolution = 96;
  const double voxel = 4.0 / 96;
  const PipelineResult r = run_pipeline(p);
  ASSERT_TRUE(r.stats.clean.has_value());
  const CleanReport& c = *r.stats.clean;
  EXPECT_EQ(c.components_before, c.components_after + c.removed_components);
  EXPECT_EQ(c.components_after, r.stats.measure.components.size());
  EXPECT_NEAR(c.min_component_volume, 2 * voxel * voxel * voxel, 1e-12);
  for (const auto& comp : r.stats.measure.components)
    EXPECT_GE(std::abs(comp.volume), c.min_component_volume);
  // With the threshold off, the same run keeps every component; the largest of those below the
  // threshold is the one the report names.
  p.mesh.min_component = 0.0;
  const PipelineResult all = run_pipeline(p);
  EXPECT_EQ(all.stats.measure.components.size(), c.components_before);
  double largest_dust = 0;
  for (const auto& comp : all.stats.measure.components)
    if (std::abs(comp.volume) < c.min_component_volume)
      largest_dust = std::max(largest_dust, std::abs(comp.volume));
  ASSERT_GT(c.removed_components, 0u);
  EXPECT_NEAR(c.largest_removed_volume, largest_dust, 1e-9 * c.min_component_volume);
}

// A mesh's faces by their corners' positions, each starting at its least corner (the
// orientation kept).
std::vector<std::array<std::array<float, 3>, 3>> faces_by_position(const TriMesh& m) {
  std::vector<std::array<std::array<float, 3>, 3>> out;
  for (const auto& t : m.triangles) {
    std::array<std::array<float, 3>, 3> f = {m.positions[t[0]], m.positions[t[1]],
                                             m.positions[t[2]]};
    std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
    out.push_back(f);
  }
  return out;
}

// Whether `part` is `whole` with some items left out, in order.
template <class T>
bool is_subsequence(const std::vector<T>& part, const std::vector<T>& whole) {
  std::size_t i = 0;
  for (const T& x : whole)
    if (i < part.size() && part[i] == x) ++i;
  return i == part.size();
}

// PipelineOptions::normals false (as `qjulia mesh -o x.ply` runs): the same mesh and measures,
// without normals, which area_weighted_normals() then makes as the pipeline would have; after the
// dust removal and after a decimation.
TEST(Pipeline, WithoutNormalsTheMeshIsTheSameAndTheWritersNormalsAreThePipelines) {
  Params p = preset("newton-cubic");
  p.resolution = 96;
  for (const std::optional<std::size_t> faces : {std::optional<std::size_t>(), {60000}}) {
    SCOPED_TRACE(faces ? "decimated" : "not decimated");
    p.mesh.faces = faces;
    const PipelineResult with = run_pipeline(p);
    PipelineOptions opts;
    opts.normals = false;
    const PipelineResult without = run_pipeline(p, opts);
    ASSERT_EQ(with.mesh.normals.size(), with.mesh.positions.size());
    EXPECT_TRUE(without.mesh.normals.empty());
    EXPECT_EQ(without.mesh.positions, with.mesh.positions);
    EXPECT_EQ(without.mesh.triangles, with.mesh.triangles);
    EXPECT_EQ(without.stats.measure.volume, with.stats.measure.volume);
    EXPECT_EQ(without.stats.measure.euler, with.stats.measure.euler);
    EXPECT_TRUE(area_weighted_normals(without.mesh) == with.mesh.normals);
  }
}

TEST(Pipeline, DustRemovalKeepsTheOrderAndLeavesTheFacesTheGeneralCleanLeaves) {
  // The pipeline removes the dust in parallel, block by block of faces and vertices; the
  // general clean() removes the same components in one pass. At 160 the mesh has some ten
  // blocks of faces and the dust is spread over all of them.
  Params p = preset("newton-cubic");
  p.resolution = 160;
  const PipelineResult r = run_pipeline(p);
  ASSERT_TRUE(r.stats.clean.has_value());
  ASSERT_GT(r.stats.clean->removed_components, 100u);
  ASSERT_GT(r.mesh.triangles.size(), std::size_t{8} << 16);
  p.mesh.min_component = 0.0;
  const PipelineResult all = run_pipeline(p);
  ASSERT_EQ(all.stats.clean->removed_components, 0u);
  // What is kept is in the order it had, with the normals it had, and every vertex is used.
  const auto kept = faces_by_position(r.mesh), every = faces_by_position(all.mesh);
  EXPECT_EQ(kept.size() + r.stats.clean->removed_faces, every.size());
  EXPECT_TRUE(is_subsequence(kept, every));
  std::vector<std::pair<std::array<float, 3>, std::array<float, 3>>> kept_v, every_v;
  for (std::size_t v = 0; v < r.mesh.positions.size(); ++v)
    kept_v.emplace_back(r.mesh.positions[v], r.mesh.normals[v]);
  for (std::size_t v = 0; v < all.mesh.positions.size(); ++v)
    every_v.emplace_back(all.mesh.positions[v], all.mesh.normals[v]);
  EXPECT_TRUE(is_subsequence(kept_v, every_v));
  // Made after the dust removal, they are each vertex's face-order sum over the mesh as kept.
  ASSERT_EQ(r.mesh.normals.size(), r.mesh.positions.size());
  EXPECT_TRUE(r.mesh.normals == area_weighted_normals(r.mesh));
  std::vector<char> used(r.mesh.positions.size(), 0);
  for (const auto& t : r.mesh.triangles)
    for (std::uint32_t v : t) used[v] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
  // The same faces as the general clean() with the same threshold.
  CleanOptions copts;
  copts.min_component_volume = r.stats.clean->min_component_volume;
  CleanReport creport;
  auto cleaned = faces_by_position(clean(all.mesh, copts, &creport));
  EXPECT_EQ(creport.removed_components, r.stats.clean->removed_components);
  auto sorted_kept = kept;
  std::sort(sorted_kept.begin(), sorted_kept.end());
  std::sort(cleaned.begin(), cleaned.end());
  EXPECT_TRUE(sorted_kept == cleaned);
}

TEST(Pipeline, UnitBallAt256DecimatedTo2000FacesStaysClosedAndOnTheSphere) {
  Params p = preset("unit-ball");
  p.resolution = 256;
  p.mesh.faces = 2000;
  const PipelineResult r = run_pipeline(p);
  const MeshMeasure& m = r.stats.measure;
  EXPECT_GE(m.faces, 1000u);
  EXPECT_LE(m.faces, 2000u);
  EXPECT_TRUE(m.closed);
  EXPECT_TRUE(m.manifold);
  EXPECT_TRUE(m.oriented);
  ASSERT_EQ(m.components.size(), 1u);
  EXPECT_EQ(m.components[0].genus, 0);
  double worst = 0;
  for (const auto& v : r.mesh.positions)
    worst = std::max(
        worst,
        std::abs(std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]) - 1.0));
  EXPECT_LT(worst, 0.02);
  ASSERT_TRUE(r.stats.decimate.has_value());
  EXPECT_GT(r.stats.decimate->faces_before, 100000u);
}

TEST(Pipeline, BasinColoursOfNewtonsCubicShowItsTwoKindsOfRoots) {
  Params p = preset("newton-cubic");
  p.resolution = 48;
  p.mesh.color = ColorMode::kBasin;
  const PipelineResult r = run_pipeline(p);
  ASSERT_EQ(r.mesh.colors.size(), r.mesh.positions.size());
  // Every vertex gets the colour of the root its outside neighbour converges to. In quaternions
  // h^3 = 1 has the root 1 and a whole sphere of roots -1/2 + (sqrt(3)/2) u (u a unit imaginary
  // quaternion: the two complex roots revolved about the real axis), so two basins.
  std::set<std::array<float, 3>> colours(r.mesh.colors.begin(), r.mesh.colors.end());
  const std::array<float, 3> grey{0.6f, 0.6f, 0.6f};
  colours.erase(grey);
  EXPECT_EQ(colours.size(), 2u);
}

TEST(Pipeline, IterationColoursVaryAndStayInRange) {
  Params p = preset("classic-julia");
  p.resolution = 48;
  p.mesh.color = ColorMode::kIterations;
  const PipelineResult r = run_pipeline(p);
  ASSERT_EQ(r.mesh.colors.size(), r.mesh.positions.size());
  std::set<std::array<float, 3>> colours;
  for (const auto& c : r.mesh.colors) {
    for (float x : c) {
      EXPECT_GE(x, 0.0f);
      EXPECT_LE(x, 1.0f);
    }
    colours.insert(c);
  }
  EXPECT_GT(colours.size(), 100u);
}

TEST(Pipeline, StatsDescribeTheMeshThatIsWrittenOnEveryPreset) {
  // The measures come from the bricks and follow dust removal and scaling; they must be what
  // measure() finds in the final mesh.
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    Params p = preset(name);
    p.resolution = 72;
    if (name == "classic-julia") p.print.size_mm = 80;
    const PipelineResult r = run_pipeline(p);
    const MeshMeasure m = measure(r.mesh);
    const MeshMeasure& s = r.stats.measure;
    EXPECT_EQ(s.vertices, m.vertices);
    EXPECT_EQ(s.faces, m.faces);
    EXPECT_EQ(s.edges, m.edges);
    EXPECT_EQ(s.euler, m.euler);
    EXPECT_EQ(s.closed, m.closed);
    EXPECT_EQ(s.manifold, m.manifold);
    EXPECT_EQ(s.components.size(), m.components.size());
    EXPECT_NEAR(s.volume, m.volume, 1e-9 * std::abs(m.volume));
    EXPECT_NEAR(s.area, m.area, 1e-9 * m.area);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(s.bbox_min[a], m.bbox_min[a], 1e-9 * (1 + std::abs(m.bbox_min[a])));
      EXPECT_NEAR(s.bbox_max[a], m.bbox_max[a], 1e-9 * (1 + std::abs(m.bbox_max[a])));
    }
    ASSERT_TRUE(r.stats.clean);
    EXPECT_EQ(r.stats.clean->components_after, m.components.size());
  }
}

}  // namespace
}  // namespace qjulia
