#include "qjulia/surface/extract.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <tuple>

#include "grid/grid_impl.h"
#include "qjulia/field/classify.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

using detail::pack;
using detail::unpack;
using openvdb::Coord;

// Cube corner d sits at offset (d & 1, d >> 1 & 1, d >> 2 & 1).
int bit(int d, int axis) { return (d >> axis) & 1; }

// The twelve cube edges as (lower corner, axis), and the four corners of each face in cyclic
// order with the face's outward normal axis and side.
struct CubeTables {
  std::array<int, 12> edge_corner{};
  std::array<int, 12> edge_axis{};
  std::array<std::array<int, 4>, 6> face_corners{};
  std::array<int, 6> face_axis{}, face_side{};
  std::array<std::array<int, 8>, 8> edge_of{};  // corner pair -> edge, -1 if not an edge
  std::array<std::array<bool, 12>, 12> share_face{};

  CubeTables() {
    for (auto& row : edge_of) row.fill(-1);
    int e = 0;
    for (int axis = 0; axis < 3; ++axis)
      for (int d = 0; d < 8; ++d)
        if (!bit(d, axis)) {
          edge_corner[e] = d;
          edge_axis[e] = axis;
          edge_of[d][d | (1 << axis)] = edge_of[d | (1 << axis)][d] = e;
          ++e;
        }
    int f = 0;
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const int base = side << axis;
        face_corners[f] = {base, base | (1 << u), base | (1 << u) | (1 << v), base | (1 << v)};
        face_axis[f] = axis;
        face_side[f] = side;
        ++f;
      }
    for (int f2 = 0; f2 < 6; ++f2)
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
          const int ea = edge_of[face_corners[f2][a]][face_corners[f2][(a + 1) % 4]];
          const int eb = edge_of[face_corners[f2][b]][face_corners[f2][(b + 1) % 4]];
          share_face[ea][eb] = true;
        }
  }
};

const CubeTables& tables() {
  static const CubeTables t;
  return t;
}

std::uint64_t edge_key(const Coord& cell, int e) {
  const auto& t = tables();
  const int d = t.edge_corner[e];
  return (pack(cell.x() + bit(d, 0), cell.y() + bit(d, 1), cell.z() + bit(d, 2)) << 2) |
         static_cast<std::uint64_t>(t.edge_axis[e]);
}

// Reads sampled values, computing the virtual ones.
class Values {
 public:
  Values(const SampledGrid::Impl& impl, const Solid& solid)
      : impl_(impl), solid_(solid), acc_(impl.grid->getConstAccessor()) {}
  float operator()(int i, int j, int k) const {
    return detail::point_value(impl_.geometry, solid_, acc_, i, j, k);
  }

 private:
  const SampledGrid::Impl& impl_;
  const Solid& solid_;
  openvdb::FloatGrid::ConstAccessor acc_;
};

// Vertices keep this fraction of an edge away from its ends.
constexpr double kEndMargin = 1e-3;

struct Vec3 {
  double x, y, z;
};

