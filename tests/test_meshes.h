#pragma once
// Meshes built in code for the tests and benchmarks (spheres, boxes, noisy spheres), and a
// small independent topology checker (the tests do not rely on the library's own checks).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace fixtures {

using qjulia::TriMesh;

/// UV sphere: `rings` latitude bands, `segments` longitudes; 2*segments*(rings-1) faces,
/// outward, closed, manifold.
inline TriMesh uv_sphere(int rings, int segments, double radius = 1.0,
                         std::array<double, 3> center = {0, 0, 0}) {
  TriMesh m;
  const double pi = std::acos(-1.0);
  auto add = [&](double x, double y, double z) {
    m.positions.push_back({float(center[0] + radius * x), float(center[1] + radius * y),
                           float(center[2] + radius * z)});
  };
  add(0, 0, 1);  // north pole: 0
  for (int i = 1; i < rings; ++i) {
    double th = pi * i / rings;
    for (int j = 0; j < segments; ++j) {
      double ph = 2 * pi * j / segments;
      add(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    }
  }
  add(0, 0, -1);  // south pole
  const uint32_t south = uint32_t(m.positions.size() - 1);
  auto ring = [&](int i, int j) { return uint32_t(1 + (i - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  for (int j = 0; j < segments; ++j)
    m.triangles.push_back({south, ring(rings - 1, j + 1), ring(rings - 1, j)});
  return m;
}

/// Icosphere with 20 * 4^level faces, vertices on the unit sphere scaled by radius.
inline TriMesh icosphere(int level, double radius = 1.0, std::array<double, 3> center = {0, 0, 0}) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<std::array<double, 3>> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                          {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                          {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& q : p) {
    double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    for (auto& c : q) c /= n;
  }
  for (int l = 0; l < level; ++l) {
    std::unordered_map<uint64_t, uint32_t> mid;
    mid.reserve(f.size() * 2);
    auto midpoint = [&](uint32_t a, uint32_t b) {
      uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      std::array<double, 3> q{p[a][0] + p[b][0], p[a][1] + p[b][1], p[a][2] + p[b][2]};
      double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
      for (auto& c : q) c /= n;
      p.push_back(q);
      return mid[key] = uint32_t(p.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> g;
    g.reserve(f.size() * 4);
    for (const auto& tri : f) {
      uint32_t a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]),
               c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f.swap(g);
  }
  TriMesh m;
  m.triangles = f;
  for (const auto& q : p)
    m.positions.push_back({float(center[0] + radius * q[0]), float(center[1] + radius * q[1]),
                           float(center[2] + radius * q[2])});
  return m;
}

/// An icosphere whose radius is displaced by a sum of octaves of sines: a bumpy, fractal-like
/// closed surface for benchmarks.
inline TriMesh noisy_sphere(int level) {
  TriMesh m = icosphere(level);
  for (auto& p : m.positions) {
    double x = p[0], y = p[1], z = p[2], r = 1.0, amp = 0.08, freq = 3.0;
    for (int o = 0; o < 6; ++o) {
      r += amp * std::sin(freq * x + 1.3 * o) * std::sin(freq * y + 0.7 * o) *
           std::sin(freq * z + 2.1 * o);
      amp *= 0.5;
      freq *= 2.1;
    }
    for (auto& c : p) c = float(c * r);
  }
  return m;
}

/// A torus (major radius 1, minor radius 0.35 + bump * sin(5u) sin(7v)) tessellated as an n by m
/// grid of quads: 2nm faces, closed, genus 1 (Euler 0).
inline TriMesh torus(int n, int m, double bump = 0.0) {
  TriMesh t;
  const double pi = std::acos(-1.0);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double u = 2 * pi * i / n, v = 2 * pi * j / m;
      const double r = 0.35 + bump * std::sin(5 * u) * std::sin(7 * v);
      t.positions.push_back({float((1 + r * std::cos(v)) * std::cos(u)),
                             float((1 + r * std::cos(v)) * std::sin(u)), float(r * std::sin(v))});
    }
  auto id = [&](int i, int j) { return uint32_t((i % n) * m + (j % m)); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      t.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return t;
}

/// Axis-aligned box [lo, hi], 12 outward triangles.
inline TriMesh box(std::array<double, 3> lo, std::array<double, 3> hi) {
  TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back(
        {float(i & 1 ? hi[0] : lo[0]), float(i & 2 ? hi[1] : lo[1]), float(i & 4 ? hi[2] : lo[2])});
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

/// Appends b to a.
inline void append(TriMesh& a, const TriMesh& b) {
  const uint32_t off = uint32_t(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
}

/// Independent topology check: every undirected edge has exactly two faces traversing it in
/// opposite directions (closed, oriented, no non-manifold edge), and every vertex's faces
/// form one fan (its link is a single cycle).
struct Topology {
  bool closed_manifold_oriented = false;
  long long euler = 0;
  std::size_t components = 0;  ///< vertex-connected components of the faces
};

inline Topology check(const TriMesh& m) {
  Topology out;
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  std::set<uint32_t> verts;
  bool ok = true;
  for (const auto& t : m.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) ok = false;
    for (int k = 0; k < 3; ++k) {
      verts.insert(t[k]);
      if (++directed[{t[k], t[(k + 1) % 3]}] > 1) ok = false;
    }
  }
  std::size_t edges = 0;
  for (const auto& [e, n] : directed) {
    if (!directed.count({e.second, e.first})) ok = false;
    if (e.first < e.second) ++edges;
  }
  // Vertex links: next -> prev around each vertex must be one cycle.
  std::vector<std::map<uint32_t, uint32_t>> link(m.positions.size());
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) link[t[k]][t[(k + 1) % 3]] = t[(k + 2) % 3];
  for (uint32_t v : verts) {
    const auto& l = link[v];
    if (l.empty()) continue;
    uint32_t start = l.begin()->first, cur = start;
    std::size_t steps = 0;
    do {
      auto it = l.find(cur);
      if (it == l.end()) {
        ok = false;
        break;
      }
      cur = it->second;
      ++steps;
    } while (cur != start && steps <= l.size());
    if (steps != l.size()) ok = false;
  }
  out.closed_manifold_oriented = ok;
  out.euler = (long long)verts.size() - (long long)edges + (long long)m.triangles.size();
  std::vector<uint32_t> parent(m.positions.size());
  for (uint32_t v = 0; v < parent.size(); ++v) parent[v] = v;
  auto find = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& t : m.triangles) {
    parent[find(t[0])] = find(t[1]);
    parent[find(t[1])] = find(t[2]);
  }
  std::set<uint32_t> roots;
  for (const auto& t : m.triangles) roots.insert(find(t[0]));
  out.components = roots.size();
  return out;
}

/// A progress callback that requests `token` once the reported fraction reaches `at` and never
/// asks to stop itself (so a stage that stops must have checked the token); `last` receives the
/// last fraction reported.
inline qjulia::ProgressFn request_at(double at, qjulia::CancelToken& token, double& last) {
  return [at, &token, &last](double f) {
    last = f;
    if (f >= at) token.request();
    return true;
  };
}

/// Signed volume by the divergence theorem.
inline double volume(const TriMesh& m) {
  double v = 0;
  for (const auto& t : m.triangles) {
    const auto &a = m.positions[t[0]], &b = m.positions[t[1]], &c = m.positions[t[2]];
    v += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) +
         double(a[1]) * (double(b[2]) * c[0] - double(b[0]) * c[2]) +
         double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  return v / 6;
}

}  // namespace fixtures
