#include "qjulia/surface/extract.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <tuple>

#include "base/geometry.h"
#include "base/mesh_check.h"
#include "base/union_find.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"
#include "qjulia/pipeline/pipeline.h"
#include "surface/pairing.h"

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
  out.mesh = extract(grid, {}, &es);
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
    worst = std::max(
        worst,
        std::abs(std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]) - 1.0));
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
std::vector<std::pair<std::size_t, double>> big_components(const MeshMeasure& m,
                                                           double min_volume) {
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

TEST(Extract, TheSurfaceIsEmbeddedOnEveryPreset) {
  // No two triangles meet other than in a shared corner or edge (CGAL's exact test), at the
  // resolutions of `--check`'s promise (128 and 256) and one that is not a power of two.
  for (int resolution : {100, 128, 256}) {
    for (const std::string& name : preset_names()) {
      SCOPED_TRACE(name + " at " + std::to_string(resolution));
      Params p = preset(name);
      p.resolution = resolution;
      const SampledGrid grid = sample(p);
      ExtractStats es;
      const TriMesh mesh = extract(grid, {}, &es);
      ASSERT_GT(mesh.triangles.size(), 0u);
      EXPECT_EQ(es.unembedded_cells, 0u);
      EXPECT_TRUE(detail::self_intersecting_face_pairs(mesh).empty());
    }
  }
}

TEST(Extract, UnitBallAt512CostsAtMostThreePercentOfADenseGrid) {
  Params p = preset("unit-ball");
  p.resolution = 512;
  const SampledGrid grid = sample(p);
  EXPECT_LE(static_cast<double>(grid.evaluations()), 0.03 * grid.dense_evaluations());
}

// Independent complex-arithmetic classifiers (docs/design.md's methods on C).
using Cx = std::complex<double>;

bool complex_cutoff_inside(Cx z, Cx (*f)(Cx), int n, double r) {
  for (int k = 1; k <= n; ++k) {
    const Cx next = f(z);
    if (!std::isfinite(next.real()) || !std::isfinite(next.imag())) return true;  // a pole
    if (std::abs(next - z) < r) return false;
    z = next;
  }
  return true;
}

Cx newton(Cx z) { return (2.0 * z * z * z + 1.0) / (3.0 * z * z); }
Cx rosa(Cx z) { return (2.0 * z * z * z - 2.0 * z * z - 3.0) / (3.0 * z * z + 4.0 * z + 1.0); }

// True when the complex picture changes within `radius` of (x, rho): some point of a small
// circle (or the centre) is classified differently from another.
template <typename Inside>
bool near_complex_boundary(Inside inside, double x, double rho, double radius) {
  const bool centre = inside(x, rho);
  for (int k = 0; k < 16; ++k) {
    const double a = 2 * kPi * k / 16;
    if (inside(x + radius * std::cos(a), rho + radius * std::sin(a)) != centre) return true;
  }
  return false;
}

// Checks that a revolved mesh is the complex picture rotated about the x axis: every vertex
// (away from the box walls) lies within a quarter voxel of the complex boundary, and every
// complex boundary point found on a grid has a vertex within a voxel of its circle.
template <typename Inside>
void expect_revolved_complex_picture(const Params& p, Inside inside) {
  const Meshed m = mesh_of(p);
  expect_watertight(m.measure);
  const double h = m.voxel;
  std::size_t checked = 0, far = 0;
  for (const auto& v : m.mesh.positions) {
    bool on_wall = false;
    for (int a = 0; a < 3; ++a)
      on_wall = on_wall || std::abs(v[a] - p.bounds.min[a]) < 1e-5 ||
                std::abs(v[a] - p.bounds.max[a]) < 1e-5;
    if (on_wall) continue;
    ++checked;
    // A vertex lies on a grid edge (two coordinates on the lattice): the complex picture must
    // change along that edge within a quarter voxel of it. Thin features are finer than any
    // circle of samples, so the search runs along the edge, 129 samples.
    bool lattice[3];
    int on_lattice = 0;
    for (int a = 0; a < 3; ++a) {
      const double u = (v[a] - p.bounds.min[a]) / h - 0.5;
      on_lattice += lattice[a] = std::abs(u - std::round(u)) < 1e-3;
    }
    // Directions: the axes, then the cube diagonals (the centre vertices of awkward loops are
    // not on grid edges).
    static const double kDirs[7][3] = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1}, {1, 1, 1},
                                       {1, 1, -1}, {1, -1, 1}, {-1, 1, 1}};
    bool found = false;
    for (int a = 0; a < 7 && !found; ++a) {
      if (on_lattice == 2 && (a >= 3 || lattice[a])) continue;
      const double norm = std::sqrt(kDirs[a][0] * kDirs[a][0] + kDirs[a][1] * kDirs[a][1] +
                                    kDirs[a][2] * kDirs[a][2]);
      auto at = [&](double t) {
        const double q[3] = {v[0] + t * kDirs[a][0] / norm, v[1] + t * kDirs[a][1] / norm,
                             v[2] + t * kDirs[a][2] / norm};
        return inside(q[0], std::hypot(q[1], q[2]));
      };
      // Uniform samples, and samples at geometrically shrinking offsets, which find the
      // sub-voxel islands the refinement may have stopped next to.
      const bool first = at(-0.25 * h);
      for (int k = 1; k <= 128 && !found; ++k) found = at(-0.25 * h + k * 0.5 * h / 128) != first;
      for (int k = 0; k < 40 && !found; ++k)
        found =
            at(0.25 * h * std::pow(0.5, k)) != first || at(-0.25 * h * std::pow(0.5, k)) != first;
      // The grid points at the ends of the vertex's edge, when within a quarter voxel: a speck
      // around a grid point is thinner than any spacing of samples.
      if (a < 3 && !found) {
        const double u = (v[a] - p.bounds.min[a]) / h - 0.5;
        for (double end : {std::floor(u), std::ceil(u)}) {
          const double t = p.bounds.min[a] + (end + 0.5) * h - v[a];
          if (std::abs(t) <= 0.25 * h && at(t) != first) found = true;
        }
      }
      // Islands thinner than those spacings next to the vertex: a fine scan of +-0.03 voxel.
      for (int k = -3000; k <= 3000 && !found; ++k) found = at(k * 1e-5 * h) != first;
    }
    if (!found) ++far;
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_EQ(far, 0u) << "of " << checked << " vertices";
  // Coverage: boundary points of the complex picture on a grid of the (x, rho) half plane
  // inside the box, against the vertices binned by (x, rho).
  const double rho_max =
      std::min({p.bounds.max[1], -p.bounds.min[1], p.bounds.max[2], -p.bounds.min[2]});
  const int nx = static_cast<int>((p.bounds.max[0] - p.bounds.min[0]) / h) + 1;
  const int nr = static_cast<int>(rho_max / h) + 1;
  std::vector<char> has_vertex(static_cast<std::size_t>(nx) * nr, 0);
  for (const auto& v : m.mesh.positions) {
    const int i = static_cast<int>((v[0] - p.bounds.min[0]) / h);
    const int j = static_cast<int>(std::hypot(double(v[1]), double(v[2])) / h);
    if (i >= 0 && i < nx && j >= 0 && j < nr) has_vertex[static_cast<std::size_t>(i) * nr + j] = 1;
  }
  auto covered = [&](double x, double rho) {
    const int i0 = static_cast<int>((x - p.bounds.min[0]) / h), j0 = static_cast<int>(rho / h);
    for (int i = i0 - 1; i <= i0 + 1; ++i)
      for (int j = j0 - 1; j <= j0 + 1; ++j)
        if (i >= 0 && i < nx && j >= 0 && j < nr &&
            has_vertex[static_cast<std::size_t>(i) * nr + j])
          return true;
    return false;
  };
  std::size_t boundary = 0, missed = 0;
  for (int i = 1; i + 1 < nx; ++i)
    for (int j = 1; j + 2 < nr; ++j) {
      const double x = p.bounds.min[0] + (i + 0.5) * h, rho = (j + 0.5) * h;
      if (inside(x, rho) == inside(x + h, rho)) continue;
      ++boundary;
      if (!covered(x + 0.5 * h, rho)) ++missed;
    }
  EXPECT_GT(boundary, 50u);
  EXPECT_EQ(missed, 0u) << "of " << boundary << " boundary points";
}