// Moves a vertex onto the solid's boundary along the segment a (value fa) -> b (value fb), one
// end inside (<= 0) and one outside: false position (Illinois) against the exact classifier,
// so the final bracket always holds the boundary.
Vec3 refine(const Solid& solid, const Vec3& a, float fa, const Vec3& b, float fb, double tol_t,
            int max_steps, std::uint64_t* evaluations) {
  auto at = [&](double t) {
    return Vec3{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)};
  };
  double lo = 0, hi = 1;  // lo keeps the sign of a, hi the sign of b
  double flo = fa, fhi = fb;
  const bool a_inside = fa <= 0;
  // An end outside only because of the box or a clip plane: the boundary is the plane when
  // the point on it is inside, which makes caps exactly flat.
  const Vec3& out = a_inside ? b : a;
  if (solid.constraint(out.x, out.y, out.z) > 0) {
    const Vec3& in = a_inside ? a : b;
    double cl = 0, ch = 1;  // constraint crossing from `in` (<= 0) to `out` (> 0), exact enough
    for (int n = 0; n < 60; ++n) {
      const double m = 0.5 * (cl + ch);
      const Vec3 p{in.x + m * (out.x - in.x), in.y + m * (out.y - in.y), in.z + m * (out.z - in.z)};
      (solid.constraint(p.x, p.y, p.z) > 0 ? ch : cl) = m;
    }
    const double tc = a_inside ? cl : 1 - cl;
    const Vec3 pc = at(std::clamp(tc, kEndMargin, 1 - kEndMargin));
    ++*evaluations;
    const float fc = solid.field(pc.x, pc.y, pc.z);
    if (fc <= 0) return pc;
    // The fractal boundary comes first: refine between the inside end and the plane point.
    if (a_inside) {
      hi = tc;
      fhi = fc;
    } else {
      lo = tc;
      flo = fc;
    }
  }
  // False position, with a bisection step whenever the last step did not halve the bracket:
  // fast where the field is smooth, never slower than bisection where it is steep (h^2 has
  // F = 2^N log|h| inside).
  bool bisect = false;
  for (int step = 0; step < max_steps && hi - lo > tol_t; ++step) {
    const double width = hi - lo;
    double t = bisect ? 0.5 * (lo + hi) : (flo * hi - fhi * lo) / (flo - fhi);
    const double margin = 0.01 * width;
    if (!(t > lo + margin && t < hi - margin)) t = std::clamp(t, lo + margin, hi - margin);
    const Vec3 p = at(t);
    ++*evaluations;
    const float f = solid.field(p.x, p.y, p.z);
    if ((f <= 0) == (flo <= 0)) {
      lo = t;
      flo = f;
    } else {
      hi = t;
      fhi = f;
    }
    bisect = bisect || hi - lo > 0.5 * width;  // once steep, stay with bisection
  }
  double t = (flo * hi - fhi * lo) / (flo - fhi);
  if (!(t >= lo && t <= hi)) t = 0.5 * (lo + hi);
  // Never on a grid point: a vertex there would coincide with the vertices of the other edges
  // of that point and leave zero-area triangles.
  return at(std::clamp(t, kEndMargin, 1 - kEndMargin));
}

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

struct Chunk {
  std::vector<std::array<std::int64_t, 3>> triangles;  // >= 0 edge vertex, < 0 extra vertex
  std::vector<std::array<float, 3>> extra;             // centre vertices of awkward loops
  std::uint64_t evaluations = 0;
};

// Triangulates a loop of `len` (<= 12) cube edges so that no new edge joins two cube edges
// that share a face, by dynamic programming over sub-polygons. Writes loop positions (0..len-1)
// to `out`, three per triangle, counter-clockwise like the loop. Returns the triangle count, or
// 0 when no such triangulation exists.
int triangulate_loop(const int* loop, int len,
                     const std::array<std::array<bool, 12>, 12>& share_face, std::uint8_t* out) {
  auto allowed = [&](int i, int j) {
    return j - i == 1 || (i == 0 && j == len - 1) || !share_face[loop[i]][loop[j]];
  };
  // split[i][j]: a vertex k that makes (i, k, j) a triangle of a valid triangulation of the
  // sub-polygon i..j, or -1; for j - i == 1 the sub-polygon is a single edge.
  int split[12][12];
  for (int gap = 2; gap < len; ++gap)
    for (int i = 0; i + gap < len; ++i) {
      const int j = i + gap;
      split[i][j] = -1;
      if (!allowed(i, j)) continue;
      for (int k = i + 1; k < j && split[i][j] < 0; ++k)
        if ((k - i == 1 || split[i][k] >= 0) && (j - k == 1 || split[k][j] >= 0)) split[i][j] = k;
    }
  if (split[0][len - 1] < 0) return 0;
  int n = 0;
  int stack[24][2], top = 0;
  stack[top][0] = 0;
  stack[top++][1] = len - 1;
  while (top > 0) {
    const int i = stack[--top][0], j = stack[top][1];
    if (j - i < 2) continue;
    const int k = split[i][j];
    out[3 * n] = static_cast<std::uint8_t>(i);
    out[3 * n + 1] = static_cast<std::uint8_t>(k);
    out[3 * n + 2] = static_cast<std::uint8_t>(j);
    ++n;
    stack[top][0] = i;
    stack[top++][1] = k;
    stack[top][0] = k;
    stack[top++][1] = j;
  }
  return n;
}

