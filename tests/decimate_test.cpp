// Tests of decimate(): face budget, error bound (checked independently), topology.
#include "qjulia/mesh/decimate.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>

#include "mesh/collapse.h"
#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"
#include "qjulia/pipeline/pipeline.h"
#include "test_meshes.h"

using qjulia::TriMesh;

namespace {

using P = std::array<double, 3>;
P at(const TriMesh& m, uint32_t v) {
  return {m.positions[v][0], m.positions[v][1], m.positions[v][2]};
}
P sub(P a, P b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(P a, P b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
P cross(P a, P b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double point_segment(P p, P a, P b) {
  P ab = sub(b, a);
  double t = std::clamp(dot(sub(p, a), ab) / std::max(dot(ab, ab), 1e-300), 0.0, 1.0);
  P q = {a[0] + t * ab[0] - p[0], a[1] + t * ab[1] - p[1], a[2] + t * ab[2] - p[2]};
  return std::sqrt(dot(q, q));
}

/// Distance from p to triangle abc: the plane distance when the projection falls inside,
/// else the nearest edge.
double point_triangle(P p, P a, P b, P c) {
  P n = cross(sub(b, a), sub(c, a));
  double nn = dot(n, n);
  if (nn > 0) {
    double d = dot(sub(p, a), n) / nn;
    P q = {p[0] - d * n[0], p[1] - d * n[1], p[2] - d * n[2]};
    bool inside = dot(cross(sub(b, a), sub(q, a)), n) >= 0 &&
                  dot(cross(sub(c, b), sub(q, b)), n) >= 0 &&
                  dot(cross(sub(a, c), sub(q, c)), n) >= 0;
    if (inside) return std::abs(d) * std::sqrt(nn);
  }
  return std::min({point_segment(p, a, b), point_segment(p, b, c), point_segment(p, c, a)});
}

/// Brute-force distance from p to a (small) mesh.
double point_mesh(P p, const TriMesh& m) {
  double best = 1e300;
  for (const auto& t : m.triangles)
    best = std::min(best, point_triangle(p, at(m, t[0]), at(m, t[1]), at(m, t[2])));
  return best;
}

/// Max over dense samples of the output's faces of the distance to the unit sphere.
double max_distance_to_unit_sphere(const TriMesh& m, int n = 12) {
  double worst = 0;
  for (const auto& t : m.triangles) {
    P a = at(m, t[0]), b = at(m, t[1]), c = at(m, t[2]);
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        double u = double(i) / n, v = double(j) / n, w = 1 - u - v;
        P q = {w * a[0] + u * b[0] + v * c[0], w * a[1] + u * b[1] + v * c[1],
               w * a[2] + u * b[2] + v * c[2]};
        worst = std::max(worst, std::abs(std::sqrt(dot(q, q)) - 1.0));
      }
  }
  return worst;
}

}  // namespace

TEST(Decimate, UnitSphereTo2000FacesStaysClosedManifoldAndOnTheSphere) {
  TriMesh sphere = fixtures::uv_sphere(256, 256);  // 130,560 faces
  ASSERT_EQ(sphere.face_count(), 130560u);
  qjulia::DecimateOptions opts;
  opts.faces = 2000;
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(sphere, opts, &rep);
  EXPECT_GE(out.face_count(), 1000u);
  EXPECT_LE(out.face_count(), 2000u);
  EXPECT_EQ(rep.faces_before, sphere.face_count());
  EXPECT_EQ(rep.faces_after, out.face_count());
  EXPECT_TRUE(rep.target_reached);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  for (const auto& p : out.positions)
    EXPECT_NEAR(std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]), 1.0,
                0.02);
  EXPECT_GT(fixtures::volume(out), 0.95 * fixtures::volume(sphere));
  // The reported distance agrees with an independent dense measure to the sphere (the input is
  // within 1e-4 of it).
  const double to_sphere = max_distance_to_unit_sphere(out);
  EXPECT_GT(rep.hausdorff, 0.0);
  EXPECT_NEAR(rep.hausdorff, to_sphere, 0.25 * to_sphere + 2e-4);
}