TEST(Extract, NewtonCubicIsTheComplexPictureRevolvedAboutTheRealAxis) {
  Params p = preset("newton-cubic");
  p.resolution = 96;
  expect_revolved_complex_picture(p, [&](double x, double rho) {
    return complex_cutoff_inside(Cx(x, rho), newton, p.iterations, p.bailout);
  });
}

TEST(Extract, RosaRationalMapIsTheComplexPictureRevolvedAboutTheRealAxis) {
  Params p = preset("rosa-rational");
  p.resolution = 96;
  p.mesh.clip.clear();  // the preset is cut open; the revolved solid is the whole one
  expect_revolved_complex_picture(p, [&](double x, double rho) {
    return complex_cutoff_inside(Cx(x, rho), rosa, p.iterations, p.bailout);
  });
}

TEST(Extract, SectionZEqualsZeroOfClassicJuliaIsTheComplexFilledJuliaSet) {
  Params p = preset("classic-julia");
  p.resolution = 128;
  const Cx c(p.constant("c")->w, p.constant("c")->x);
  auto inside = [&](double x, double y) {
    Cx z(x, y);
    if (std::abs(z) > p.bailout) return false;
    for (int k = 1; k <= p.iterations; ++k) {
      z = z * z + c;
      if (std::abs(z) > p.bailout) return false;
    }
    return true;
  };
  const Meshed m = mesh_of(p);
  expect_watertight(m.measure);
  const double h = m.voxel;
  // Where mesh edges cross the plane z = 0, the crossing point is on the complex boundary.
  std::size_t crossings = 0, far = 0;
  std::vector<std::pair<double, double>> section;
  for (const auto& t : m.mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const auto &a = m.mesh.positions[t[e]], &b = m.mesh.positions[t[(e + 1) % 3]];
      if ((a[2] < 0) == (b[2] < 0)) continue;
      const double s = a[2] / (double(a[2]) - b[2]);
      const double x = a[0] + s * (b[0] - a[0]), y = a[1] + s * (b[1] - a[1]);
      ++crossings;
      section.emplace_back(x, y);
      // Linear interpolation between two refined vertices: within half a voxel.
      if (!near_complex_boundary(inside, x, y, 0.5 * h)) ++far;
    }
  EXPECT_GT(crossings, 500u);
  EXPECT_EQ(far, 0u) << "of " << crossings;
  // Every complex boundary point on a grid has a section point within a voxel.
  std::size_t boundary = 0, missed = 0;
  for (double x = -1.4; x < 1.4; x += h)
    for (double y = -1.4; y < 1.4; y += h) {
      if (inside(x, y) == inside(x + h, y)) continue;
      ++boundary;
      bool found = false;
      for (const auto& [sx, sy] : section)
        if (std::abs(sx - (x + 0.5 * h)) <= 1.5 * h && std::abs(sy - y) <= 1.5 * h) {
          found = true;
          break;
        }
      if (!found) ++missed;
    }
  EXPECT_GT(boundary, 100u);
  EXPECT_EQ(missed, 0u) << "of " << boundary;
}

