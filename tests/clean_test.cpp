// Tests of clean(), count_self_intersections() and printability().
#include "qjulia/mesh/clean.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "base/mesh_check.h"
#include "qjulia/base/error.h"
#include "qjulia/base/mesh.h"
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

TEST(Measure, CountsTheEdgesOfBrokenMeshesAsAPlainListOfHalfEdgesDoes) {
  // Spheres broken at random: holes, flipped and repeated faces, fins, random and repeated
  // corners; against the half-edges grouped in a map, and components joined by a plain
  // union-find.
  std::mt19937 rng(7);
  for (int it = 0; it < 120; ++it) {
    TriMesh m =
        it % 2 ? fixtures::icosphere(1 + it % 3) : fixtures::uv_sphere(4 + it % 5, 5 + it % 7);
    if (it % 3 == 0) fixtures::append(m, fixtures::icosphere(1, 0.1, {3, 0, 0}));
    const int defects = it < 6 ? 0 : 1 + static_cast<int>(rng() % 12);
    for (int d = 0; d < defects; ++d) {
      const std::size_t f = rng() % m.triangles.size();
      const auto v = static_cast<std::uint32_t>(rng() % m.positions.size());
      switch (rng() % 6) {
        case 0:
          if (m.triangles.size() > 4) m.triangles.erase(m.triangles.begin() + f);
          break;
        case 1:
          std::swap(m.triangles[f][0], m.triangles[f][1]);
          break;
        case 2:
          m.triangles.push_back(m.triangles[f]);
          break;
        case 3:
          m.triangles[f][rng() % 3] = v;
          break;
        case 4:
          m.triangles.push_back({m.triangles[f][0], m.triangles[f][1], v});
          break;
        default:
          m.triangles[f][1] = m.triangles[f][0];
      }
    }
    m.positions.push_back({9, 9, 9});  // referenced by no face
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::pair<std::size_t, bool>>>
        half;  // undirected edge: its faces and whether each goes from the lower end
    for (std::size_t f = 0; f < m.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = m.triangles[f][k], b = m.triangles[f][(k + 1) % 3];
        half[{std::min(a, b), std::max(a, b)}].push_back({f, a < b});
      }
    std::size_t boundary = 0, nonmanifold = 0, misoriented = 0;
    std::vector<char> open(m.triangles.size(), 0);
    for (const auto& [e, h] : half) {
      boundary += h.size() == 1;
      nonmanifold += h.size() > 2;
      misoriented += h.size() == 2 && h[0].second == h[1].second;
      if (h.size() != 2)
        for (const auto& fh : h) open[fh.first] = 1;
    }
    std::vector<std::uint32_t> root(m.positions.size());
    std::iota(root.begin(), root.end(), 0u);
    std::function<std::uint32_t(std::uint32_t)> find = [&](std::uint32_t x) {
      return root[x] == x ? x : root[x] = find(root[x]);
    };
    for (const auto& t : m.triangles) {
      root[find(t[0])] = find(t[1]);
      root[find(t[1])] = find(t[2]);
    }
    std::map<std::uint32_t, bool> closed;  // by root
    for (std::size_t f = 0; f < m.triangles.size(); ++f) {
      const std::uint32_t r = find(m.triangles[f][0]);
      if (!closed.count(r)) closed[r] = true;
      if (open[f]) closed[r] = false;
    }
    const qjulia::MeshMeasure mm = qjulia::measure(m);
    SCOPED_TRACE(it);
    EXPECT_EQ(mm.edges, half.size());
    EXPECT_EQ(mm.boundary_edges, boundary);
    EXPECT_EQ(mm.nonmanifold_edges, nonmanifold);
    EXPECT_EQ(mm.misoriented_edges, misoriented);
    ASSERT_EQ(mm.components.size(), closed.size());
    std::size_t closed_count = 0, closed_expected = 0;
    long long euler = 0;
    for (const auto& c : mm.components) {
      closed_count += c.closed;
      euler += c.euler;
    }
    for (const auto& [r, c] : closed) closed_expected += c;
    EXPECT_EQ(closed_count, closed_expected);
    EXPECT_EQ(euler, mm.euler);
    EXPECT_EQ(mm.euler, static_cast<long long>(mm.vertices) - static_cast<long long>(half.size()) +
                            static_cast<long long>(m.triangles.size()));
    // check_topology() leaves out the faces with a repeated index.
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<bool>> proper;
    std::size_t degenerate = 0;
    for (const auto& t : m.triangles) {
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
        ++degenerate;
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        proper[{std::min(a, b), std::max(a, b)}].push_back(a < b);
      }
    }
    std::size_t p_boundary = 0, p_nonmanifold = 0, p_misoriented = 0;
    std::set<std::uint32_t> rim;
    for (const auto& [e, h] : proper) {
      if (h.size() == 1) {
        ++p_boundary;
        rim.insert(e.first);
        rim.insert(e.second);
      }
      p_nonmanifold += h.size() > 2;
      p_misoriented += h.size() == 2 && h[0] == h[1];
    }
    const qjulia::detail::TopologyCheck tc = qjulia::detail::check_topology(m, true);
    EXPECT_EQ(tc.degenerate_faces, degenerate);
    EXPECT_EQ(tc.edges, proper.size());
    EXPECT_EQ(tc.boundary_edges, p_boundary);
    EXPECT_EQ(tc.nonmanifold_edges, p_nonmanifold);
    EXPECT_EQ(tc.misoriented_edges, p_misoriented);
    EXPECT_EQ(tc.boundary_vertices, std::vector<std::uint32_t>(rim.begin(), rim.end()));
  }
}