TEST(Decimate, MaxErrorBoundHoldsByIndependentDenseSampling) {
  TriMesh sphere = fixtures::uv_sphere(200, 200);  // chord error ~1.2e-4
  const double input_error = 1.0 - std::cos(std::acos(-1.0) / 200);
  qjulia::DecimateOptions opts;
  opts.max_error = 0.004;
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(sphere, opts, &rep);
  EXPECT_LT(out.face_count(), sphere.face_count() / 10);  // it did simplify
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  EXPECT_LE(rep.hausdorff, *opts.max_error);
  EXPECT_TRUE(rep.target_reached);
  // Output -> input: dense samples of the output faces against the sphere the input lies on.
  EXPECT_LE(max_distance_to_unit_sphere(out), *opts.max_error - input_error);
  // Input -> output: every 7th input vertex, brute force against the output.
  double worst = 0;
  for (std::size_t v = 0; v < sphere.positions.size(); v += 7)
    worst = std::max(worst, point_mesh(at(sphere, uint32_t(v)), out));
  EXPECT_LE(worst, *opts.max_error);
}

TEST(Decimate, BumpyMillionFaceMeshTakesTheChunkedPathAndStaysClosed) {
  TriMesh bumpy = fixtures::noisy_sphere(8);  // 1,310,720 faces: split into chunks
  qjulia::DecimateOptions opts;
  opts.faces = 100000;
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(bumpy, opts, &rep);
  EXPECT_LE(out.face_count(), 100000u);
  EXPECT_GE(out.face_count(), 90000u);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_NEAR(fixtures::volume(out), fixtures::volume(bumpy), 0.01 * fixtures::volume(bumpy));
  EXPECT_LT(rep.hausdorff, 0.02);
}

namespace {
/// classic-julia at resolution 64 through the pipeline: 24,124 faces, genus 12, one component.
TriMesh classic_julia_64() {
  qjulia::Params params = qjulia::preset("classic-julia");
  params.resolution = 64;
  return qjulia::run_pipeline(params).mesh;
}

/// The fast method to a face budget.
TriMesh decimated_to(const TriMesh& mesh, long long faces, qjulia::DecimateReport* report) {
  qjulia::DecimateOptions opts;
  opts.faces = faces;
  return qjulia::decimate(mesh, opts, report);
}
}  // namespace

TEST(Decimate, ABudgetBelowWhatTheSurfaceCanHoldKeepsItsTopologyAndShape) {
  // classic-julia at 64: 24,124 faces, genus 12. One pass of the collapses to 1000 faces left
  // 3,428 faces and a third of the volume; to 20, a tetrahedron; to 4, nothing. The budget is
  // met only with the input's components and Euler characteristic, else the result stops above
  // it and says so.
  const TriMesh mesh = classic_julia_64();
  const auto before = fixtures::check(mesh);
  ASSERT_TRUE(before.closed_manifold_oriented);
  const double volume = fixtures::volume(mesh);
  for (const long long budget : {1000LL, 20LL, 4LL}) {
    qjulia::DecimateReport rep;
    const TriMesh out = decimated_to(mesh, budget, &rep);
    const auto after = fixtures::check(out);
    EXPECT_TRUE(after.closed_manifold_oriented) << budget;
    EXPECT_EQ(after.euler, before.euler) << budget;
    EXPECT_EQ(after.components, before.components) << budget;
    EXPECT_NEAR(fixtures::volume(out), volume, 0.08 * volume) << budget;
    EXPECT_LT(out.face_count(), mesh.face_count() / 10) << budget;
    EXPECT_EQ(rep.faces_after, out.face_count());
    EXPECT_EQ(rep.target_reached, out.face_count() <= static_cast<std::size_t>(budget)) << budget;
    if (budget < 100) {
      EXPECT_FALSE(rep.target_reached) << budget;
    }
  }
}

