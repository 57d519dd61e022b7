#include "surface/color.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>
#include <vector>

namespace qjulia::detail {
namespace {

// A colour ramp over [0, 1] (dark blue, teal, yellow), linear RGB.
std::array<float, 3> ramp(double x) {
  static const float stops[4][3] = {
      {0.05f, 0.05f, 0.35f}, {0.0f, 0.45f, 0.55f}, {0.55f, 0.8f, 0.2f}, {1.0f, 0.9f, 0.1f}};
  x = std::clamp(x, 0.0, 1.0) * 3;
  const int i = std::min(2, static_cast<int>(x));
  const float f = static_cast<float>(x - i);
  return {stops[i][0] + f * (stops[i + 1][0] - stops[i][0]),
          stops[i][1] + f * (stops[i + 1][1] - stops[i][1]),
          stops[i][2] + f * (stops[i + 1][2] - stops[i][2])};
}

// Per-vertex colours from the orbit of a point one voxel off the surface. kIterations: the
// continuous count of a point just outside (how late it escapes / converges) on a ramp.
// kBasin: which attractor the orbit reached, from just outside for the cut-off method (the
// orbit converges there) and just inside for the escape method (it stays bounded).
}  // namespace

std::uint64_t colorize(TriMesh& mesh, const Solid& solid, double voxel, ColorMode mode) {
  const Classifier& cls = solid.classifier();
  const Params& p = cls.params();
  const bool outward = mode == ColorMode::kIterations || p.method == Method::kCutoff;
  const double offset = (outward ? 1.0 : -1.0) * voxel;
  std::vector<Orbit> orbits(mesh.positions.size());
  tbb::parallel_for(std::size_t{0}, mesh.positions.size(), [&](std::size_t n) {
    const auto& x = mesh.positions[n];
    const auto& nn = mesh.normals[n];
    orbits[n] = cls.orbit(x[0] + offset * nn[0], x[1] + offset * nn[1], x[2] + offset * nn[2]);
  });
  mesh.colors.resize(mesh.positions.size());
  if (mode == ColorMode::kIterations) {
    for (std::size_t n = 0; n < orbits.size(); ++n) {
      // F is in (0, N + 1] outside: small F = a late exit = close to the set.
      mesh.colors[n] = ramp(1.0 - orbits[n].field / (p.iterations + 1));
    }
    return orbits.size();
  }
  // Basins: cluster the final iterates of converged / bounded orbits; unconverged or escaped
  // orbits get grey. An attractor is identified by its real part and the length of its
  // imaginary part: a map with real coefficients has whole spheres of attractors (rotations of
  // a complex root about the real axis), which are one basin, as in the complex picture.
  std::vector<Quat> attractors;
  const double tol = std::max(10 * p.bailout, 1e-3);
  std::vector<int> basin(orbits.size(), -1);
  for (std::size_t n = 0; n < orbits.size(); ++n) {
    const bool settled =
        p.method == Method::kCutoff ? orbits[n].exit_step >= 0 : orbits[n].exit_step < 0;
    if (!settled || !is_finite(orbits[n].last)) continue;
    const Quat& q = orbits[n].last;
    const Quat key{q.w, std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z), 0, 0};
    int found = -1;
    for (std::size_t a = 0; a < attractors.size() && found < 0; ++a)
      if (abs(attractors[a] - key) < tol) found = static_cast<int>(a);
    if (found < 0 && attractors.size() < 64) {
      attractors.push_back(key);
      found = static_cast<int>(attractors.size()) - 1;
    }
    basin[n] = found;
  }
  // Order the attractors so colours do not depend on vertex order.
  std::vector<int> order(attractors.size());
  for (std::size_t a = 0; a < order.size(); ++a) order[a] = static_cast<int>(a);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const Quat &qa = attractors[a], &qb = attractors[b];
    return std::tie(qa.w, qa.x, qa.y, qa.z) < std::tie(qb.w, qb.x, qb.y, qb.z);
  });
  std::vector<int> rank(order.size());
  for (std::size_t r = 0; r < order.size(); ++r) rank[order[r]] = static_cast<int>(r);
  static const float palette[8][3] = {
      {0.85f, 0.2f, 0.15f}, {0.15f, 0.55f, 0.85f}, {0.2f, 0.7f, 0.3f},  {0.9f, 0.7f, 0.1f},
      {0.6f, 0.3f, 0.75f},  {0.1f, 0.7f, 0.7f},    {0.9f, 0.45f, 0.6f}, {0.5f, 0.5f, 0.2f}};
  for (std::size_t n = 0; n < orbits.size(); ++n) {
    if (basin[n] < 0) {
      mesh.colors[n] = {0.6f, 0.6f, 0.6f};
    } else {
      const float* c = palette[rank[basin[n]] % 8];
      mesh.colors[n] = {c[0], c[1], c[2]};
    }
  }
  return orbits.size();
}

}  // namespace qjulia::detail