// Moves the centre vertex of a loop onto the nearest boundary point found along the loop's
// normal and the 13 directions to a cube's neighbours, within half a voxel, else within a
// voxel; keeps it where none is found.
std::array<float, 3> project_centre(const Solid& solid, const Vec3& c, const Vec3& normal,
                                    double voxel, double tol_t, std::uint64_t* evaluations) {
  std::array<float, 3> out{static_cast<float>(c.x), static_cast<float>(c.y),
                           static_cast<float>(c.z)};
  // The loop's normal, then the 13 directions to the neighbours of a cube.
  Vec3 dirs[14];
  dirs[0] = normal;
  int nd = 1;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz)
        if (dx > 0 || (dx == 0 && (dy > 0 || (dy == 0 && dz > 0))))
          dirs[nd++] = {double(dx), double(dy), double(dz)};
  double best = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < 2 && !std::isfinite(best); ++pass)
    for (const Vec3& dir : dirs) {
      const double len = std::sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
      if (!(len > 0)) continue;
      const double d = (pass == 0 ? 0.5 : 1.0) * voxel / len;
      const Vec3 a{c.x - d * dir.x, c.y - d * dir.y, c.z - d * dir.z};
      const Vec3 b{c.x + d * dir.x, c.y + d * dir.y, c.z + d * dir.z};
      *evaluations += 2;
      const float fa = solid.field(a.x, a.y, a.z), fb = solid.field(b.x, b.y, b.z);
      if ((fa <= 0) == (fb <= 0)) continue;
      const Vec3 p = refine(solid, a, fa, b, fb, tol_t, 24, evaluations);
      const double dist = std::hypot(p.x - c.x, p.y - c.y, p.z - c.z);
      if (dist < best) {
        best = dist;
        out = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
      }
    }
  return out;
}

}  // namespace

