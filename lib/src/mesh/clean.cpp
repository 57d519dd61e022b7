#include "qjulia/mesh/clean.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "base/geometry.h"
#include "base/mesh_check.h"
#include "base/stage_progress.h"
#include "base/union_find.h"
#include "base/weld.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"

namespace qjulia {

namespace {

using detail::cross;
using detail::dot;
using detail::to_vec3d;
using detail::Vec3d;

constexpr uint32_t kCancelMask = (1u << 16) - 1;  // check the token every 65,536 iterations

/// Maps every vertex to the first vertex with bit-identical position (after -0 -> +0).
/// Returns the number of vertices merged away.
std::size_t weld_exact(const TriMesh& mesh, std::vector<uint32_t>& remap) {
  const std::size_t nv = mesh.positions.size();
  remap.resize(nv);
  const std::size_t distinct = detail::number_positions(mesh.positions.data(), nv, remap.data());
  // The group's number to its first vertex (groups are numbered in the order of those).
  std::vector<uint32_t> first;
  first.reserve(distinct);
  for (std::size_t v = 0; v < nv; ++v) {
    if (remap[v] == first.size()) first.push_back(static_cast<uint32_t>(v));
    remap[v] = first[remap[v]];
  }
  return nv - distinct;
}

/// The faces of zero area in float precision (|cross| <= 1e-6 longest edge^2).
std::vector<uint32_t> zero_area_faces(const TriMesh& mesh, const CancelToken* cancel) {
  constexpr double kZero = 1e-6;
  std::vector<uint32_t> degenerate;
  for (uint32_t f = 0; f < mesh.triangles.size(); ++f) {
    if ((f & kCancelMask) == 0) throw_if_cancelled(cancel);
    const auto& t = mesh.triangles[f];
    const Vec3d a = to_vec3d(mesh.positions[t[0]]), b = to_vec3d(mesh.positions[t[1]]),
                c = to_vec3d(mesh.positions[t[2]]);
    const Vec3d n = cross(b - a, c - a);
    const double l2 = std::max({dot(b - a, b - a), dot(c - b, c - b), dot(a - c, a - c)});
    if (std::sqrt(dot(n, n)) <= kZero * l2) degenerate.push_back(f);
  }
  return degenerate;
}

/// Zero-area faces with three distinct vertices: a needle (two nearly coincident vertices)
/// is collapsed; a cap (a vertex on the opposite edge) is removed by flipping that edge with
/// the neighbour, which keeps the surface and its topology. Returns {collapsed, flipped}.
std::pair<std::size_t, std::size_t> fix_zero_area(TriMesh& mesh, const CancelToken* cancel) {
  const std::vector<uint32_t> degenerate = zero_area_faces(mesh, cancel);
  if (degenerate.empty()) return {0, 0};
  auto& tris = mesh.triangles;
  const auto& pos = mesh.positions;
  constexpr double kNeedle = 1e-4;  // shortest <= kNeedle * longest is a needle
  // Directed edge -> face.
  std::unordered_map<uint64_t, uint32_t> edge_face;
  edge_face.reserve(tris.size() * 3);
  auto key = [](uint64_t a, uint64_t b) { return (a << 32) | b; };
  for (uint32_t f = 0; f < tris.size(); ++f) {
    if ((f & kCancelMask) == 0) throw_if_cancelled(cancel);
    for (int k = 0; k < 3; ++k) edge_face[key(tris[f][k], tris[f][(k + 1) % 3])] = f;
  }
  std::vector<uint8_t> touched(tris.size(), 0);
  detail::UnionFind merged(pos.size());  // needles collapsed into their smaller vertex
  std::size_t collapsed = 0, flipped = 0;
  for (uint32_t f : degenerate) {
    if (touched[f]) continue;
    const auto t = tris[f];
    double len[3];
    for (int k = 0; k < 3; ++k)  // edge k: t[k] -> t[k+1]
      len[k] = detail::length(to_vec3d(pos[t[(k + 1) % 3]]) - to_vec3d(pos[t[k]]));
    int longest = int(std::max_element(len, len + 3) - len);
    int shortest = int(std::min_element(len, len + 3) - len);
    if (len[shortest] <= kNeedle * len[longest]) {
      uint32_t a = t[shortest], b = t[(shortest + 1) % 3];
      if (merged.find(a) == a && merged.find(b) == b) {  // neither collapsed yet
        merged.unite(a, b);
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
    const Vec3d pa = to_vec3d(pos[a]), pb = to_vec3d(pos[b]), pm = to_vec3d(pos[m]),
                pd = to_vec3d(pos[d]);
    if (dot(cross(pd - pa, pm - pa), cross(pb - pd, pm - pd)) <= 0) continue;
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
  if (collapsed)
    for (auto& t : tris)
      for (auto& v : t) v = merged.find(v);
  return {collapsed, flipped};
}

/// Removes the vertex-connected components whose |volume| is below `threshold`.
void remove_dust(TriMesh& mesh, double threshold, CleanReport& rep, const CancelToken* cancel) {
  std::vector<uint32_t> comp;
  const std::size_t ncomp = detail::face_components(mesh, comp);
  rep.components_before = ncomp;
  std::vector<double> volume(ncomp, 0.0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if ((f & kCancelMask) == 0) throw_if_cancelled(cancel);
    const auto& t = mesh.triangles[f];
    volume[comp[f]] +=
        detail::tetra_volume(to_vec3d(mesh.positions[t[0]]), to_vec3d(mesh.positions[t[1]]),
                             to_vec3d(mesh.positions[t[2]]));
  }
  std::vector<uint8_t> keep(ncomp, 1);
  for (std::size_t c = 0; c < ncomp; ++c)
    if (std::abs(volume[c]) < threshold) {
      keep[c] = 0;
      ++rep.removed_components;
      rep.largest_removed_volume = std::max(rep.largest_removed_volume, std::abs(volume[c]));
    }
  rep.components_after = ncomp - rep.removed_components;
  if (rep.removed_components) {
    std::size_t w = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
      if (keep[comp[f]]) mesh.triangles[w++] = mesh.triangles[f];
    rep.removed_faces = mesh.triangles.size() - w;
    mesh.triangles.resize(w);
  }
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
  detail::report_progress(opts.progress, opts.cancel, 0.0);

  // 1. Merge bit-identical vertices.
  std::vector<uint32_t> remap;
  rep.merged_vertices = weld_exact(mesh, remap);
  if (rep.merged_vertices)
    for (auto& t : mesh.triangles)
      for (auto& v : t) v = remap[v];
  detail::report_progress(opts.progress, opts.cancel, 0.2);

  // 2. Degenerate faces: repeated indices, fins, then zero-area faces (a few rounds: a flip
  // or collapse can expose another degenerate face).
  bool dirty = rep.merged_vertices > 0;
  for (const auto& t : mesh.triangles)
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) dirty = true;
  if (dirty) rep.degenerate_faces_removed += detail::drop_repeated_and_fins(mesh);
  for (int round = 0; round < 4; ++round) {
    auto [collapsed, flipped] = fix_zero_area(mesh, opts.cancel);
    rep.degenerate_faces_flipped += flipped;
    if (collapsed) rep.degenerate_faces_removed += detail::drop_repeated_and_fins(mesh);
    if (!collapsed && !flipped) break;
  }
  detail::report_progress(opts.progress, opts.cancel, 0.5);

  // 3. Components below the volume threshold.
  double threshold = 0;
  if (opts.min_component_volume)
    threshold = *opts.min_component_volume;
  else if (opts.voxel_size > 0)
    threshold = kDefaultDustVoxels * opts.voxel_size * opts.voxel_size * opts.voxel_size;
  rep.min_component_volume = threshold;
  remove_dust(mesh, threshold, rep, opts.cancel);
  detail::report_progress(opts.progress, opts.cancel, 0.8);

  detail::compact_vertices(mesh);
  detail::report_progress(opts.progress, opts.cancel, 1.0);
  if (report) *report = rep;
  return mesh;
}

}  // namespace qjulia