TEST(Decimate, ATorusDecimatedHardKeepsItsHole) {
  const TriMesh torus = fixtures::torus(200, 100, 0.05);  // 40,000 faces, genus 1
  for (const long long budget : {400LL, 8LL}) {
    const TriMesh out = decimated_to(torus, budget, nullptr);
    const auto topo = fixtures::check(out);
    EXPECT_TRUE(topo.closed_manifold_oriented) << budget;
    EXPECT_EQ(topo.euler, 0) << budget;
    EXPECT_EQ(topo.components, 1u) << budget;
    EXPECT_LT(out.face_count(), 2000u) << budget;
  }
}

/// The tetrahedron with corners at `at` and `size` along each axis from it, faces outward.
TriMesh tetrahedron(std::array<float, 3> at, float size) {
  TriMesh t;
  t.positions = {at, at, at, at};
  for (int k = 0; k < 3; ++k) t.positions[k + 1][k] += size;
  t.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return t;
}

// The simplifier of the fast method alone: collapses down to what the topology allows.

TEST(CollapseEdges, ATetrahedronStaysATetrahedron) {
  const TriMesh tetra = tetrahedron({0, 0, 0}, 1);
  ASSERT_TRUE(fixtures::check(tetra).closed_manifold_oriented);
  qjulia::detail::CollapseOptions opts;
  opts.target_faces = 1;
  const auto out = qjulia::detail::collapse_edges(tetra, opts);
  EXPECT_EQ(out.size(), 4u);  // any collapse would leave two faces on the same three vertices
}

TEST(CollapseEdges, EveryComponentAndItsGenusSurviveTheSmallestBudget) {
  // A torus (genus 1), a sphere and a small sphere apart, and a tetrahedron: taken as far down
  // as the collapses go, each stays a closed surface of its own genus, turned the same way.
  TriMesh mesh = fixtures::torus(60, 30);
  fixtures::append(mesh, fixtures::icosphere(3, 0.5, {4, 0, 0}));
  fixtures::append(mesh, fixtures::icosphere(2, 0.05, {0, 4, 0}));
  fixtures::append(mesh, tetrahedron({0, 0, 4}, 0.1f));
  const auto before = fixtures::check(mesh);
  ASSERT_TRUE(before.closed_manifold_oriented);
  ASSERT_EQ(before.components, 4u);
  qjulia::detail::CollapseOptions opts;
  opts.target_faces = 1;
  TriMesh out;
  out.positions = mesh.positions;
  out.triangles = qjulia::detail::collapse_edges(mesh, opts);
  const auto after = fixtures::check(out);
  EXPECT_TRUE(after.closed_manifold_oriented);
  EXPECT_EQ(after.components, before.components);
  EXPECT_EQ(after.euler, before.euler);
  // A sphere goes down to a tetrahedron, the torus to a few dozen faces: far below the input.
  EXPECT_LT(out.face_count(), 200u) << out.face_count();
  EXPECT_GT(fixtures::volume(out), 0.0);
}