TriMesh extract(const SampledGrid& grid, const Params& params, const ExtractOptions& opts,
                ExtractStats* stats) {
  const SampledGrid::Impl& impl = grid.impl();
  const auto& geo = impl.geometry;
  const Solid solid(params);
  const auto& t = tables();
  const auto& cells = impl.crossing;
  auto report = [&](double f) {
    if (opts.progress && !opts.progress(f)) throw Cancelled();
  };
  auto position = [&](int i, int j, int k) {
    return Vec3{geo.origin[0] + i * geo.voxel, geo.origin[1] + j * geo.voxel,
                geo.origin[2] + k * geo.voxel};
  };

  // 1. Every edge with a sign change is a vertex.
  std::vector<std::vector<std::uint64_t>> chunk_edges((cells.size() + 4095) / 4096);
  tbb::parallel_for(std::size_t{0}, chunk_edges.size(), [&](std::size_t c) {
    Values values(impl, solid);
    auto& out = chunk_edges[c];
    for (std::size_t n = c * 4096; n < std::min(cells.size(), (c + 1) * 4096); ++n) {
      const Coord cell = unpack(cells[n]);
      bool in[8];
      for (int d = 0; d < 8; ++d)
        in[d] = values(cell.x() + bit(d, 0), cell.y() + bit(d, 1), cell.z() + bit(d, 2)) <= 0;
      for (int e = 0; e < 12; ++e) {
        const int d0 = t.edge_corner[e], d1 = d0 | (1 << t.edge_axis[e]);
        if (in[d0] != in[d1]) out.push_back(edge_key(cell, e));
      }
    }
  });
  std::vector<std::uint64_t> edges;
  for (auto& c : chunk_edges) edges.insert(edges.end(), c.begin(), c.end());
  chunk_edges.clear();
  tbb::parallel_sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  report(0.1);

  // 2. Vertex positions, refined onto the boundary.
  TriMesh mesh;
  mesh.positions.resize(edges.size());
  std::atomic<std::uint64_t> evaluations{0};
  std::atomic<std::size_t> done{0};
  const double tol_t = opts.tolerance;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, edges.size(), 512),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      Values values(impl, solid);
                      std::uint64_t count = 0;
                      for (std::size_t n = r.begin(); n != r.end(); ++n) {
                        const int axis = static_cast<int>(edges[n] & 3);
                        const Coord a = unpack(edges[n] >> 2);
                        Coord b = a;
                        b[axis] += 1;
                        const Vec3 pa = position(a.x(), a.y(), a.z());
                        const Vec3 pb = position(b.x(), b.y(), b.z());
                        const Vec3 p = refine(solid, pa, values(a.x(), a.y(), a.z()), pb,
                                              values(b.x(), b.y(), b.z()), tol_t,
                                              opts.max_refine_steps, &count);
                        mesh.positions[n] = {static_cast<float>(p.x), static_cast<float>(p.y),
                                             static_cast<float>(p.z)};
                      }
                      evaluations += count;
                      done += r.size();
                    });
  report(0.7);

  // 3. Polygons: per cell, face segments oriented with the inside on their right (seen from
  // outside the cube), chained into loops, each loop a fan of triangles.
  const std::size_t chunk_size = 2048;
  std::vector<Chunk> chunks((cells.size() + chunk_size - 1) / chunk_size);
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t c) {
    Values values(impl, solid);
    Chunk& out = chunks[c];
    for (std::size_t n = c * chunk_size; n < std::min(cells.size(), (c + 1) * chunk_size); ++n) {
      const Coord cell = unpack(cells[n]);
      float v[8];
      for (int d = 0; d < 8; ++d)
        v[d] = values(cell.x() + bit(d, 0), cell.y() + bit(d, 1), cell.z() + bit(d, 2));
      int next_of[12];
      std::fill(std::begin(next_of), std::end(next_of), -1);
      for (int f = 0; f < 6; ++f) {
        const auto& fc = t.face_corners[f];
        bool in[4];
        int inside = 0;
        for (int q = 0; q < 4; ++q) inside += in[q] = v[fc[q]] <= 0;
        if (inside == 0 || inside == 4) continue;
        // The crossing edges of the face, in cyclic order: edge q joins corners q and q+1.
        int crossing[4], nc = 0;
        for (int q = 0; q < 4; ++q)
          if (in[q] != in[(q + 1) % 4]) crossing[nc++] = q;
        std::array<std::pair<int, int>, 2> segs;  // pairs of face edge slots
        int ns = 0;
        if (nc == 2) {
          segs[ns++] = {crossing[0], crossing[1]};
        } else {
          // Ambiguous face: the asymptotic decider of the bilinear interpolant, which both
          // cells sharing the face compute alike.
          const double a = v[fc[0]], b = v[fc[1]], cc = v[fc[2]], d = v[fc[3]];
          const double den = a + cc - b - d;
          const bool saddle_inside = den != 0 && (a * cc - b * d) / den <= 0;
          // Corner q is cut off by the segment of edges q-1 and q.
          const bool cut_inside = !saddle_inside;
          for (int q = 0; q < 4; ++q)
            if (in[q] == cut_inside) segs[ns++] = {(q + 3) % 4, q};
        }
        const int axis = t.face_axis[f];
        const double normal_sign = t.face_side[f] ? 1.0 : -1.0;
        for (int s = 0; s < ns; ++s) {
          int e1 = t.edge_of[fc[segs[s].first]][fc[(segs[s].first + 1) % 4]];
          int e2 = t.edge_of[fc[segs[s].second]][fc[(segs[s].second + 1) % 4]];
          // Midpoints of the edges and an inside corner, in cube-local coordinates.
          auto mid = [&](int e, int a2) {
            const int d0 = t.edge_corner[e];
            return a2 == t.edge_axis[e] ? 0.5 : static_cast<double>(bit(d0, a2));
          };
          // A corner on the inside of the segment: with two crossings any inside corner of the
          // face; a segment of an ambiguous face cuts off corner `second`, and when that corner
          // is outside, its neighbour is inside.
          int inside_corner = -1;
          if (nc == 4) {
            const int q = segs[s].second;
            inside_corner = fc[in[q] ? q : (q + 1) % 4];
          } else {
            for (int q = 0; q < 4 && inside_corner < 0; ++q)
              if (in[q]) inside_corner = fc[q];
          }
          double m1[3], dv[3], cv[3];
          for (int a2 = 0; a2 < 3; ++a2) {
            m1[a2] = mid(e1, a2);
            dv[a2] = mid(e2, a2) - m1[a2];
            cv[a2] = bit(inside_corner, a2) - m1[a2];
          }
          // (n x d) . c with n = normal_sign * e_axis.
          const int u = (axis + 1) % 3, w = (axis + 2) % 3;
          const double nxd_u = -normal_sign * dv[w];
          const double nxd_w = normal_sign * dv[u];
          const double left = nxd_u * cv[u] + nxd_w * cv[w];
          if (left > 0) std::swap(e1, e2);  // the inside must be on the right
          next_of[e1] = e2;
        }
      }
      // Chain the segments into loops.
      bool used[12] = {};
      for (int start = 0; start < 12; ++start) {
        if (next_of[start] < 0 || used[start]) continue;
        int loop[12], len = 0;
        for (int e = start; !used[e] && len < 12; e = next_of[e]) {
          used[e] = true;
          loop[len++] = e;
          if (next_of[e] < 0) break;
        }
        if (len < 3) continue;
        std::int64_t ids[12];
        for (int q = 0; q < len; ++q) {
          const std::uint64_t key = edge_key(cell, loop[q]);
          ids[q] = std::lower_bound(edges.begin(), edges.end(), key) - edges.begin();
        }
        // Triangulate the loop without a diagonal that joins two vertices of one cube face
        // (the neighbour cell could make the same edge); else around a centre vertex.
        std::array<std::uint8_t, 3 * 10> tris;
        const int ntris = triangulate_loop(loop, len, t.share_face, tris.data());
        if (ntris > 0) {
          for (int q = 0; q < ntris; ++q)
            out.triangles.push_back({ids[tris[3 * q]], ids[tris[3 * q + 1]], ids[tris[3 * q + 2]]});
        } else {
          Vec3 centre{0, 0, 0}, normal{0, 0, 0};
          for (int q = 0; q < len; ++q) {
            const auto& a = mesh.positions[ids[q]];
            const auto& b = mesh.positions[ids[(q + 1) % len]];
            centre.x += a[0] / len;
            centre.y += a[1] / len;
            centre.z += a[2] / len;
            // Newell's normal of the loop.
            normal.x += (double(a[1]) - b[1]) * (double(a[2]) + b[2]);
            normal.y += (double(a[2]) - b[2]) * (double(a[0]) + b[0]);
            normal.z += (double(a[0]) - b[0]) * (double(a[1]) + b[1]);
          }
          out.extra.push_back(
              project_centre(solid, centre, normal, geo.voxel, tol_t, &out.evaluations));
          const std::int64_t cid = -static_cast<std::int64_t>(out.extra.size());
          for (int q = 0; q < len; ++q) out.triangles.push_back({cid, ids[q], ids[(q + 1) % len]});
        }
      }
    }
  });
  report(0.9);
  for (const Chunk& c : chunks) {
    evaluations += c.evaluations;
    const std::int64_t base = static_cast<std::int64_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), c.extra.begin(), c.extra.end());
    for (const auto& tri : c.triangles) {
      std::array<std::uint32_t, 3> out;
      for (int q = 0; q < 3; ++q)
        out[q] = static_cast<std::uint32_t>(tri[q] >= 0 ? tri[q] : base - tri[q] - 1);
      mesh.triangles.push_back(out);
    }
  }
  compute_normals(mesh);
  if (opts.color != ColorMode::kNone) evaluations += colorize(mesh, solid, geo.voxel, opts.color);
  if (stats) stats->evaluations = evaluations;
  report(1.0);
  return mesh;
}

}  // namespace qjulia
