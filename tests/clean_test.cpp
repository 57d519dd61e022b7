// Tests of clean(), count_self_intersections() and printability().
#include "qjulia/mesh/clean.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>

#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"
#include "qjulia/mesh/print.h"
#include "test_meshes.h"

using qjulia::TriMesh;

namespace {
const double kPi = std::acos(-1.0);

/// Splits every vertex of `m` into one copy per face (a triangle soup).
TriMesh soup(const TriMesh& m) {
  TriMesh s;
  for (const auto& t : m.triangles) {
    const uint32_t base = uint32_t(s.positions.size());
    for (uint32_t v : t) s.positions.push_back(m.positions[v]);
    s.triangles.push_back({base, base + 1, base + 2});
  }
  return s;
}
}  // namespace

TEST(Clean, ClosedSphereIsUnchangedTopologically) {
  TriMesh sphere = fixtures::icosphere(4);
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(sphere, {}, &rep);
  EXPECT_EQ(out.face_count(), sphere.face_count());
  EXPECT_EQ(out.vertex_count(), sphere.vertex_count());
  EXPECT_EQ(rep.merged_vertices, 0u);
  EXPECT_EQ(rep.components_after, 1u);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_NEAR(fixtures::volume(out), fixtures::volume(sphere), 1e-9);
}

TEST(Clean, TriangleSoupIsWeldedBackIntoAClosedSphere) {
  TriMesh sphere = fixtures::icosphere(3);
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(soup(sphere), {}, &rep);
  EXPECT_EQ(out.vertex_count(), sphere.vertex_count());
  EXPECT_EQ(rep.merged_vertices, 3 * sphere.face_count() - sphere.vertex_count());
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  EXPECT_EQ(fixtures::check(out).euler, 2);
}

TEST(Clean, DustRemovalRemovesOnlyComponentsBelowTheThreshold) {
  // A unit sphere, 5 specks of radius 0.05 (volume ~5.2e-4) and 3 balls of radius 0.2
  // (~0.0335), all disjoint.
  TriMesh m = fixtures::icosphere(4);
  for (int i = 0; i < 5; ++i) fixtures::append(m, fixtures::icosphere(2, 0.05, {3.0 + i, 0, 0}));
  for (int i = 0; i < 3; ++i) fixtures::append(m, fixtures::icosphere(2, 0.2, {0, 3.0 + i, 0}));
  const double speck = 4.0 / 3.0 * kPi * std::pow(0.05, 3);
  const double ball = 4.0 / 3.0 * kPi * std::pow(0.2, 3);
  qjulia::CleanOptions opts;
  opts.min_component_volume = std::sqrt(speck * ball);  // between the two sizes
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(m, opts, &rep);
  EXPECT_EQ(rep.components_before, 9u);
  EXPECT_EQ(rep.components_after, 4u);
  EXPECT_EQ(rep.removed_components, 5u);
  EXPECT_EQ(rep.removed_faces, 5u * 320u);
  // The largest speck removed: an inscribed polyhedron, a little below the sphere's volume.
  EXPECT_GT(rep.largest_removed_volume, 0.9 * speck);
  EXPECT_LT(rep.largest_removed_volume, speck);
  EXPECT_EQ(out.face_count(), 5120u + 3u * 320u);
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  // The volume left is the big sphere plus the balls (inscribed polyhedra: a bit less).
  const double expected = 4.0 / 3.0 * kPi + 3 * ball;
  EXPECT_NEAR(fixtures::volume(out), expected, 0.02 * expected);
}

TEST(Clean, DefaultThresholdIsTwoCubicVoxels) {
  // voxel 0.1: threshold 0.002. A speck of radius 0.05 (5.2e-4) goes, one of 0.1 (4.2e-3) stays.
  TriMesh m = fixtures::icosphere(3);
  fixtures::append(m, fixtures::icosphere(2, 0.05, {3, 0, 0}));
  fixtures::append(m, fixtures::icosphere(2, 0.1, {0, 3, 0}));
  qjulia::CleanOptions opts;
  opts.voxel_size = 0.1;
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(m, opts, &rep);
  EXPECT_DOUBLE_EQ(rep.min_component_volume, qjulia::kDefaultDustVoxels * 1e-3);
  EXPECT_EQ(rep.removed_components, 1u);
  EXPECT_EQ(rep.components_after, 2u);
}

TEST(Clean, InnerCavityIsKeptByItsAbsoluteVolume) {
  // A hollow ball: outer sphere outward, inner sphere inward (negative volume).
  TriMesh m = fixtures::icosphere(3, 1.0);
  TriMesh inner = fixtures::icosphere(3, 0.5);
  for (auto& t : inner.triangles) std::swap(t[1], t[2]);
  fixtures::append(m, inner);
  qjulia::CleanOptions opts;
  opts.min_component_volume = 0.1;  // the cavity's |volume| ~0.52 is above it
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(m, opts, &rep);
  EXPECT_EQ(rep.components_after, 2u);
  EXPECT_NEAR(fixtures::volume(out), fixtures::volume(m), 1e-9);
}

TEST(Clean, RepeatedIndexFacesAndCollapsedEdgeAreRemovedKeepingItClosed) {
  // Collapse one edge of a closed sphere by giving its second vertex the first one's position:
  // welding turns the two faces on the edge into repeated-index faces.
  TriMesh m = fixtures::icosphere(3);
  const auto t0 = m.triangles[100];
  m.positions[t0[1]] = m.positions[t0[0]];
  // And add an explicit repeated-index face.
  m.triangles.push_back({t0[2], t0[2], t0[0]});
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(m, {}, &rep);
  EXPECT_EQ(rep.merged_vertices, 1u);
  EXPECT_EQ(rep.degenerate_faces_removed, 3u);
  EXPECT_EQ(out.face_count(), fixtures::icosphere(3).face_count() - 2);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
}