// An independent complex escape classifier (docs/design.md's escape method on C).
template <typename Map>
bool complex_escape_inside(Cx z, Map f, int n, double r) {
  if (std::abs(z) > r) return false;
  for (int k = 1; k <= n; ++k) {
    z = f(z);
    if (!std::isfinite(z.real()) || !std::isfinite(z.imag()) || std::abs(z) > r) return false;
  }
  return true;
}

TEST(Extract, RealCoefficientSineAndExponentialMapsAreTheirComplexPicturesRevolved) {
  // The rotation fact for transcendental maps with real c, escape method, against std::sin and
  // std::exp on the complex half plane (x, rho). c*sin(h), c = 1.8, N = 8, R = 20 in
  // [-4, 4] x [-3, 3]^2: two spiked lenses on the real axis, revolved into discs with rings of
  // spikes (70k vertices checked). exp(h) - 0.5, N = 8, R = 20 in [-2, 4] x [-4, 4]^2: islands
  // of slow escape, revolved into a ring and a row of smaller rings around the axis, plus the
  // next period at rho near 2 pi in the corners (34k vertices). A change of c by 0.02 in the
  // complex maps makes both checks fail.
  {
    SCOPED_TRACE("c*sin(h)");
    Params p;
    p.formula = "c*sin(h)";
    p.constants = {{"c", Quat(1.8)}};
    p.method = Method::kEscape;
    p.iterations = 8;
    p.bailout = 20;
    p.bounds = {{-4, -3, -3}, {4, 3, 3}};
    p.resolution = 96;
    const double c = 1.8;
    expect_revolved_complex_picture(p, [&](double x, double rho) {
      return complex_escape_inside(
          Cx(x, rho), [&](Cx z) { return c * std::sin(z); }, p.iterations, p.bailout);
    });
  }
  {
    SCOPED_TRACE("exp(h)+c");
    Params p;
    p.formula = "exp(h)+c";
    p.constants = {{"c", Quat(-0.5)}};
    p.method = Method::kEscape;
    p.iterations = 8;
    p.bailout = 20;
    p.bounds = {{-2, -4, -4}, {4, 4, 4}};
    p.resolution = 96;
    const double c = -0.5;
    expect_revolved_complex_picture(p, [&](double x, double rho) {
      return complex_escape_inside(
          Cx(x, rho), [&](Cx z) { return std::exp(z) + c; }, p.iterations, p.bailout);
    });
  }
}

