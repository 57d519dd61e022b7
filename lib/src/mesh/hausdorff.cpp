// Sample-based Hausdorff distance: a spatial hash of vertices and their stars.
#include "mesh/hausdorff.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/mesh_check.h"

namespace qjulia::detail {

namespace {

using V3 = std::array<double, 3>;
V3 d3(const std::array<float, 3>& p) { return {p[0], p[1], p[2]}; }
V3 operator-(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 operator+(const V3& a, const V3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 operator*(double s, const V3& a) { return {s * a[0], s * a[1], s * a[2]}; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/// Squared distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
double point_triangle_d2(const V3& p, const V3& a, const V3& b, const V3& c) {
  V3 ab = b - a, ac = c - a, ap = p - a;
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return dot(ap, ap);
  V3 bp = p - b;
  double d3v = dot(ab, bp), d4 = dot(ac, bp);
  if (d3v >= 0 && d4 <= d3v) return dot(bp, bp);
  double vc = d1 * d4 - d3v * d2;
  if (vc <= 0 && d1 >= 0 && d3v <= 0) {
    double v = d1 / (d1 - d3v);
    V3 q = p - (a + v * ab);
    return dot(q, q);
  }
  V3 cp = p - c;
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dot(cp, cp);
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    double w = d2 / (d2 - d6);
    V3 q = p - (a + w * ac);
    return dot(q, q);
  }
  double va = d3v * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3v) >= 0 && (d5 - d6) >= 0) {
    double w = (d4 - d3v) / ((d4 - d3v) + (d5 - d6));
    V3 q = p - (b + w * (c - b));
    return dot(q, q);
  }
  double denom = 1.0 / (va + vb + vc);
  double v = vb * denom, w = vc * denom;
  V3 q = p - (a + v * ab + w * ac);
  return dot(q, q);
}

/// Nearest-vertex locator: vertices hashed into cubic cells, and each vertex's faces.
class StarLocator {
 public:
  /// Meshes below this many faces are indexed by faces (exact distances); larger ones by
  /// vertices and their stars (cheaper to build).
  static constexpr std::size_t kFaceIndexLimit = 1'500'000;