TEST(Clean, ZeroAreaCapIsFlippedAway) {
  // Move a vertex of a closed mesh onto the midpoint of the opposite edge of one of its faces.
  TriMesh m = fixtures::icosphere(2);
  const auto t = m.triangles[7];
  auto& p = m.positions[t[2]];
  const auto& a = m.positions[t[0]];
  const auto& b = m.positions[t[1]];
  for (int k = 0; k < 3; ++k) p[k] = 0.5f * (a[k] + b[k]);
  qjulia::CleanReport rep;
  TriMesh out = qjulia::clean(m, {}, &rep);
  EXPECT_GE(rep.degenerate_faces_flipped + rep.degenerate_faces_removed, 1u);
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  // No zero-area face is left.
  for (const auto& f : out.triangles) {
    const auto &x = out.positions[f[0]], &y = out.positions[f[1]], &z = out.positions[f[2]];
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(y[k]) - x[k];
      v[k] = double(z[k]) - x[k];
    }
    const double n =
        std::hypot(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]);
    EXPECT_GT(n, 1e-9);
  }
}

TEST(Clean, RejectsBadOptionsAndIndices) {
  TriMesh m = fixtures::icosphere(1);
  qjulia::CleanOptions opts;
  opts.min_component_volume = -1.0;
  EXPECT_THROW(qjulia::clean(m, opts), qjulia::InvalidInput);
  m.triangles.push_back({0, 1, 999});
  EXPECT_THROW(qjulia::clean(m), qjulia::InvalidInput);
}

TEST(SelfIntersections, SphereHasNoneAndTwoOverlappingSpheresHaveSome) {
  EXPECT_EQ(qjulia::count_self_intersections(fixtures::icosphere(3)), 0u);
  TriMesh two = fixtures::icosphere(3);
  fixtures::append(two, fixtures::icosphere(3, 1.0, {0.5, 0, 0}));
  EXPECT_GT(qjulia::count_self_intersections(two), 0u);
}

TEST(Printability, ReportsTopologyVolumeAndBoxInMillimetres) {
  TriMesh m = fixtures::box({0, 0, 0}, {10, 20, 30});  // mm
  qjulia::PrintabilityOptions opts;
  opts.check_self_intersections = true;
  auto r = qjulia::printability(m, opts);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.manifold);
  EXPECT_TRUE(r.oriented);
  EXPECT_TRUE(r.outward);
  EXPECT_EQ(r.components, 1u);
  ASSERT_TRUE(r.self_intersections.has_value());
  EXPECT_EQ(*r.self_intersections, 0u);
  EXPECT_NEAR(r.volume, 6000.0, 1e-6);
  ASSERT_TRUE(r.volume_cm3.has_value());
  EXPECT_NEAR(*r.volume_cm3, 6.0, 1e-9);
  EXPECT_NEAR(r.area, 2 * (200 + 600 + 300), 1e-6);
  EXPECT_DOUBLE_EQ(r.size[2], 30.0);
  EXPECT_TRUE(r.printable());
  // An open box is not closed.
  m.triangles.pop_back();
  r = qjulia::printability(m);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.boundary_edges, 3u);
  EXPECT_FALSE(r.printable());
}

TEST(Clean, ResultDependsOnlyOnTheInputNotOnTheThreads) {
  // A soup (every vertex welded), a collapsed edge, a zero-area cap and specks of dust.
  TriMesh m = soup(fixtures::noisy_sphere(5));
  for (int i = 0; i < 5; ++i) fixtures::append(m, fixtures::icosphere(2, 0.02, {3.0 + i, 0, 0}));
  m.positions[m.triangles[100][1]] = m.positions[m.triangles[100][0]];
  qjulia::CleanOptions opts;
  opts.min_component_volume = 1e-4;
  TriMesh out[3];
  qjulia::CleanReport rep[3];
  for (int threads = 1; threads <= 3; ++threads) {
    tbb::task_arena arena(threads);
    arena.execute([&] { out[threads - 1] = qjulia::clean(m, opts, &rep[threads - 1]); });
  }
  EXPECT_EQ(rep[0].removed_components, 5u);
  EXPECT_GT(rep[0].merged_vertices, 0u);
  for (int k = 1; k < 3; ++k) {
    EXPECT_EQ(out[0].positions, out[k].positions);
    EXPECT_EQ(out[0].triangles, out[k].triangles);
    EXPECT_EQ(rep[0].merged_vertices, rep[k].merged_vertices);
    EXPECT_EQ(rep[0].degenerate_faces_removed, rep[k].degenerate_faces_removed);
  }
}

TEST(Clean, ATokenRequestedDuringTheWorkCancelsAtTheNextCheck) {
  for (const double at : {0.0, 0.2, 0.5, 0.8}) {
    qjulia::CancelToken token;
    qjulia::CleanOptions opts;
    opts.cancel = &token;
    double last = -1;
    opts.progress = fixtures::request_at(at, token, last);
    EXPECT_THROW(qjulia::clean(fixtures::icosphere(4), opts), qjulia::Cancelled) << at;
    EXPECT_EQ(last, at);
  }
}

TEST(Printability, ARequestedTokenCancels) {
  qjulia::CancelToken token;
  token.request();
  qjulia::PrintabilityOptions opts;
  opts.cancel = &token;
  EXPECT_THROW(qjulia::printability(fixtures::icosphere(3), opts), qjulia::Cancelled);
}