TEST(CollapseEdges, LockedVerticesStayAndTheErrorBoundStopsTheCollapses) {
  const TriMesh sphere = fixtures::icosphere(4);  // 5120 faces
  std::vector<uint8_t> locked(sphere.positions.size(), 0);
  for (std::size_t v = 0; v < locked.size(); ++v) locked[v] = sphere.positions[v][2] > 0.5f;
  qjulia::detail::CollapseOptions opts;
  opts.target_faces = 100;
  opts.locked = &locked;
  const auto out = qjulia::detail::collapse_edges(sphere, opts);
  std::vector<uint8_t> used(sphere.positions.size(), 0);
  for (const auto& t : out)
    for (uint32_t v : t) used[v] = 1;
  for (std::size_t v = 0; v < locked.size(); ++v)
    if (locked[v]) {
      EXPECT_TRUE(used[v]) << v;
    }
  // With a bound of 1e-3 of the radius, far fewer collapses than without one are allowed.
  opts.locked = nullptr;
  const auto free_run = qjulia::detail::collapse_edges(sphere, opts);
  opts.max_error = 1e-3;
  const auto bounded = qjulia::detail::collapse_edges(sphere, opts);
  EXPECT_LE(free_run.size(), 100u);
  EXPECT_GT(bounded.size(), 1000u) << bounded.size();
  TriMesh b;
  b.positions = sphere.positions;
  b.triangles = bounded;
  EXPECT_LT(max_distance_to_unit_sphere(b), 0.01);
}

TEST(Decimate, BudgetAboveTheFaceCountReturnsTheInput) {
  TriMesh sphere = fixtures::icosphere(2);
  qjulia::DecimateOptions opts;
  opts.faces = 1000000;
  TriMesh out = qjulia::decimate(sphere, opts);
  EXPECT_EQ(out.face_count(), sphere.face_count());
}

TEST(Decimate, RejectsMissingOrNonPositiveBounds) {
  TriMesh sphere = fixtures::icosphere(2);
  EXPECT_THROW(qjulia::decimate(sphere, {}), qjulia::InvalidInput);
  qjulia::DecimateOptions opts;
  opts.faces = 0;
  EXPECT_THROW(qjulia::decimate(sphere, opts), qjulia::InvalidInput);
  opts.faces.reset();
  opts.max_error = -1.0;
  EXPECT_THROW(qjulia::decimate(sphere, opts), qjulia::InvalidInput);
}

TEST(Decimate, UnreferencedVerticesDoNotCountInTheHausdorffDistance) {
  TriMesh sphere = fixtures::uv_sphere(64, 64);
  sphere.positions.push_back({100.0f, 0.0f, 0.0f});  // referenced by no face
  qjulia::DecimateOptions opts;
  opts.faces = 1000;
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(sphere, opts, &rep);
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  EXPECT_LT(rep.hausdorff, 0.05);
  for (const auto& p : out.positions) EXPECT_LT(p[0], 1.5f);
}

TEST(Decimate, AvoidSelfIntersectionsReportsAndKeepsTheResultClosed) {
  // Two bumpy spheres side by side (gap ~0.2, less where bumps meet), decimated hard: the
  // result is checked with CGAL, the count reported, and the mesh stays closed.
  TriMesh m = fixtures::noisy_sphere(5);
  TriMesh other = fixtures::noisy_sphere(5);
  for (auto& p : other.positions) p[0] += 2.2f;
  fixtures::append(m, other);
  qjulia::DecimateOptions opts;
  opts.faces = 2000;
  opts.avoid_self_intersections = true;
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(m, opts, &rep);
  ASSERT_TRUE(rep.self_intersections.has_value());
  EXPECT_EQ(*rep.self_intersections, 0u);
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  EXPECT_LE(out.face_count(), 2000u);
}

namespace {
/// Decimates `mesh` on `threads` threads.
TriMesh decimate_on(int threads, const TriMesh& mesh, const qjulia::DecimateOptions& opts,
                    qjulia::DecimateReport* rep) {
  tbb::task_arena arena(threads);
  TriMesh out;
  arena.execute([&] { out = qjulia::decimate(mesh, opts, rep); });
  return out;
}
}  // namespace