  explicit StarLocator(const TriMesh& mesh)
      : mesh_(mesh),
        items_are_faces_(mesh.triangles.size() < kFaceIndexLimit),
        stars_(items_are_faces_ ? TriMesh{} : mesh) {
    const auto& pos = mesh.positions;
    double edge_sum = 0;
    std::size_t edge_n = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); f += 7) {  // a sample is enough
      const auto& t = mesh.triangles[f];
      V3 d = d3(pos[t[1]]) - d3(pos[t[0]]);
      edge_sum += std::sqrt(dot(d, d));
      ++edge_n;
    }
    lo_ = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
           std::numeric_limits<double>::max()};
    V3 hi = {-lo_[0], -lo_[1], -lo_[2]};
    for (const auto& p : pos)
      for (int k = 0; k < 3; ++k) {
        lo_[k] = std::min(lo_[k], double(p[k]));
        hi[k] = std::max(hi[k], double(p[k]));
      }
    double extent = std::max({hi[0] - lo_[0], hi[1] - lo_[1], hi[2] - lo_[2], 1e-30});
    cell_ = edge_n ? 1.2 * edge_sum / edge_n : extent;
    cell_ = std::max(cell_, extent / 1e6);  // keep cell coordinates within 21 bits
    for (auto& l : lo_) l -= cell_;
    if (items_are_faces_) {
      // A face goes into every cell its bounding box overlaps.
      for (uint32_t f = 0; f < mesh.triangles.size(); ++f) {
        const auto& t = mesh.triangles[f];
        int lo_c[3], hi_c[3];
        for (int k = 0; k < 3; ++k) {
          double a = std::min({pos[t[0]][k], pos[t[1]][k], pos[t[2]][k]});
          double b = std::max({pos[t[0]][k], pos[t[1]][k], pos[t[2]][k]});
          lo_c[k] = static_cast<int>((a - lo_[k]) / cell_);
          hi_c[k] = static_cast<int>((b - lo_[k]) / cell_);
        }
        for (int x = lo_c[0]; x <= hi_c[0]; ++x)
          for (int y = lo_c[1]; y <= hi_c[1]; ++y)
            for (int z = lo_c[2]; z <= hi_c[2]; ++z) entries_.push_back({pack(x, y, z), f});
      }
    } else {
      entries_.resize(pos.size());
      tbb::parallel_for(std::size_t(0), pos.size(), [&](std::size_t i) {
        entries_[i] = {key_of(d3(pos[i])), static_cast<uint32_t>(i)};
      });
      // Unreferenced vertices are not on the surface.
      entries_.erase(std::remove_if(entries_.begin(), entries_.end(),
                                    [&](const auto& e) {
                                      return stars_.offsets[e.second] ==
                                             stars_.offsets[e.second + 1];
                                    }),
                     entries_.end());
    }
    tbb::parallel_sort(entries_.begin(), entries_.end());
    // Open-addressing table: cell key -> first entry.
    std::size_t cap = 16;
    while (cap < 2 * entries_.size()) cap <<= 1;
    table_.assign(cap, {kEmpty, 0});
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      if (i > 0 && entries_[i].first == entries_[i - 1].first) continue;
      std::size_t h = hash(entries_[i].first) & (cap - 1);
      while (table_[h].first != kEmpty) h = (h + 1) & (cap - 1);
      table_[h] = {entries_[i].first, static_cast<uint32_t>(i)};
    }
  }

  /// Distance from p to the nearest face (small meshes) or to the faces around its nearest vertex
  /// (large meshes; an upper bound, off by at most about an edge length). Infinity when empty.
  double distance(const V3& p) const {
    if (entries_.empty()) return std::numeric_limits<double>::infinity();
    int c[3];
    double wall = cell_;  // distance from p to the walls of its own cell
    for (int k = 0; k < 3; ++k) {
      const double u = (p[k] - lo_[k]) / cell_;
      c[k] = static_cast<int>(std::floor(u));
      wall = std::min({wall, (u - c[k]) * cell_, (c[k] + 1 - u) * cell_});
    }
    double best = std::numeric_limits<double>::max();
    uint32_t best_v = 0;
    // Shell r holds every vertex closer than r * cell; stop once the best is that close.
    for (int r = 0; r < 64; ++r) {
      for (int dx = -r; dx <= r; ++dx)
        for (int dy = -r; dy <= r; ++dy)
          for (int dz = -r; dz <= r; ++dz) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
            int x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
            if (x < 0 || y < 0 || z < 0 || x >= (1 << 21) || y >= (1 << 21) || z >= (1 << 21))
              continue;
            // Skip cells farther than the best so far.
            double box2 = 0;
            const int cc[3] = {x, y, z};
            for (int k = 0; k < 3; ++k) {
              const double a = lo_[k] + cc[k] * cell_, b = a + cell_;
              const double d = p[k] < a ? a - p[k] : (p[k] > b ? p[k] - b : 0.0);
              box2 += d * d;
            }
            if (box2 >= best) continue;
            uint64_t key = pack(x, y, z);
            std::size_t h = hash(key) & (table_.size() - 1);
            while (table_[h].first != kEmpty && table_[h].first != key)
              h = (h + 1) & (table_.size() - 1);
            if (table_[h].first == kEmpty) continue;
            for (std::size_t i = table_[h].second; i < entries_.size() && entries_[i].first == key;
                 ++i) {
              double d2;
              if (items_are_faces_) {
                const auto& t = mesh_.triangles[entries_[i].second];
                d2 = point_triangle_d2(p, d3(mesh_.positions[t[0]]), d3(mesh_.positions[t[1]]),
                                       d3(mesh_.positions[t[2]]));
              } else {
                V3 d = d3(mesh_.positions[entries_[i].second]) - p;
                d2 = dot(d, d);
              }
              if (d2 < best) {
                best = d2;
                best_v = entries_[i].second;
              }
            }
          }
      const double reach = r * cell_ + wall;  // every item closer than this has been seen
      if (best <= reach * reach) break;
    }
    if (items_are_faces_) return std::sqrt(best);
    double d2 = best;
    for (uint32_t k = stars_.offsets[best_v]; k < stars_.offsets[best_v + 1]; ++k) {
      const auto& t = mesh_.triangles[stars_.faces[k]];
      d2 = std::min(d2, point_triangle_d2(p, d3(mesh_.positions[t[0]]), d3(mesh_.positions[t[1]]),
                                          d3(mesh_.positions[t[2]])));
    }
    return std::sqrt(d2);
  }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t(0);
  static uint64_t pack(uint64_t x, uint64_t y, uint64_t z) { return (x << 42) | (y << 21) | z; }
  static std::size_t hash(uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    return static_cast<std::size_t>(k);
  }
  uint64_t key_of(const V3& p) const {
    uint64_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = static_cast<uint64_t>(std::min((p[k] - lo_[k]) / cell_, double((1 << 21) - 1)));
    return pack(c[0], c[1], c[2]);
  }

  const TriMesh& mesh_;
  bool items_are_faces_;
  VertexFaces stars_;
  V3 lo_{};
  double cell_ = 1;
  std::vector<std::pair<uint64_t, uint32_t>> entries_;
  std::vector<std::pair<uint64_t, uint32_t>> table_;
};