TEST(Measure, ASpeckFarFromTheFirstVertexKeepsItsVolumeToFullPrecision) {
  // A speck of radius 1e-3 about 56 units from the mesh's first vertex (on a unit sphere): taken
  // relative to that vertex, each face's volume term is about 1e5 times the speck's volume.
  TriMesh m = fixtures::icosphere(3);
  const TriMesh speck = fixtures::icosphere(2, 1e-3, {40, -30, 25});
  fixtures::append(m, speck);
  // The speck's volume from its own (float) positions, in long double about its first vertex.
  const auto& p0 = speck.positions[speck.triangles[0][0]];
  auto at = [&](std::uint32_t v) {
    std::array<long double, 3> r;
    for (int k = 0; k < 3; ++k) r[k] = (long double)speck.positions[v][k] - p0[k];
    return r;
  };
  long double exact = 0;
  for (const auto& t : speck.triangles) {
    const auto a = at(t[0]), b = at(t[1]), c = at(t[2]);
    exact += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
             a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  exact /= 6;
  ASSERT_GT(exact, 3e-9L);  // an inscribed polyhedron of the ball's 4.19e-9
  const qjulia::MeshMeasure mm = qjulia::measure(m);
  ASSERT_EQ(mm.components.size(), 2u);
  ASSERT_EQ(mm.components[1].faces, speck.triangles.size());
  EXPECT_NEAR(mm.components[1].volume, double(exact), 1e-12 * double(exact));
  EXPECT_NEAR(mm.volume, mm.components[0].volume + mm.components[1].volume, 1e-15);
  // An open component keeps its volume relative to the mesh's first vertex: one face of the
  // speck alone.
  TriMesh open = fixtures::icosphere(3);
  TriMesh face;
  face.positions = speck.positions;
  face.triangles = {speck.triangles[0]};
  fixtures::append(open, face);
  const qjulia::MeshMeasure om = qjulia::measure(open);
  ASSERT_EQ(om.components.size(), 2u);
  const auto& o = open.positions[open.triangles[0][0]];
  const auto& t = speck.triangles[0];
  std::array<std::array<long double, 3>, 3> c;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) c[i][k] = (long double)speck.positions[t[i]][k] - o[k];
  const long double det = (c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1]) -
                           c[0][1] * (c[1][0] * c[2][2] - c[1][2] * c[2][0]) +
                           c[0][2] * (c[1][0] * c[2][1] - c[1][1] * c[2][0])) /
                          6;
  EXPECT_FALSE(om.components[1].closed);
  EXPECT_NEAR(om.components[1].volume, double(det), 1e-9 * std::abs(double(det)));
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