// The measures the bricks give (no pass over the mesh) against measure() of the whole mesh.
void expect_same_measure(const MeshMeasure& a, const MeshMeasure& b) {
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.faces, b.faces);
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.boundary_edges, b.boundary_edges);
  EXPECT_EQ(a.closed, b.closed);
  EXPECT_EQ(a.manifold, b.manifold);
  EXPECT_EQ(a.oriented, b.oriented);
  EXPECT_EQ(a.degenerate_faces, b.degenerate_faces);
  EXPECT_EQ(a.euler, b.euler);
  EXPECT_NEAR(a.volume, b.volume, 1e-9 * std::abs(b.volume));
  EXPECT_NEAR(a.area, b.area, 1e-9 * b.area);
  for (int k = 0; k < 3; ++k) {
    EXPECT_DOUBLE_EQ(a.bbox_min[k], b.bbox_min[k]);
    EXPECT_DOUBLE_EQ(a.bbox_max[k], b.bbox_max[k]);
  }
  ASSERT_EQ(a.components.size(), b.components.size());
  auto key = [](const ComponentMeasure& c) { return std::make_tuple(c.faces, c.genus, c.euler); };
  std::vector<std::tuple<std::size_t, long long, long long>> ka, kb;
  double va = 0, vb = 0;
  for (const auto& c : a.components) ka.push_back(key(c)), va += std::abs(c.volume);
  for (const auto& c : b.components) kb.push_back(key(c)), vb += std::abs(c.volume);
  std::sort(ka.begin(), ka.end());
  std::sort(kb.begin(), kb.end());
  EXPECT_EQ(ka, kb);
  EXPECT_NEAR(va, vb, 1e-9 * vb);
}

TEST(Extract, BricksMeasureTheMeshAsAWholeMeshPassDoesOnEveryPreset) {
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    Params p = preset(name);
    p.resolution = 80;
    const SampledGrid grid = sample(p);
    ExtractStats es;
    const TriMesh mesh = extract(grid, {}, &es);
    ASSERT_TRUE(es.measure_valid);
    expect_same_measure(es.measure, measure(mesh));
    ASSERT_EQ(es.face_component.size(), mesh.triangles.size());
  }
}