TEST(Decimate, ResultDependsOnlyOnTheInputNotOnTheThreads) {
  // 327,680 faces: the chunked path (chunks simplified in parallel, then joined).
  const TriMesh bumpy = fixtures::noisy_sphere(7);
  qjulia::DecimateOptions opts;
  opts.faces = 30000;
  qjulia::DecimateReport one, two, three;
  const TriMesh a = decimate_on(1, bumpy, opts, &one);
  const TriMesh b = decimate_on(2, bumpy, opts, &two);
  const TriMesh c = decimate_on(3, bumpy, opts, &three);
  ASSERT_LE(a.face_count(), 30000u);
  EXPECT_GT(a.face_count(), 25000u);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.positions, c.positions);
  EXPECT_EQ(a.triangles, c.triangles);
  EXPECT_EQ(one.hausdorff, two.hausdorff);
  EXPECT_EQ(one.hausdorff, three.hausdorff);
}

TEST(Decimate, ErrorBoundResultDependsOnlyOnTheInputNotOnTheThreads) {
  const TriMesh bumpy = fixtures::noisy_sphere(7);
  qjulia::DecimateOptions opts;
  opts.max_error = 0.01;
  qjulia::DecimateReport one, two;
  const TriMesh a = decimate_on(1, bumpy, opts, &one);
  const TriMesh b = decimate_on(2, bumpy, opts, &two);
  EXPECT_LT(a.face_count(), bumpy.face_count() / 2);
  EXPECT_LE(one.hausdorff, 0.01);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(one.hausdorff, two.hausdorff);
}

TEST(Decimate, ARequestedTokenCancelsBeforeAnyWork) {
  qjulia::CancelToken token;
  token.request();
  qjulia::DecimateOptions opts;
  opts.faces = 100;
  opts.cancel = &token;
  EXPECT_THROW(qjulia::decimate(fixtures::icosphere(3), opts), qjulia::Cancelled);
}

TEST(Decimate, ATokenRequestedDuringTheWorkCancelsAtTheNextCheck) {
  // At the start, after the chunks and before the Hausdorff distance: the stage must notice the
  // token (the callback never asks to stop).
  for (const double at : {0.0, 0.4, 0.7}) {
    qjulia::CancelToken token;
    qjulia::DecimateOptions opts;
    opts.faces = 20000;
    opts.cancel = &token;
    double last = -1;
    opts.progress = fixtures::request_at(at, token, last);
    EXPECT_THROW(qjulia::decimate(fixtures::noisy_sphere(7), opts), qjulia::Cancelled) << at;
    EXPECT_EQ(last, at);
  }
}

// ---------------------------------------------------------------------------------------------
// The quality method (OpenMesh's Decimater).

namespace {
qjulia::DecimateOptions quality(std::optional<long long> faces, std::optional<double> max_error) {
  qjulia::DecimateOptions opts;
  opts.method = qjulia::DecimateMethod::kQuality;
  opts.faces = faces;
  opts.max_error = max_error;
  return opts;
}
}  // namespace

TEST(DecimateQuality, UnitSphereTo2000FacesStaysClosedManifoldAndOnTheSphere) {
  TriMesh sphere = fixtures::uv_sphere(128, 128);
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(sphere, quality(2000, std::nullopt), &rep);
  EXPECT_LE(out.face_count(), 2000u);
  EXPECT_GE(out.face_count(), 1990u);
  EXPECT_TRUE(rep.target_reached);
  EXPECT_TRUE(rep.closed);
  EXPECT_TRUE(rep.manifold);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  for (const auto& p : out.positions)  // input vertices: on the sphere
    EXPECT_NEAR(std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]), 1.0,
                1e-6);
  const double to_sphere = max_distance_to_unit_sphere(out);
  EXPECT_NEAR(rep.hausdorff, to_sphere, 0.25 * to_sphere + 2e-4);
}

