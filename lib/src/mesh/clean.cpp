#include "qjulia/mesh/clean.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>
#include <unordered_map>

#include "base/mesh_check.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"

namespace qjulia {

namespace {

using Vec3 = std::array<double, 3>;

Vec3 to_d(const std::array<float, 3>& p) { return {p[0], p[1], p[2]}; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

void report_progress(const ProgressFn& progress, double fraction) {
  if (progress && !progress(fraction)) throw Cancelled();
}

/// Maps every vertex to the first vertex with bit-identical position (after -0 -> +0).
/// Returns the number of vertices merged away.
std::size_t weld_exact(const TriMesh& mesh, std::vector<uint32_t>& remap) {
  const std::size_t nv = mesh.positions.size();
  auto bits = [&](uint32_t i) {
    std::array<uint32_t, 3> b;
    for (int k = 0; k < 3; ++k) {
      float x = mesh.positions[i][k] + 0.0f;  // -0 -> +0
      std::memcpy(&b[k], &x, 4);
    }
    return b;
  };
  std::vector<uint32_t> order(nv);
  std::iota(order.begin(), order.end(), 0u);
  tbb::parallel_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    auto ba = bits(a), bb = bits(b);
    return ba != bb ? ba < bb : a < b;
  });
  remap.resize(nv);
  std::size_t merged = 0;
  for (std::size_t i = 0; i < nv;) {
    std::size_t j = i + 1;
    const auto bi = bits(order[i]);
    while (j < nv && bits(order[j]) == bi) ++j;
    for (std::size_t k = i; k < j; ++k) remap[order[k]] = order[i];
    merged += j - i - 1;
    i = j;
  }
  return merged;
}

/// Zero-area faces with three distinct vertices: a needle (two nearly coincident vertices)
/// is collapsed; a cap (a vertex on the opposite edge) is removed by flipping that edge with
/// the neighbour, which keeps the surface and its topology. Returns {collapsed, flipped}.
std::pair<std::size_t, std::size_t> fix_zero_area(TriMesh& mesh) {
  auto& tris = mesh.triangles;
  const auto& pos = mesh.positions;
  constexpr double kZero = 1e-6;    // |cross| <= kZero * longest^2: zero in float precision
  constexpr double kNeedle = 1e-4;  // shortest <= kNeedle * longest is a needle
  std::vector<uint32_t> degenerate;
  for (uint32_t f = 0; f < tris.size(); ++f) {
    const auto& t = tris[f];
    Vec3 a = to_d(pos[t[0]]), b = to_d(pos[t[1]]), c = to_d(pos[t[2]]);
    Vec3 n = cross(sub(b, a), sub(c, a));
    double l2 =
        std::max({dot(sub(b, a), sub(b, a)), dot(sub(c, b), sub(c, b)), dot(sub(a, c), sub(a, c))});
    if (std::sqrt(dot(n, n)) <= kZero * l2) degenerate.push_back(f);
  }
  if (degenerate.empty()) return {0, 0};
  // Directed edge -> face.
  std::unordered_map<uint64_t, uint32_t> edge_face;
  edge_face.reserve(tris.size() * 3);
  auto key = [](uint64_t a, uint64_t b) { return (a << 32) | b; };
  for (uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) edge_face[key(tris[f][k], tris[f][(k + 1) % 3])] = f;
  std::vector<uint8_t> touched(tris.size(), 0);
  std::vector<uint32_t> merge(pos.size());
  std::iota(merge.begin(), merge.end(), 0u);
  std::size_t collapsed = 0, flipped = 0;
  for (uint32_t f : degenerate) {
    if (touched[f]) continue;
    const auto t = tris[f];
    double len[3];
    for (int k = 0; k < 3; ++k) {
      Vec3 d = sub(to_d(pos[t[(k + 1) % 3]]), to_d(pos[t[k]]));
      len[k] = std::sqrt(dot(d, d));  // edge k: t[k] -> t[k+1]
    }
    int longest = int(std::max_element(len, len + 3) - len);
    int shortest = int(std::min_element(len, len + 3) - len);
    if (len[shortest] <= kNeedle * len[longest]) {
      uint32_t a = t[shortest], b = t[(shortest + 1) % 3];
      if (merge[a] == a && merge[b] == b) {
        merge[std::max(a, b)] = std::min(a, b);
        touched[f] = 1;
        ++collapsed;
      }
      continue;
    }
    uint32_t a = t[longest], b = t[(longest + 1) % 3], m = t[(longest + 2) % 3];
    auto it = edge_face.find(key(b, a));
    if (it == edge_face.end() || touched[it->second]) continue;
    uint32_t g = it->second;
    const auto& tg = tris[g];
    uint32_t d = tg[0] + tg[1] + tg[2] - a - b;
    if (d == m || edge_face.count(key(m, d)) || edge_face.count(key(d, m))) continue;
    // New faces (a, d, m) and (d, b, m) must not be zero-area or folded.
    Vec3 pa = to_d(pos[a]), pb = to_d(pos[b]), pm = to_d(pos[m]), pd = to_d(pos[d]);
    Vec3 n1 = cross(sub(pd, pa), sub(pm, pa)), n2 = cross(sub(pb, pd), sub(pm, pd));
    if (dot(n1, n2) <= 0) continue;
    tris[f] = {a, d, m};
    tris[g] = {d, b, m};
    edge_face.erase(key(a, b));
    edge_face.erase(key(b, a));
    edge_face[key(a, d)] = f;
    edge_face[key(d, m)] = f;
    edge_face[key(m, a)] = f;
    edge_face[key(d, b)] = g;
    edge_face[key(b, m)] = g;
    edge_face[key(m, d)] = g;
    touched[f] = touched[g] = 1;
    ++flipped;
  }
  if (collapsed) {
    for (auto& t : tris)
      for (auto& v : t)
        while (merge[v] != v) v = merge[v];
  }
  return {collapsed, flipped};
}

}  // namespace