// A random parameter set: one of fifteen maps (polynomials, rational maps, real powers, the
// analytic functions, a conjugate), either method, either mode, a random box that may cut the
// set, sometimes a clip plane or another slice, 16 to 48 voxels.
Params random_set(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  auto pick = [&](int n) { return static_cast<int>(rng() % static_cast<unsigned>(n)); };
  struct Map {
    const char* formula;
    Method method;
  };
  static const Map kMaps[] = {
      {"h^2+c", Method::kEscape},         {"h^3+c", Method::kEscape},
      {"p*h^2+q", Method::kEscape},       {"(2*h^3+1)/(3*h^2)", Method::kCutoff},
      {"c*sin(h)", Method::kEscape},      {"exp(h)+c", Method::kEscape},
      {"h^2+c", Method::kCutoff},         {"h^1.5+c", Method::kEscape},
      {"(h^2+c)/(h-p)", Method::kCutoff}, {"conj(h)^2+c", Method::kEscape},
      {"h*c*h+q", Method::kEscape},       {"cos(h)*c", Method::kEscape},
      {"h^-2+c", Method::kCutoff},        {"log(h)+c", Method::kCutoff},
      {"h^4+c", Method::kEscape}};
  const Map& map = kMaps[pick(15)];
  Params p;
  p.formula = map.formula;
  p.method = pick(10) < 3 ? (map.method == Method::kEscape ? Method::kCutoff : Method::kEscape)
                          : map.method;
  p.mode = pick(4) == 0 ? Mode::kMandelbrot : Mode::kJulia;
  for (const char* name : {"c", "p", "q"})
    p.set_constant(name, Quat(u(rng), u(rng), 0.5 * u(rng), 0.5 * u(rng)));
  p.iterations = 2 + pick(13);
  static const double kRates[] = {0.05, 0.3, 1, 2, 4, 10}, kRadii[] = {1.5, 2, 4, 8};
  p.bailout = p.method == Method::kCutoff ? kRates[pick(6)] : kRadii[pick(4)];
  p.resolution = 16 + pick(33);
  if (pick(2) == 0)
    for (int a = 0; a < 3; ++a) {
      p.bounds.min[a] = -0.3 - 2.2 * (0.5 + 0.5 * u(rng));
      p.bounds.max[a] = 0.3 + 2.2 * (0.5 + 0.5 * u(rng));
    }
  if (pick(10) < 3) p.mesh.clip.push_back({{u(rng), u(rng), 1.1 + u(rng)}, 0.5 * u(rng)});
  if (pick(5) == 0) {
    static const char* kAxes[] = {"mnp", "rnp", "rmp", "pmr"};
    p.slice.axes = kAxes[pick(4)];
    p.slice.fixed = 0.5 * u(rng);
  }
  return p;
}

TEST(Extract, RandomSetsGiveClosedEmbeddedSurfacesThatTheirBricksMeasure) {
  // What the presets' tests check, on sets no one chose: the surface is closed, manifold and
  // oriented, no cell is left with crossing triangles and no two triangles cross (CGAL's exact
  // test, on a third of the sets), the bricks' measures are those of a pass over the whole mesh,
  // and one thread makes the same mesh as all. Among these sets, h^-2 + c (cut-off) at 31 voxels
  // is a speck of volume 4.3e-11 about two units from the grid's origin, which the bricks
  // measured 1.5e-9 off when they summed their volumes relative to that origin.
  std::mt19937_64 rng(6);
  int meshed = 0;
  for (int i = 0; i < 60; ++i) {
    const Params p = random_set(rng);
    SCOPED_TRACE(params_to_json(p, false));
    ASSERT_NO_THROW(validate(p));
    const SampledGrid grid = sample(p);
    ExtractStats es;
    const TriMesh mesh = extract(grid, {}, &es);
    if (mesh.triangles.empty()) continue;
    ++meshed;
    const MeshMeasure whole = measure(mesh);
    expect_watertight(whole);
    EXPECT_EQ(es.unembedded_cells, 0u);
    // CGAL's test on one set in three: it takes most of the time, a minute under the sanitizers
    // on all sixty.
    if (i % 3 == 0) {
      EXPECT_TRUE(detail::self_intersecting_face_pairs(mesh).empty());
    }
    ASSERT_TRUE(es.measure_valid);
    expect_same_measure(es.measure, whole);
    // The same mesh on one thread.
    TriMesh one;
    tbb::task_arena(1).execute([&] { one = extract(sample(p), {}); });
    EXPECT_EQ(one.positions, mesh.positions);
    EXPECT_EQ(one.triangles, mesh.triangles);
  }
  // Most random sets have a surface in their box: the checks above ran on them.
  EXPECT_GE(meshed, 40);
}

