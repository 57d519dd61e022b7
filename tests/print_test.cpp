// Tests of scale_to_longest_side() and thicken().
#include "qjulia/mesh/print.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"
#include "test_meshes.h"

using qjulia::TriMesh;

namespace {
std::array<double, 3> extent(const TriMesh& m) {
  std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& p : m.positions)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
  return {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
}
}  // namespace

TEST(ScaleToLongestSide, GivesTheExactLength) {
  TriMesh m = fixtures::box({-1, 0, 2}, {2, 0.5, 3});  // longest side 3 along x
  const double s = qjulia::scale_to_longest_side(m, 80.0);
  EXPECT_DOUBLE_EQ(s, 80.0 / 3.0);
  auto e = extent(m);
  EXPECT_FLOAT_EQ(float(e[0]), 80.0f);
  EXPECT_NEAR(e[1], 0.5 * 80.0 / 3.0, 1e-4);
  // Scaling is about the origin.
  EXPECT_FLOAT_EQ(m.positions[0][0], float(-80.0 / 3.0));
  TriMesh sphere = fixtures::icosphere(3, 0.37, {5, 5, 5});
  qjulia::scale_to_longest_side(sphere, 120.0);
  e = extent(sphere);
  EXPECT_NEAR(std::max({e[0], e[1], e[2]}), 120.0, 120.0 * 1e-6);
}

TEST(ScaleToLongestSide, RejectsBadLengthsAndFlatMeshes) {
  TriMesh m = fixtures::box({0, 0, 0}, {1, 1, 1});
  EXPECT_THROW(qjulia::scale_to_longest_side(m, 0.0), qjulia::InvalidInput);
  EXPECT_THROW(qjulia::scale_to_longest_side(m, -3.0), qjulia::InvalidInput);
  TriMesh empty;
  EXPECT_THROW(qjulia::scale_to_longest_side(empty, 10.0), qjulia::InvalidInput);
  TriMesh point = m;
  for (auto& p : point.positions) p = {1, 1, 1};
  EXPECT_THROW(qjulia::scale_to_longest_side(point, 10.0), qjulia::InvalidInput);
}

TEST(Thicken, ThinSlabBecomesAtLeastMinThicknessThick) {
  TriMesh slab = fixtures::box({0, 0, 0}, {2, 2, 0.2});
  qjulia::ThickenOptions opts;
  opts.min_thickness = 0.5;
  TriMesh out = qjulia::thicken(slab, opts);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_GT(fixtures::volume(out), 0);
  EXPECT_GE(extent(out)[2], 0.5);
  // Thickness through the middle: the surface has points at least 0.5 apart along z near the
  // slab's centre.
  double zmin = 1e300, zmax = -1e300;
  for (const auto& p : out.positions)
    if (std::abs(p[0] - 1.0) < 0.3 && std::abs(p[1] - 1.0) < 0.3) {
      zmin = std::min(zmin, double(p[2]));
      zmax = std::max(zmax, double(p[2]));
    }
  EXPECT_GE(zmax - zmin, 0.5);
}

TEST(Thicken, ThickSphereKeepsItsVolume) {
  TriMesh sphere = fixtures::icosphere(5);
  qjulia::ThickenOptions opts;
  opts.min_thickness = 0.2;  // voxel 0.05
  TriMesh out = qjulia::thicken(sphere, opts);
  auto topo = fixtures::check(out);
  EXPECT_TRUE(topo.closed_manifold_oriented);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_NEAR(fixtures::volume(out), fixtures::volume(sphere), 0.03 * fixtures::volume(sphere));
  // Within about a voxel of the unit sphere everywhere.
  for (const auto& p : out.positions)
    EXPECT_NEAR(std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]), 1.0,
                0.05);
}

TEST(Thicken, ThinFinOnAThickBallIsThickenedAndTheBallKept) {
  TriMesh m = fixtures::icosphere(4);
  fixtures::append(m, fixtures::box({0.5, -0.5, -0.05}, {2.0, 0.5, 0.05}));  // 0.1 thick fin
  qjulia::ThickenOptions opts;
  opts.min_thickness = 0.3;
  TriMesh out = qjulia::thicken(m, opts);
  EXPECT_TRUE(fixtures::check(out).closed_manifold_oriented);
  // Fin tip region is now >= 0.3 thick in z.
  double zmin = 1e300, zmax = -1e300;
  for (const auto& p : out.positions)
    if (p[0] > 1.5 && p[0] < 1.8 && std::abs(p[1]) < 0.2) {
      zmin = std::min(zmin, double(p[2]));
      zmax = std::max(zmax, double(p[2]));
    }
  EXPECT_GE(zmax - zmin, 0.3);
  // The ball far from the fin is unchanged within about a voxel (0.075).
  for (const auto& p : out.positions) {
    if (p[0] < -0.3) {
      EXPECT_NEAR(std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]), 1.0,
                  0.08);
    }
  }
}

TEST(Thicken, RejectsNonPositiveThickness) {
  TriMesh m = fixtures::icosphere(1);
  qjulia::ThickenOptions opts;
  EXPECT_THROW(qjulia::thicken(m, opts), qjulia::InvalidInput);
  opts.min_thickness = -1;
  EXPECT_THROW(qjulia::thicken(m, opts), qjulia::InvalidInput);
}

TEST(Thicken, ATokenRequestedDuringTheWorkCancelsAtTheNextCheck) {
  // Requested after the distance field (0.2) and after the erosion (0.3): OpenVDB's tools are
  // interrupted through the token, and thicken throws.
  for (const double at : {0.0, 0.2, 0.3}) {
    qjulia::CancelToken token;
    qjulia::ThickenOptions opts;
    opts.min_thickness = 0.2;
    opts.cancel = &token;
    double last = -1;
    opts.progress = fixtures::request_at(at, token, last);
    EXPECT_THROW(qjulia::thicken(fixtures::icosphere(4), opts), qjulia::Cancelled) << at;
    EXPECT_EQ(last, at);
  }
}
