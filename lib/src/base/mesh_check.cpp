#include "base/mesh_check.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>

#include "base/geometry.h"
#include "base/union_find.h"

namespace qjulia::detail {

namespace {

/// Number of connected components of a vertex link given as pairs of link vertices.
int link_components(const std::vector<std::pair<uint32_t, uint32_t>>& link) {
  // Union-find over the distinct link vertices (a vertex has ~6 faces).
  std::vector<uint32_t> ids;
  ids.reserve(link.size() * 2);
  for (const auto& e : link) {
    ids.push_back(e.first);
    ids.push_back(e.second);
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  auto index = [&](uint32_t v) {
    return static_cast<uint32_t>(std::lower_bound(ids.begin(), ids.end(), v) - ids.begin());
  };
  UnionFind sets(ids.size());
  for (const auto& e : link) sets.unite(index(e.first), index(e.second));
  return static_cast<int>(sets.sets());
}

/// Fast path of a closed manifold vertex: following next -> prev visits every link edge once.
bool single_cycle(const std::vector<std::pair<uint32_t, uint32_t>>& link) {
  const std::size_t k = link.size();
  if (k > 64) return false;
  uint32_t cur = link[0].second;
  for (std::size_t steps = 1; steps < k; ++steps) {
    std::size_t i = 0;
    while (i < k && link[i].first != cur) ++i;
    if (i == k || i == 0) return false;
    cur = link[i].second;
  }
  return cur == link[0].first;
}

}  // namespace

VertexFaces::VertexFaces(const TriMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  offsets.assign(nv + 1, 0);
  for (const auto& t : mesh.triangles)
    for (uint32_t v : t) ++offsets[v + 1];
  for (std::size_t i = 0; i < nv; ++i) offsets[i + 1] += offsets[i];
  faces.resize(offsets[nv]);
  std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (uint32_t v : mesh.triangles[f]) faces[fill[v]++] = f;
}

std::vector<uint8_t> pinched_vertices(const TriMesh& mesh, const VertexFaces& vf) {
  const auto& tris = mesh.triangles;
  const std::size_t nv = mesh.positions.size();
  std::vector<uint8_t> pinched(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    std::vector<std::pair<uint32_t, uint32_t>> link;
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      link.clear();
      for (uint32_t k = vf.offsets[v]; k < vf.offsets[v + 1]; ++k) {
        const auto& t = tris[vf.faces[k]];
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
        int c = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
        link.emplace_back(t[(c + 1) % 3], t[(c + 2) % 3]);
      }
      if (link.size() > 1 && !single_cycle(link) && link_components(link) > 1) pinched[v] = 1;
    }
  });
  return pinched;
}

EdgeScan scan_edges(const TriMesh& mesh, const VertexFaces& vf, bool skip_degenerate,
                    const CancelToken* cancel) {
  const std::size_t nv = mesh.positions.size();
  struct Half {
    uint32_t hi, face;
    bool forward;  // lo -> hi in the face
  };
  EdgeScan scan;
  scan.edges_at.assign(nv, 0);
  tbb::enumerable_thread_specific<EdgeScan> parts;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
    throw_if_cancelled(cancel);
    EdgeScan& part = parts.local();
    std::vector<Half> half;
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      // The half-edges of v's faces whose lower end is v (a face with v twice is listed twice).
      half.clear();
      uint32_t last = UINT32_MAX;
      for (uint32_t k = vf.offsets[v]; k < vf.offsets[v + 1]; ++k) {
        const uint32_t f = vf.faces[k];
        if (f == last) continue;
        last = f;
        const auto& t = mesh.triangles[f];
        if (skip_degenerate && (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])) continue;
        for (int e = 0; e < 3; ++e) {
          const uint32_t a = t[e], b = t[(e + 1) % 3];
          if (std::min(a, b) == v) half.push_back({std::max(a, b), f, a < b});
        }
      }
      std::sort(half.begin(), half.end(), [](const Half& x, const Half& y) {
        return x.hi != y.hi ? x.hi < y.hi : x.face < y.face;
      });
      for (std::size_t i = 0; i < half.size();) {
        std::size_t j = i + 1;
        while (j < half.size() && half[j].hi == half[i].hi) ++j;
        const std::size_t n = j - i;
        const std::array<uint32_t, 2> ends{static_cast<uint32_t>(v), half[i].hi};
        ++part.edges;
        ++scan.edges_at[v];
        if (n == 1) {
          ++part.boundary_edges;
          part.boundary.push_back(ends);
        } else if (n > 2) {
          ++part.nonmanifold_edges;
          part.bad.push_back(ends);
        } else if (half[i].forward == half[i + 1].forward) {
          ++part.misoriented_edges;
          part.bad.push_back(ends);
        }
        if (n != 2)
          for (std::size_t k = i; k < j; ++k) part.open_faces.push_back(half[k].face);
        i = j;
      }
    }
  });
  for (EdgeScan& part : parts) {
    scan.edges += part.edges;
    scan.boundary_edges += part.boundary_edges;
    scan.nonmanifold_edges += part.nonmanifold_edges;
    scan.misoriented_edges += part.misoriented_edges;
    scan.open_faces.insert(scan.open_faces.end(), part.open_faces.begin(), part.open_faces.end());
    scan.boundary.insert(scan.boundary.end(), part.boundary.begin(), part.boundary.end());
    scan.bad.insert(scan.bad.end(), part.bad.begin(), part.bad.end());
  }
  return scan;
}