TEST(Extract, NormalsAreEachVertexsFaceOrderSumOnAnyThreadCount) {
  // newton-cubic at 128: about 410,000 faces on some 200,000 vertices, so each thread's range of
  // vertices has many faces, and some faces have corners in two ranges. Then the same faces in a
  // random order: every block of faces has corners in every range.
  Params p = preset("newton-cubic");
  p.resolution = 128;
  TriMesh mesh = extract(sample(p), {});
  ASSERT_GT(mesh.triangles.size(), std::size_t{1} << 18);
  auto face_order_sums = [](const TriMesh& m) {
    std::vector<std::array<float, 3>> sums(m.positions.size(), {0, 0, 0});
    detail::add_area_normals(
        m.triangles, [&](std::uint32_t v) -> const auto& { return m.positions[v]; },
        [&](std::uint32_t v) { return &sums[v]; });
    for (auto& n : sums) detail::normalize_sum(n);
    return sums;
  };
  ASSERT_EQ(mesh.normals, face_order_sums(mesh));  // extract's own normals
  TriMesh shuffled = mesh;
  std::shuffle(shuffled.triangles.begin(), shuffled.triangles.end(), std::mt19937(7));
  for (const TriMesh* m : {&mesh, &shuffled}) {
    const std::vector<std::array<float, 3>> serial = face_order_sums(*m);
    for (int threads : {1, 2, 3, 7}) {
      SCOPED_TRACE(threads);
      tbb::task_arena arena(threads);
      std::vector<std::array<float, 3>> parallel;
      arena.execute([&] { parallel = area_weighted_normals(*m); });
      ASSERT_EQ(parallel.size(), serial.size());
      std::size_t differ = 0;
      for (std::size_t v = 0; v < serial.size(); ++v) differ += parallel[v] != serial[v];
      EXPECT_EQ(differ, 0u);
    }
  }
}

TEST(Extract, ReportsItsProgressBrickByBrickAndStopsWhenAskedTo) {
  // The fraction rises through the work, not from 0 straight to 1; returning false cancels.
  Params p = preset("newton-cubic");
  p.resolution = 96;
  const SampledGrid grid = sample(p);
  std::vector<double> seen;
  ExtractOptions opts;
  opts.progress = [&](double f) {
    seen.push_back(f);
    return true;
  };
  extract(grid, opts);
  ASSERT_GE(seen.size(), 10u);
  EXPECT_EQ(seen.back(), 1.0);
  std::size_t inside = 0;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_GE(seen[i], 0.0);
    EXPECT_LE(seen[i], 1.0);
    if (i > 0) {
      EXPECT_GE(seen[i], seen[i - 1]) << "at report " << i;
    }
    inside += seen[i] > 0.1 && seen[i] < 0.9;
  }
  EXPECT_GE(inside, 5u) << "reports between 10% and 90%";
  int calls = 0;
  opts.progress = [&](double f) { return ++calls < 3 || f >= 1.0; };
  EXPECT_THROW(extract(grid, opts), Cancelled);
}

TEST(Extract, SmallGridsAreSampledWhole) {
  // At a few voxels a side the coarse lattice would miss the ball: such grids are sampled
  // densely, and the surface is the same as the dense path's.
  for (int res : {4, 8, 12, 16, 24, 32}) {
    SCOPED_TRACE(res);
    Params p = preset("unit-ball");
    p.resolution = res;
    const Meshed sparse = mesh_of(p, false), dense = mesh_of(p, true);
    expect_watertight(sparse.measure);
    EXPECT_EQ(sparse.measure.faces, dense.measure.faces);
    EXPECT_NEAR(sparse.measure.volume, dense.measure.volume, 1e-12);
  }
}

// The pairing of a brick's half-edges (surface/pairing.h) on small hand-made bricks: faces as
// slots, listings as (from, to). Each case runs in the matrix of counts and, with its slots
// moved above the matrix's 1024, in the hash table; both must count alike.
using SlotFaces = std::vector<std::array<std::uint32_t, 3>>;
using Listings = std::vector<std::array<std::uint32_t, 2>>;