TEST(DecimateQuality, MaxErrorBoundHoldsByIndependentDenseSampling) {
  TriMesh sphere = fixtures::uv_sphere(100, 100);
  const double input_error = 1.0 - std::cos(std::acos(-1.0) / 100);
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(sphere, quality(std::nullopt, 0.004), &rep);
  EXPECT_LT(out.face_count(), sphere.face_count() / 5);  // it did simplify
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  EXPECT_LE(rep.hausdorff, 0.004);
  EXPECT_TRUE(rep.target_reached);
  EXPECT_LE(max_distance_to_unit_sphere(out), 0.004 - input_error);
  double worst = 0;
  for (std::size_t v = 0; v < sphere.positions.size(); v += 3)
    worst = std::max(worst, point_mesh(at(sphere, uint32_t(v)), out));
  EXPECT_LE(worst, 0.004);
}

TEST(DecimateQuality, KeepsTheGenusOfATorusDecimatedHard) {
  const TriMesh torus = fixtures::torus(200, 100, 0.05);  // 40,000 faces, genus 1
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(torus, quality(400, std::nullopt), &rep);
  EXPECT_LE(out.face_count(), 400u);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 0);
}

TEST(DecimateQuality, KeepsTheGenusOfAFractalMesh) {
  const TriMesh mesh = classic_julia_64();
  const auto before = fixtures::check(mesh);
  ASSERT_TRUE(before.closed_manifold_oriented);
  const auto budget = static_cast<long long>(mesh.face_count() / 5);
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(mesh, quality(budget, std::nullopt), &rep);
  EXPECT_LE(static_cast<long long>(out.face_count()), budget);
  EXPECT_TRUE(rep.target_reached);
  const auto after = fixtures::check(out);
  EXPECT_TRUE(after.closed_manifold_oriented);
  EXPECT_EQ(after.euler, before.euler);
  EXPECT_NEAR(fixtures::volume(out), fixtures::volume(mesh), 0.02 * fixtures::volume(mesh));
}

TEST(DecimateQuality, LeavesANonManifoldPartAsItIsAndPrintsNothing) {
  // Two spheres touching in one vertex: that vertex is non-manifold. Its faces are kept as
  // they are, the rest is decimated, and OpenMesh's complaints never reach stderr.
  TriMesh m = fixtures::uv_sphere(40, 40);
  TriMesh other = fixtures::uv_sphere(40, 40);
  const uint32_t north = 0, offset = static_cast<uint32_t>(m.positions.size());
  for (auto& p : other.positions) p[2] += 2.0f;  // its south pole lands on the north pole
  fixtures::append(m, other);
  const uint32_t south = offset + static_cast<uint32_t>(other.positions.size()) - 1;
  for (auto& t : m.triangles)
    for (auto& v : t)
      if (v == south) v = north;
  testing::internal::CaptureStderr();
  qjulia::DecimateReport rep;
  TriMesh out = qjulia::decimate(m, quality(600, std::nullopt), &rep);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_LE(out.face_count(), 600u);
  EXPECT_TRUE(rep.closed);
  std::size_t around_north = 0;
  for (const auto& t : out.triangles)
    around_north += t[0] == north || t[1] == north || t[2] == north;
  EXPECT_EQ(around_north, 80u);  // both fans of the pinch, unchanged
}

TEST(DecimateQuality, ResultDependsOnlyOnTheInputNotOnTheThreads) {
  const TriMesh bumpy = fixtures::noisy_sphere(4);
  qjulia::DecimateReport one, two;
  const TriMesh a = decimate_on(1, bumpy, quality(1000, 0.03), &one);
  const TriMesh b = decimate_on(2, bumpy, quality(1000, 0.03), &two);
  EXPECT_LT(a.face_count(), bumpy.face_count() / 2);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(one.hausdorff, two.hausdorff);
}

TEST(DecimateQuality, ATokenRequestedDuringTheCollapsesCancels) {
  qjulia::CancelToken token;
  auto opts = quality(1000, std::nullopt);
  opts.cancel = &token;
  opts.progress = [&](double f) {
    if (f > 0.1) token.request();  // during the collapses (they report 0 to 0.4)
    return true;
  };
  EXPECT_THROW(qjulia::decimate(fixtures::noisy_sphere(6), opts), qjulia::Cancelled);
}