TopologyCheck check_topology(const TriMesh& mesh, bool allow_boundary) {
  TopologyCheck out;
  for (const auto& t : mesh.triangles)
    out.degenerate_faces += t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
  const VertexFaces vf(mesh);
  const EdgeScan scan = scan_edges(mesh, vf, /*skip_degenerate=*/true);
  out.edges = scan.edges;
  out.boundary_edges = scan.boundary_edges;
  out.nonmanifold_edges = scan.nonmanifold_edges;
  out.misoriented_edges = scan.misoriented_edges;
  std::vector<uint32_t> bad;
  for (const auto& e : scan.boundary) {
    out.boundary_vertices.insert(out.boundary_vertices.end(), e.begin(), e.end());
    if (!allow_boundary) bad.insert(bad.end(), e.begin(), e.end());
  }
  for (const auto& e : scan.bad) bad.insert(bad.end(), e.begin(), e.end());
  // Vertex fans: the link of a vertex must be connected.
  const std::size_t nv = mesh.positions.size();
  const std::vector<uint8_t> pinched = pinched_vertices(mesh, vf);
  for (std::size_t v = 0; v < nv; ++v)
    if (pinched[v]) {
      ++out.nonmanifold_vertices;
      bad.push_back(static_cast<uint32_t>(v));
    }
  std::sort(out.boundary_vertices.begin(), out.boundary_vertices.end());
  out.boundary_vertices.erase(
      std::unique(out.boundary_vertices.begin(), out.boundary_vertices.end()),
      out.boundary_vertices.end());
  std::sort(bad.begin(), bad.end());
  bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
  out.bad_vertices = std::move(bad);
  return out;
}

std::size_t face_components(const TriMesh& mesh, std::vector<uint32_t>& face_component) {
  UnionFind sets(mesh.positions.size());
  for (const auto& t : mesh.triangles) {
    sets.unite(t[0], t[1]);
    sets.unite(t[0], t[2]);
  }
  constexpr uint32_t kNone = 0xffffffffu;
  std::vector<uint32_t> label(mesh.positions.size(), kNone);
  uint32_t count = 0;
  face_component.resize(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const uint32_t r = sets.find(mesh.triangles[f][0]);
    if (label[r] == kNone) label[r] = count++;
    face_component[f] = label[r];
  }
  return count;
}

double signed_volume(const TriMesh& mesh) {
  double v = 0;
  for (const auto& t : mesh.triangles)
    v += tetra_volume(to_vec3d(mesh.positions[t[0]]), to_vec3d(mesh.positions[t[1]]),
                      to_vec3d(mesh.positions[t[2]]));
  return v;
}