TriMesh clean(const TriMesh& input, const CleanOptions& opts, CleanReport* report) {
  if (opts.min_component_volume && !(*opts.min_component_volume >= 0))
    throw InvalidInput("clean: min_component_volume must be >= 0, got " +
                       std::to_string(*opts.min_component_volume));
  if (!(opts.voxel_size >= 0))
    throw InvalidInput("clean: voxel_size must be >= 0, got " + std::to_string(opts.voxel_size));
  validate_mesh(input, "clean");

  CleanReport rep;
  TriMesh mesh = input;
  report_progress(opts.progress, 0.0);

  // 1. Merge bit-identical vertices.
  std::vector<uint32_t> remap;
  rep.merged_vertices = weld_exact(mesh, remap);
  if (rep.merged_vertices)
    for (auto& t : mesh.triangles)
      for (auto& v : t) v = remap[v];
  report_progress(opts.progress, 0.2);

  // 2. Degenerate faces: repeated indices, fins, then zero-area faces (a few rounds: a flip
  // or collapse can expose another degenerate face).
  bool dirty = rep.merged_vertices > 0;
  for (const auto& t : mesh.triangles)
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) dirty = true;
  if (dirty) rep.degenerate_faces_removed += detail::drop_repeated_and_fins(mesh);
  for (int round = 0; round < 4; ++round) {
    auto [collapsed, flipped] = fix_zero_area(mesh);
    rep.degenerate_faces_flipped += flipped;
    if (collapsed) rep.degenerate_faces_removed += detail::drop_repeated_and_fins(mesh);
    if (!collapsed && !flipped) break;
  }
  report_progress(opts.progress, 0.5);

  // 3. Components below the volume threshold.
  double threshold = 0;
  if (opts.min_component_volume)
    threshold = *opts.min_component_volume;
  else if (opts.voxel_size > 0)
    threshold = kDefaultDustVoxels * opts.voxel_size * opts.voxel_size * opts.voxel_size;
  rep.min_component_volume = threshold;
  std::vector<uint32_t> comp;
  const std::size_t ncomp = detail::face_components(mesh, comp);
  rep.components_before = ncomp;
  std::vector<double> volume(ncomp, 0.0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    Vec3 a = to_d(mesh.positions[t[0]]), b = to_d(mesh.positions[t[1]]),
         c = to_d(mesh.positions[t[2]]);
    volume[comp[f]] += dot(a, cross(b, c)) / 6.0;
  }
  std::vector<uint8_t> keep(ncomp, 1);
  for (std::size_t c = 0; c < ncomp; ++c)
    if (std::abs(volume[c]) < threshold) {
      keep[c] = 0;
      ++rep.removed_components;
    }
  rep.components_after = ncomp - rep.removed_components;
  if (rep.removed_components) {
    std::size_t w = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
      if (keep[comp[f]]) mesh.triangles[w++] = mesh.triangles[f];
    rep.removed_faces = mesh.triangles.size() - w;
    mesh.triangles.resize(w);
  }
  report_progress(opts.progress, 0.8);

  detail::compact_vertices(mesh);
  report_progress(opts.progress, 1.0);
  if (report) *report = rep;
  return mesh;
}

}  // namespace qjulia
