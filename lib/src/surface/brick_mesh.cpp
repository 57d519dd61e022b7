#include "surface/brick_mesh.h"

#include <algorithm>
#include <cmath>

#include "surface/cube.h"
#include "surface/refine.h"

namespace qjulia::detail {

BrickMesh mesh_brick(const Brick& br, const Solid& solid, const GridGeometry& geo,
                     const BrickMeshOptions& opts) {
  const CubeTables& t = cube();
  BrickMesh out;
  out.key = br.key;
  const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
  auto position = [&](int li, int lj, int lk) {
    return std::array<double, 3>{geo.origin[0] + (base[0] + li) * geo.voxel,
                                 geo.origin[1] + (base[1] + lj) * geo.voxel,
                                 geo.origin[2] + (base[2] + lk) * geo.voxel};
  };
  // 1. The crossing edges of the surface cells (each once, by code).
  std::vector<int> cells;
  for (int c = 0; c < kBrickCells; ++c)
    if (br.surface.test(c)) cells.push_back(c);
  Bits<kEdgeCodes> seen;
  std::vector<int> edges;
  for (int c : cells) {
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    for (int e = 0; e < 12; ++e) {
      const int d0 = t.edge_corner[e], axis = t.edge_axis[e];
      const int l[3] = {ci[0] + corner_bit(d0, 0), ci[1] + corner_bit(d0, 1),
                        ci[2] + corner_bit(d0, 2)};
      int h[3] = {l[0], l[1], l[2]};
      ++h[axis];
      const bool in_a = br.value[point_index(l[0], l[1], l[2])] <= 0;
      const bool in_b = br.value[point_index(h[0], h[1], h[2])] <= 0;
      if (in_a == in_b) continue;
      const int code = edge_code(l[0], l[1], l[2], axis);
      if (seen.test(code)) continue;
      seen.set(code);
      edges.push_back(code);
    }
  }
  std::sort(edges.begin(), edges.end());
  // 2. Their vertices on the boundary, all at once. Edges owned by a neighbour (their lower
  // point on an upper face of the brick) are refined here too, for the shape of the cells; the
  // owner computes the same positions.
  std::vector<Segment> segs(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const int code = edges[i], axis = code % 3, p = code / 3;
    const int l[3] = {p / 81, (p / 9) % 9, p % 9};
    int h[3] = {l[0], l[1], l[2]};
    ++h[axis];
    segs[i].a = position(l[0], l[1], l[2]);
    segs[i].b = position(h[0], h[1], h[2]);
    segs[i].fa = br.value[point_index(l[0], l[1], l[2])];
    segs[i].fb = br.value[point_index(h[0], h[1], h[2])];
  }
  std::vector<std::array<double, 3>> where(edges.size());
  out.evaluations += refine_segments(solid, segs.data(), segs.size(), opts.tolerance,
                                     opts.max_refine_steps, where.data());
  // Owned edge vertices first, by code; a code -> local index map for the triangles.
  int local[kEdgeCodes];
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const int code = edges[i], axis = code % 3, p = code / 3;
    const int l[3] = {p / 81, (p / 9) % 9, p % 9};
    (void)axis;
    if (l[0] < kBrick && l[1] < kBrick && l[2] < kBrick) {
      local[code] = static_cast<int>(out.positions.size());
      out.codes.push_back(static_cast<std::uint16_t>(code));
      out.positions.push_back({static_cast<float>(where[i][0]), static_cast<float>(where[i][1]),
                               static_cast<float>(where[i][2])});
    }
  }
  auto ref_of = [&](int code) -> std::uint32_t {
    const int p = code / 3;
    const int l[3] = {p / 81, (p / 9) % 9, p % 9};
    const int dir = (l[0] == kBrick) | ((l[1] == kBrick) << 1) | ((l[2] == kBrick) << 2);
    if (dir == 0) return static_cast<std::uint32_t>(local[code]);
    return foreign_ref(dir, edge_code(l[0] - kBrick * (dir & 1), l[1] - kBrick * ((dir >> 1) & 1),
                                      l[2] - kBrick * (dir >> 2), code % 3));
  };
  auto point_of = [&](int code) -> const std::array<double, 3>& {
    return where[std::lower_bound(edges.begin(), edges.end(), code) - edges.begin()];
  };
  // 3. Per cell: loops, each triangulated without a diagonal on a cube face, else around a
  // centre vertex.
  for (int c : cells) {
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    float v[8];
    for (int d = 0; d < 8; ++d)
      v[d] = br.value[point_index(ci[0] + (d & 1), ci[1] + ((d >> 1) & 1), ci[2] + (d >> 2))];
    const CellLoops loops = cell_loops(v);
    for (int L = 0; L < loops.count; ++L) {
      const int len = loops.length[L];
      const int* loop = loops.edge[L];
      int code[12];
      std::uint32_t ids[12];
      for (int q = 0; q < len; ++q) {
        const int e = loop[q], d0 = t.edge_corner[e];
        code[q] = edge_code(ci[0] + corner_bit(d0, 0), ci[1] + corner_bit(d0, 1),
                            ci[2] + corner_bit(d0, 2), t.edge_axis[e]);
        ids[q] = ref_of(code[q]);
      }
      // Segments of the loop on a face of the brick: shared with the neighbour brick.
      for (int q = 0; q < len; ++q) {
        const int e1 = loop[q], e2 = loop[(q + 1) % len];
        for (int f = 0; f < 6; ++f) {
          const int axis = t.face_axis[f], side = t.face_side[f];
          if (ci[axis] != (side ? kBrick - 1 : 0)) continue;
          const auto& fc = t.face_corners[f];
          bool has1 = false, has2 = false;
          for (int k = 0; k < 4; ++k) {
            const int e = t.edge_of[fc[k]][fc[(k + 1) % 4]];
            has1 = has1 || e == e1;
            has2 = has2 || e == e2;
          }
          if (has1 && has2) out.border[2 * axis + side].push_back({ids[q], ids[(q + 1) % len]});
        }
      }
      std::uint8_t tris[3 * 10];
      const int n = triangulate_loop(
          loop, len, [](int, int) { return 0.0; }, tris);
      if (n > 0) {
        for (int q = 0; q < n; ++q)
          out.triangles.push_back({ids[tris[3 * q]], ids[tris[3 * q + 1]], ids[tris[3 * q + 2]]});
        continue;
      }
      std::array<double, 3> centre{0, 0, 0}, normal{0, 0, 0};
      for (int q = 0; q < len; ++q) {
        const auto& a = point_of(code[q]);
        const auto& b = point_of(code[(q + 1) % len]);
        for (int k = 0; k < 3; ++k) centre[k] += a[k] / len;
        // Newell's normal of the loop.
        normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
        normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
        normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
      }
      const auto p =
          project_to_boundary(solid, centre, normal, geo.voxel, opts.tolerance, &out.evaluations);
      const std::uint32_t cid = static_cast<std::uint32_t>(out.positions.size());
      out.positions.push_back(
          {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])});
      for (int q = 0; q < len; ++q) out.triangles.push_back({cid, ids[q], ids[(q + 1) % len]});
    }
  }
  return out;
}

}  // namespace qjulia::detail
