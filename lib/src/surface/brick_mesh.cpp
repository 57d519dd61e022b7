#include "surface/brick_mesh.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "surface/cube.h"
#include "surface/refine.h"

namespace qjulia::detail {
namespace {

// The corner values of local cell c.
void cell_values(const Brick& br, int c, float v[8]) {
  const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
  for (int d = 0; d < 8; ++d)
    v[d] = br.get(point_index(ci[0] + (d & 1), ci[1] + ((d >> 1) & 1), ci[2] + (d >> 2)));
}

// The edge code of cube edge e of local cell (ci).
int code_of(const CubeTables& t, const int ci[3], int e) {
  const int d0 = t.edge_corner[e];
  return edge_code(ci[0] + corner_bit(d0, 0), ci[1] + corner_bit(d0, 1), ci[2] + corner_bit(d0, 2),
                   t.edge_axis[e]);
}

}  // namespace

BrickVertices brick_vertices(const Brick& br, const Solid& solid, const GridGeometry& geo,
                             const BrickMeshOptions& opts) {
  const CubeTables& t = cube();
  BrickVertices out;
  out.key = br.key;
  const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
  auto position = [&](int li, int lj, int lk) {
    return std::array<double, 3>{geo.origin[0] + (base[0] + li) * geo.voxel,
                                 geo.origin[1] + (base[1] + lj) * geo.voxel,
                                 geo.origin[2] + (base[2] + lk) * geo.voxel};
  };
  // The crossing edges of the surface cells that the brick owns, each once; the counts of the
  // second pass from the cells' loops.
  Bits<kEdgeCodes> seen;
  std::vector<int> edges;
  for (int c = 0; c < kBrickCells; ++c) {
    if (!br.surface.test(c)) continue;
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    float v[8];
    cell_values(br, c, v);
    for (int e = 0; e < 12; ++e) {
      const int d0 = t.edge_corner[e], d1 = d0 | (1 << t.edge_axis[e]);
      if ((v[d0] <= 0) == (v[d1] <= 0)) continue;
      const int code = code_of(t, ci, e);
      const int p = code / 3;
      if (p / 81 == kBrick || (p / 9) % 9 == kBrick || p % 9 == kBrick) continue;  // not ours
      if (seen.test(code)) continue;
      seen.set(code);
      edges.push_back(code);
    }
    const CellLoops loops = cell_loops(v);
    for (int L = 0; L < loops.count; ++L) {
      std::uint8_t tris[3 * 10];
      const int n = triangulate_loop(
          loops.edge[L], loops.length[L], [](int, int) { return 0.0; }, tris);
      if (n > 0) {
        out.triangles += static_cast<std::uint32_t>(n);
      } else {
        out.triangles += static_cast<std::uint32_t>(loops.length[L]);
        ++out.centres;
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<Segment> segs(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const int code = edges[i], axis = code % 3, p = code / 3;
    const int l[3] = {p / 81, (p / 9) % 9, p % 9};
    int h[3] = {l[0], l[1], l[2]};
    ++h[axis];
    segs[i].a = position(l[0], l[1], l[2]);
    segs[i].b = position(h[0], h[1], h[2]);
    segs[i].fa = br.get(point_index(l[0], l[1], l[2]));
    segs[i].fb = br.get(point_index(h[0], h[1], h[2]));
  }
  std::vector<std::array<double, 3>> where(edges.size());
  out.evaluations += refine_segments(solid, segs.data(), segs.size(), opts.tolerance,
                                     opts.max_refine_steps, where.data());
  out.positions.resize(edges.size());
  out.codes.resize(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) {
    out.codes[i] = static_cast<std::uint16_t>(edges[i]);
    out.positions[i] = {static_cast<float>(where[i][0]), static_cast<float>(where[i][1]),
                        static_cast<float>(where[i][2])};
  }
  return out;
}

BrickFaces brick_triangles(const Brick& br, const Solid& solid, const GridGeometry& geo,
                           const BrickMeshOptions& opts, const MeshTarget& target) {
  const CubeTables& t = cube();
  BrickFaces out;
  // The vertex of a local edge code: ours, or the neighbour's whose lower point it is.
  auto vertex_of = [&](int code) -> std::uint32_t {
    const int p = code / 3;
    const int l[3] = {p / 81, (p / 9) % 9, p % 9};
    const int dir = (l[0] == kBrick) | ((l[1] == kBrick) << 1) | ((l[2] == kBrick) << 2);
    const int own = edge_code(l[0] - kBrick * (dir & 1), l[1] - kBrick * ((dir >> 1) & 1),
                              l[2] - kBrick * (dir >> 2), code % 3);
    const std::vector<std::uint16_t>* codes = target.codes[dir];
    if (!codes) throw std::logic_error("extract: a neighbour brick is missing");
    const auto it = std::lower_bound(codes->begin(), codes->end(), own);
    if (it == codes->end() || *it != own)
      throw std::logic_error("extract: a neighbour brick lacks a shared vertex");
    return static_cast<std::uint32_t>(target.base[dir] + (it - codes->begin()));
  };
  std::size_t face = target.face_base, centre = target.centre_base;
  for (int c = 0; c < kBrickCells; ++c) {
    if (!br.surface.test(c)) continue;
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    float v[8];
    cell_values(br, c, v);
    const CellCase& cc = cell_case(v);
    for (int L = 0; L < cc.loops; ++L) {
      const int len = cc.length[L];
      const std::uint8_t* loop = cc.edge[L];
      std::uint32_t ids[12];
      for (int q = 0; q < len; ++q) ids[q] = vertex_of(code_of(t, ci, loop[q]));
      // Segments of the loop on a face of the brick: shared with the neighbour brick.
      for (int q = 0; q < len; ++q) {
        const int f = cc.face[L][q], axis = t.face_axis[f], side = t.face_side[f];
        if (ci[axis] == (side ? kBrick - 1 : 0))
          out.border[2 * axis + side].push_back({ids[q], ids[(q + 1) % len]});
      }
      // Triangulated without a diagonal that joins two vertices of one cube face (the
      // neighbour cell could make the same edge); else around a centre vertex.
      const int n = cc.triangles[L];
      if (n > 0) {
        const std::uint8_t* tris = cc.tri[L];
        for (int q = 0; q < n; ++q)
          target.triangles[face++] = {ids[tris[3 * q]], ids[tris[3 * q + 1]], ids[tris[3 * q + 2]]};
        continue;
      }
      std::array<double, 3> mid{0, 0, 0}, normal{0, 0, 0};
      for (int q = 0; q < len; ++q) {
        const auto& a = target.positions[ids[q]];
        const auto& b = target.positions[ids[(q + 1) % len]];
        for (int k = 0; k < 3; ++k) mid[k] += static_cast<double>(a[k]) / len;
        // Newell's normal of the loop.
        normal[0] += (double(a[1]) - b[1]) * (double(a[2]) + b[2]);
        normal[1] += (double(a[2]) - b[2]) * (double(a[0]) + b[0]);
        normal[2] += (double(a[0]) - b[0]) * (double(a[1]) + b[1]);
      }
      const auto p =
          project_to_boundary(solid, mid, normal, geo.voxel, opts.tolerance, &out.evaluations);
      const std::uint32_t cid = static_cast<std::uint32_t>(centre++);
      target.positions[cid] = {static_cast<float>(p[0]), static_cast<float>(p[1]),
                               static_cast<float>(p[2])};
      for (int q = 0; q < len; ++q) target.triangles[face++] = {cid, ids[q], ids[(q + 1) % len]};
    }
  }
  return out;
}

}  // namespace qjulia::detail