/// Max distance from samples of `from` (its referenced vertices plus points on its faces, at
/// about the spacing of `to`'s edges) to `to`.
double one_sided(const TriMesh& from, const TriMesh& to, std::size_t max_samples) {
  if (from.triangles.empty()) return 0;
  StarLocator locator(to);
  // Typical edge of `to`, to choose the face sampling density.
  double to_edge = 0;
  {
    std::size_t n = 0;
    for (std::size_t f = 0; f < to.triangles.size(); f += 11, ++n) {
      const auto& t = to.triangles[f];
      V3 d = d3(to.positions[t[1]]) - d3(to.positions[t[0]]);
      to_edge += std::sqrt(dot(d, d));
    }
    to_edge = n ? to_edge / n : 0;
  }
  // Per-face barycentric sampling level n: (n+1)(n+2)/2 points including corners.
  const std::size_t nf = from.triangles.size();
  std::vector<uint8_t> level(nf, 1);
  std::size_t total = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = from.triangles[f];
    V3 a = d3(from.positions[t[0]]), b = d3(from.positions[t[1]]), c = d3(from.positions[t[2]]);
    double len = std::max(
        {std::sqrt(dot(b - a, b - a)), std::sqrt(dot(c - b, c - b)), std::sqrt(dot(a - c, a - c))});
    int n = to_edge > 0 ? static_cast<int>(std::ceil(len / to_edge)) : 1;
    n = std::clamp(n, 1, 8);
    level[f] = static_cast<uint8_t>(n);
    total += static_cast<std::size_t>((n + 1) * (n + 2) / 2);
  }
  if (total <= 3 * nf) {
    // `from` is at least as fine as `to`: its vertices are the samples (strided to the budget).
    const std::size_t nv = from.positions.size();
    std::vector<uint8_t> used(nv, 0);  // unreferenced vertices are not part of the surface
    for (const auto& t : from.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
    const std::size_t vstride = std::max<std::size_t>(1, (nv + max_samples - 1) / max_samples);
    tbb::combinable<double> worst(0.0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
      double& w = worst.local();
      for (std::size_t v = r.begin(); v != r.end(); ++v)
        if (v % vstride == 0 && used[v]) w = std::max(w, locator.distance(d3(from.positions[v])));
    });
    return worst.combine([](double x, double y) { return std::max(x, y); });
  }
  // Over budget: sample a strided subset of faces.
  const std::size_t stride = std::max<std::size_t>(1, (total + max_samples - 1) / max_samples);
  tbb::combinable<double> worst(0.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 1024), [&](const auto& r) {
    double& w = worst.local();
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      if (f % stride) continue;
      const auto& t = from.triangles[f];
      V3 a = d3(from.positions[t[0]]), b = d3(from.positions[t[1]]), c = d3(from.positions[t[2]]);
      const int n = level[f];
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
          double u = double(i) / n, v = double(j) / n;
          V3 p = a + u * (b - a) + v * (c - a);
          w = std::max(w, locator.distance(p));
        }
    }
  });
  return worst.combine([](double x, double y) { return std::max(x, y); });
}

}  // namespace

HausdorffResult hausdorff_distance(const TriMesh& a, const TriMesh& b,
                                   const HausdorffOptions& opts) {
  HausdorffResult r;
  r.a_to_b = one_sided(a, b, opts.max_samples);
  r.b_to_a = one_sided(b, a, opts.max_samples);
  return r;
}

}  // namespace qjulia::detail