/// Drops faces with a repeated index, then pairs of faces on the same three vertices with
/// opposite orientation (the "fins" a collapse can leave); both keep a closed mesh closed.
std::size_t drop_repeated_and_fins(TriMesh& mesh) {
  auto& tris = mesh.triangles;
  const std::size_t before = tris.size();
  tris.erase(
      std::remove_if(tris.begin(), tris.end(),
                     [](const auto& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }),
      tris.end());
  // Sort faces by a hash of their sorted vertex triple to find coincident faces; equal hashes
  // are compared exactly below.
  auto sorted_key = [&](uint32_t f) {
    auto t = tris[f];
    std::sort(t.begin(), t.end());
    return t;
  };
  std::vector<std::pair<uint64_t, uint32_t>> hashed(tris.size());
  tbb::parallel_for(std::size_t(0), tris.size(), [&](std::size_t f) {
    const auto t = sorted_key(static_cast<uint32_t>(f));
    uint64_t h = (uint64_t(t[0]) * 0x9E3779B97F4A7C15ULL) ^
                 (uint64_t(t[1]) * 0xC2B2AE3D27D4EB4FULL) ^
                 (uint64_t(t[2]) * 0x165667B19E3779F9ULL);
    hashed[f] = {h, static_cast<uint32_t>(f)};
  });
  tbb::parallel_sort(hashed.begin(), hashed.end());
  std::vector<uint32_t> order;  // faces whose hash is shared, grouped by exact triple
  for (std::size_t i = 0; i < hashed.size();) {
    std::size_t j = i + 1;
    while (j < hashed.size() && hashed[j].first == hashed[i].first) ++j;
    if (j - i > 1) {
      std::vector<uint32_t> group;
      for (std::size_t k = i; k < j; ++k) group.push_back(hashed[k].second);
      std::sort(group.begin(), group.end(), [&](uint32_t x, uint32_t y) {
        auto kx = sorted_key(x), ky = sorted_key(y);
        return kx != ky ? kx < ky : x < y;
      });
      order.insert(order.end(), group.begin(), group.end());
    }
    i = j;
  }
  auto parity = [&](uint32_t f) {  // orientation relative to the sorted order
    const auto& t = tris[f];
    int inv = (t[0] > t[1]) + (t[0] > t[2]) + (t[1] > t[2]);
    return inv & 1;
  };
  std::vector<uint8_t> drop(tris.size(), 0);
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i + 1;
    const auto ki = sorted_key(order[i]);
    while (j < order.size() && sorted_key(order[j]) == ki) ++j;
    if (j - i > 1) {
      // Cancel opposite orientations pairwise; same-orientation copies are duplicates.
      std::vector<uint32_t> pos, neg;
      for (std::size_t k = i; k < j; ++k) (parity(order[k]) ? neg : pos).push_back(order[k]);
      std::size_t pairs = std::min(pos.size(), neg.size());
      for (std::size_t k = 0; k < pairs; ++k) drop[pos[k]] = drop[neg[k]] = 1;
      for (std::size_t k = pairs + 1; k < pos.size(); ++k) drop[pos[k]] = 1;
      for (std::size_t k = pairs + 1; k < neg.size(); ++k) drop[neg[k]] = 1;
    }
    i = j;
  }
  std::size_t w = 0;
  for (std::size_t f = 0; f < tris.size(); ++f)
    if (!drop[f]) tris[w++] = tris[f];
  tris.resize(w);
  return before - w;
}

std::size_t compact_vertices(TriMesh& mesh, std::vector<uint32_t>* old_to_new) {
  constexpr uint32_t kNone = 0xffffffffu;
  const std::size_t nv = mesh.positions.size();
  std::vector<uint32_t> remap(nv, kNone);
  uint32_t next = 0;
  for (auto& t : mesh.triangles)
    for (auto& v : t) {
      if (remap[v] == kNone) remap[v] = next++;
      v = remap[v];
    }
  auto apply = [&](std::vector<std::array<float, 3>>& a) {
    if (a.size() != nv) return;
    std::vector<std::array<float, 3>> b(next);
    for (std::size_t i = 0; i < nv; ++i)
      if (remap[i] != kNone) b[remap[i]] = a[i];
    a.swap(b);
  };
  apply(mesh.positions);
  apply(mesh.normals);
  apply(mesh.colors);
  if (old_to_new) *old_to_new = std::move(remap);
  return nv - next;
}

}  // namespace qjulia::detail
