// Decimation's error measure: sampled two-sided Hausdorff distance through the shared BVH.
#include "mesh/hausdorff.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "base/geometry.h"

namespace qjulia::detail {

namespace {

using Point = std::array<float, 3>;

/// Mean length of a sample of the edges of `m` (the first edge of every 11th face).
double typical_edge(const TriMesh& m) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t f = 0; f < m.triangles.size(); f += 11, ++n) {
    const auto& t = m.triangles[f];
    sum += length(to_vec3d(m.positions[t[1]]) - to_vec3d(m.positions[t[0]]));
  }
  return n ? sum / n : 0;
}

/// Every `stride`-th referenced vertex of `m`.
std::vector<Point> vertex_samples(const TriMesh& m, std::size_t max_samples) {
  const std::size_t nv = m.positions.size();
  std::vector<uint8_t> used(nv, 0);  // unreferenced vertices are not part of the surface
  for (const auto& t : m.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  const std::size_t stride = std::max<std::size_t>(1, (nv + max_samples - 1) / max_samples);
  std::vector<Point> points;
  for (std::size_t v = 0; v < nv; v += stride)
    if (used[v]) points.push_back(m.positions[v]);
  return points;
}

/// Barycentric grid points of level[f] on every `stride`-th face of `m`
/// ((n + 1)(n + 2) / 2 points on a face of level n, corners included).
std::vector<Point> face_samples(const TriMesh& m, const std::vector<uint8_t>& level,
                                std::size_t stride) {
  std::vector<Point> points;
  for (std::size_t f = 0; f < m.triangles.size(); f += stride) {
    const auto& t = m.triangles[f];
    const Vec3d a = to_vec3d(m.positions[t[0]]), b = to_vec3d(m.positions[t[1]]),
                c = to_vec3d(m.positions[t[2]]);
    const int n = level[f];
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Vec3d p = a + (double(i) / n) * (b - a) + (double(j) / n) * (c - a);
        points.push_back({float(p[0]), float(p[1]), float(p[2])});
      }
  }
  return points;
}

/// The samples of `from` against a surface of typical edge `to_edge`: its vertices when it is at
/// least as fine, else points on its faces at about that spacing; at most about max_samples.
std::vector<Point> samples(const TriMesh& from, double to_edge, std::size_t max_samples) {
  const std::size_t nf = from.triangles.size();
  std::vector<uint8_t> level(nf, 1);
  std::size_t total = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = from.triangles[f];
    const Vec3d a = to_vec3d(from.positions[t[0]]), b = to_vec3d(from.positions[t[1]]),
                c = to_vec3d(from.positions[t[2]]);
    const double longest = std::max({length(b - a), length(c - b), length(a - c)});
    const int n =
        to_edge > 0 ? std::clamp(static_cast<int>(std::ceil(longest / to_edge)), 1, 8) : 1;
    level[f] = static_cast<uint8_t>(n);
    total += static_cast<std::size_t>((n + 1) * (n + 2) / 2);
  }
  if (total <= 3 * nf) return vertex_samples(from, max_samples);
  return face_samples(from, level,
                      std::max<std::size_t>(1, (total + max_samples - 1) / max_samples));
}

/// Max distance from the samples of `from` to the surface in `to_tree` (of typical edge
/// `to_edge`).
double one_sided(const TriMesh& from, const TriangleBvh& to_tree, double to_edge,
                 const HausdorffOptions& opts) {
  if (from.triangles.empty()) return 0;  // an empty `to` gives infinity
  const std::vector<float> d =
      to_tree.distances(samples(from, to_edge, opts.max_samples), opts.cancel);
  return d.empty() ? 0.0 : *std::max_element(d.begin(), d.end());
}

}  // namespace

Hausdorff::Hausdorff(const TriMesh& a, const HausdorffOptions& opts) : a_(a), opts_(opts) {}
Hausdorff::~Hausdorff() = default;

HausdorffResult Hausdorff::to(const TriMesh& b) {
  HausdorffResult r;
  {
    const TriangleBvh b_tree(b.positions, b.triangles);
    r.a_to_b = one_sided(a_, b_tree, typical_edge(b), opts_);
  }
  if (!a_tree_) a_tree_ = std::make_unique<TriangleBvh>(a_.positions, a_.triangles);
  r.b_to_a = one_sided(b, *a_tree_, typical_edge(a_), opts_);
  return r;
}

}  // namespace qjulia::detail