void expect_pairing(const SlotFaces& faces, const Listings& listed, std::size_t edges,
                    std::size_t problems) {
  for (const std::uint32_t shift : {0u, 2000u}) {
    SCOPED_TRACE(shift ? "hash table" : "matrix");
    std::vector<std::uint32_t> corner;
    std::uint32_t slots = 0;
    for (const auto& t : faces)
      for (const std::uint32_t v : t) {
        corner.push_back(v + shift);
        slots = std::max(slots, v + shift + 1);
      }
    Listings moved = listed;
    for (auto& e : moved)
      for (auto& v : e) {
        v += shift;
        slots = std::max(slots, v + 1);
      }
    const detail::HalfEdgePairing p =
        detail::pair_half_edges(corner.data(), faces.size(), slots, moved.data(), moved.size());
    EXPECT_EQ(p.edges, edges);
    EXPECT_EQ(p.problems, problems);
  }
}

TEST(Pairing, TellsEdgesInsideAndOnTheBorderFromEveryOtherHalfEdge) {
  const SlotFaces tetrahedron = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  {
    SCOPED_TRACE("closed");
    expect_pairing(tetrahedron, {}, 6, 0);
  }
  {
    SCOPED_TRACE("one face turned: three edges with both half-edges one way");
    expect_pairing({{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}}, {}, 3, 6);
  }
  {
    SCOPED_TRACE("a fin on edge 0-1");
    SlotFaces fin = tetrahedron;
    fin.push_back({0, 1, 4});
    expect_pairing(fin, {}, 5, 5);
  }
  {
    SCOPED_TRACE("one face, its edges listed in their direction");
    expect_pairing({{0, 1, 2}}, {{0, 1}, {1, 2}, {2, 0}}, 0, 0);
  }
  {
    SCOPED_TRACE("listed against their direction: each half-edge and each listing");
    expect_pairing({{0, 1, 2}}, {{1, 0}, {2, 1}, {0, 2}}, 0, 6);
  }
  {
    SCOPED_TRACE("not listed");
    expect_pairing({{0, 1, 2}}, {}, 0, 3);
  }
  {
    SCOPED_TRACE("one edge listed twice: its half-edge and both listings");
    expect_pairing({{0, 1, 2}}, {{0, 1}, {0, 1}, {1, 2}, {2, 0}}, 0, 3);
  }
  {
    SCOPED_TRACE("a listing no face has");
    expect_pairing(tetrahedron, {{0, 5}}, 6, 1);
  }
  {
    SCOPED_TRACE("a repeated corner: the half-edge from a slot to itself");
    expect_pairing({{0, 0, 1}}, {}, 1, 1);
  }
}

TEST(Pairing, CountsBeyondTheMatrixsFourBitsAreCountedInTheTable) {
  // 15 copies of one face fit the matrix's counts; 16 do not, and are counted exactly.
  for (const std::size_t copies : {std::size_t{15}, std::size_t{16}}) {
    SCOPED_TRACE(copies);
    expect_pairing(SlotFaces(copies, {0, 1, 2}), {}, 0, 3 * copies);
  }
}

// UnionFind::labels() numbers the sets in one pass, relying on no parent being larger than its
// child: against the numbering by find() on random unions (runs of joined neighbours, as faces
// make, and far pairs).
TEST(UnionFind, LabelsNumberTheSetsInTheOrderOfTheirSmallestElements) {
  std::mt19937 rng(7);
  for (const std::uint32_t n : {1u, 2u, 17u, 500u, 5000u}) {
    SCOPED_TRACE(n);
    detail::UnionFind uf(n);
    std::uniform_int_distribution<std::uint32_t> any(0, n - 1);
    for (std::uint32_t k = 0; k < n / 2; ++k) {
      const std::uint32_t a = any(rng);
      uf.unite(a, k % 3 ? std::min(n - 1, a + 1 + k % 5) : any(rng));
    }
    std::vector<std::uint32_t> label;
    const std::uint32_t sets = uf.labels(label);
    EXPECT_EQ(sets, uf.sets());
    std::vector<std::uint32_t> by_root(n, UINT32_MAX);
    std::uint32_t next = 0;
    for (std::uint32_t x = 0; x < n; ++x) {
      const std::uint32_t r = uf.find(x);
      if (by_root[r] == UINT32_MAX) by_root[r] = next++;
      ASSERT_EQ(label[x], by_root[r]) << "element " << x;
    }
  }
}

}  // namespace
}  // namespace qjulia
