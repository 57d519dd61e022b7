#include "surface/brick_mesh.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "surface/cube.h"
#include "surface/embed.h"
#include "surface/refine.h"

namespace qjulia::detail {
namespace {

// A brick's known values as an array of all its points (a thread's scratch): every value of a
// pass read at the cost of a load.
class Values {
 public:
  explicit Values(const Brick& br) : v_(scratch()) {
    thread_local std::vector<float> known;
    br.known_values(known);
    std::size_t n = 0;
    br.known.for_each([&](int p) { v_[p] = known[n++]; });
  }
  float operator[](int p) const { return v_[p]; }
  // The corner values of local cell c.
  void cell(int c, float v[8]) const {
    const int p = point_index(c / 64, (c / 8) % 8, c % 8);
    constexpr int kOffset[8] = {0, 81, 9, 90, 1, 82, 10, 91};
    for (int d = 0; d < 8; ++d) v[d] = v_[p + kOffset[d]];
  }

 private:
  static float* scratch() {
    thread_local float values[kBrickPoints];
    return values;
  }
  float* v_;
};

// Asks for the cache lines of `bytes` bytes at `p`, to be read soon.
void prefetch_bytes(const void* p, std::size_t bytes) {
  for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(static_cast<const char*>(p) + b);
}

// The edge code of cube edge e of local cell (ci).
int code_of(const CubeTables& t, const int ci[3], int e) {
  const int d0 = t.edge_corner[e];
  return edge_code(ci[0] + corner_bit(d0, 0), ci[1] + corner_bit(d0, 1), ci[2] + corner_bit(d0, 2),
                   t.edge_axis[e]);
}

using Pos = std::array<double, 3>;

// Every triangulation of a loop of `len` vertices with no diagonal joining two cube edges of
// one face, as lists of loop positions (three per triangle), at most `limit` of them.
void all_triangulations(const std::uint8_t* loop, int len, std::size_t limit,
                        std::vector<std::vector<std::uint8_t>>& out) {
  const auto& share = cube().share_face;
  auto allowed = [&](int i, int j) {
    return j - i == 1 || (i == 0 && j == len - 1) || !share[loop[i]][loop[j]];
  };
  // Triangulations of the sub-polygon i..j, appended to `acc`, calling `done` for each.
  std::function<void(std::vector<std::pair<int, int>>&, std::vector<std::uint8_t>&)> expand =
      [&](std::vector<std::pair<int, int>>& todo, std::vector<std::uint8_t>& acc) {
        if (out.size() >= limit) return;
        if (todo.empty()) {
          out.push_back(acc);
          return;
        }
        const auto [i, j] = todo.back();
        todo.pop_back();
        if (j - i < 2) {
          expand(todo, acc);
        } else if (allowed(i, j)) {
          for (int k = i + 1; k < j; ++k) {
            if (!allowed(i, k) || !allowed(k, j)) continue;
            acc.push_back(static_cast<std::uint8_t>(i));
            acc.push_back(static_cast<std::uint8_t>(k));
            acc.push_back(static_cast<std::uint8_t>(j));
            todo.push_back({i, k});
            todo.push_back({k, j});
            expand(todo, acc);
            todo.pop_back();
            todo.pop_back();
            acc.resize(acc.size() - 3);
          }
        }
        todo.push_back({i, j});
      };
  std::vector<std::pair<int, int>> todo{{0, len - 1}};
  std::vector<std::uint8_t> acc;
  expand(todo, acc);
}

double area(const Triangle& t) {
  const Pos u{t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]};
  const Pos v{t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]};
  const Pos c{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  return 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
}

// True when none of `fresh` crosses another of them or one of `placed`.
bool embedded(const std::vector<Triangle>& fresh, const std::vector<Triangle>& placed) {
  for (std::size_t i = 0; i < fresh.size(); ++i) {
    for (std::size_t j = i + 1; j < fresh.size(); ++j)
      if (triangles_cross(fresh[i], fresh[j])) return false;
    for (const Triangle& p : placed)
      if (triangles_cross(fresh[i], p)) return false;
  }
  return true;
}

// The centre vertex of a loop: the boundary point nearest the loop's centroid inside the cell
// (lowest corner lo), searched along the loop's normal and 13 more directions; the centroid when
// none is found. A point strictly inside the cell: the cone from it over the loop (which lies on
// the cell's faces) never crosses itself, nor anything in the neighbouring cells.
Pos centre_of(const Solid& solid, const GridGeometry& geo, const Pos& lo, const Pos* pts, int len,
              double tol, std::uint64_t* evaluations) {
  Pos mid{0, 0, 0}, normal{0, 0, 0};
  for (int q = 0; q < len; ++q) {
    const Pos& a = pts[q];
    const Pos& b = pts[(q + 1) % len];
    for (int k = 0; k < 3; ++k) mid[k] += a[k] / len;
    // Newell's normal of the loop.
    normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
    normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
    normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
  }
  return boundary_in_cell(solid, mid, normal, lo, geo.voxel, tol, evaluations);
}

bool on_upper_face(int code) {
  const int p = code / 3;
  return p / 81 == kBrick || (p / 9) % 9 == kBrick || p % 9 == kBrick;
}

// What the first pass reads of the cube: by the corners inside (bit d for corner d), the
// edges that cross (bit e for edge e); each edge's code less that of its cell's lowest corner's
// first edge; the codes on the brick's upper faces (the neighbours' vertices).
struct EdgeTables {
  std::uint16_t crossing[256];
  int offset[12];
  Bits<kEdgeCodes> upper;
};

EdgeTables edge_tables() {
  const CubeTables& t = cube();
  EdgeTables et{};
  for (int inside = 0; inside < 256; ++inside) {
    et.crossing[inside] = 0;
    for (int e = 0; e < 12; ++e) {
      const int d0 = t.edge_corner[e], d1 = d0 | (1 << t.edge_axis[e]);
      if (((inside >> d0) & 1) != ((inside >> d1) & 1))
        et.crossing[inside] = static_cast<std::uint16_t>(et.crossing[inside] | (1u << e));
    }
  }
  const int zero[3] = {0, 0, 0};
  for (int e = 0; e < 12; ++e) et.offset[e] = code_of(t, zero, e);
  for (int code = 0; code < kEdgeCodes; ++code)
    if (on_upper_face(code)) et.upper.set(code);
  return et;
}

// BrickNeighbours::find, remembered by edge code (each vertex is a corner of up to four cells),
// in a table of the thread's that is never cleared: an entry counts when it carries this
// lookup's stamp.
class Lookup {
 public:
  explicit Lookup(const BrickNeighbours& around) : around_(around), table_(table()) {
    if (++table_.stamp == 0) {  // wrapped: clear once every 2^32 lookups
      std::fill(std::begin(table_.stamps), std::end(table_.stamps), 0u);
      table_.stamp = 1;
    }
    // The neighbours' codes (searched when asked for, on other bricks' cache lines) fetched
    // meanwhile.
    for (int dir = 1; dir < 8; ++dir)
      if (const std::vector<std::uint16_t>* list = around.codes[dir])
        prefetch_bytes(list->data(), list->size() * sizeof(std::uint16_t));
    // The brick's own vertices at once (most corners are), the neighbours' when asked.
    if (const std::vector<std::uint16_t>* own = around.codes[0])
      for (std::size_t i = 0; i < own->size(); ++i) {
        const int code = (*own)[i];
        table_.slot[code] = static_cast<std::uint64_t>(i) << 3;
        table_.stamps[code] = table_.stamp;
      }
  }
  std::pair<int, std::size_t> operator()(int code) {
    if (table_.stamps[code] != table_.stamp) {
      const auto [dir, index] = around_.find(code);
      table_.slot[code] =
          (static_cast<std::uint64_t>(index) << 3) | static_cast<std::uint64_t>(dir);
      table_.stamps[code] = table_.stamp;
    }
    const std::uint64_t s = table_.slot[code];
    return {static_cast<int>(s & 7), static_cast<std::size_t>(s >> 3)};
  }

 private:
  struct Table {
    std::uint32_t stamp = 0;
    std::uint32_t stamps[kEdgeCodes] = {};
    std::uint64_t slot[kEdgeCodes];
  };
  static Table& table() {
    thread_local Table t;
    return t;
  }
  const BrickNeighbours& around_;
  Table& table_;
};

}  // namespace

std::pair<int, std::size_t> BrickNeighbours::find(int code) const {
  const int p = code / 3;
  const int l[3] = {p / 81, (p / 9) % 9, p % 9};
  const int dir = (l[0] == kBrick) | ((l[1] == kBrick) << 1) | ((l[2] == kBrick) << 2);
  const int own = edge_code(l[0] - kBrick * (dir & 1), l[1] - kBrick * ((dir >> 1) & 1),
                            l[2] - kBrick * (dir >> 2), code % 3);
  const std::vector<std::uint16_t>* list = codes[dir];
  if (!list) throw std::logic_error("extract: a neighbour brick is missing");
  // Binary search without branches (the halves are taken by a conditional move): the codes of
  // a brick are few, and which half holds a code is unpredictable.
  const std::uint16_t* at = list->data();
  std::size_t n = list->size();
  if (n == 0) throw std::logic_error("extract: a neighbour brick lacks a shared vertex");
  while (n > 1) {
    const std::size_t half = n / 2;
    at = at[half - 1] < own ? at + half : at;
    n -= half;
  }
  if (*at != own) throw std::logic_error("extract: a neighbour brick lacks a shared vertex");
  return {dir, static_cast<std::size_t>(at - list->data())};
}

void brick_vertices(const Brick* const* bricks, std::size_t n, const Solid& solid,
                    const GridGeometry& geo, const BrickMeshOptions& opts, BrickVertices* out) {
  static const EdgeTables et = edge_tables();
  thread_local std::vector<Segment> segs;
  thread_local std::vector<Pos> where;
  segs.clear();
  for (std::size_t b = 0; b < n; ++b) {
    const Brick& br = *bricks[b];
    BrickVertices& o = out[b];
    o = BrickVertices();
    o.key = br.key;
    const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
    auto position = [&](int li, int lj, int lk) {
      return Pos{geo.origin[0] + (base[0] + li) * geo.voxel,
                 geo.origin[1] + (base[1] + lj) * geo.voxel,
                 geo.origin[2] + (base[2] + lk) * geo.voxel};
    };
    // 1. The crossing edges of the surface cells that the brick owns, each once, in code
    // order: marked in a set of codes, then read from it.
    const Values values(br);
    Bits<kEdgeCodes> seen;
    std::vector<std::uint16_t>& edges = o.codes;
    o.cells.reserve(br.surface.count());
    br.surface.for_each([&](int c) {
      float v[8];
      values.cell(c, v);
      o.cells.push_back((static_cast<std::uint32_t>(c) << 16) | cell_case_index(v));
      const int inside = signs_of(v);
      const int first = 3 * point_index(c / 64, (c / 8) % 8, c % 8);
      for_each_bit(et.crossing[inside], 0, [&](int e) { seen.set(first + et.offset[e]); });
    });
    seen = seen & ~et.upper;
    edges.reserve(seen.count());
    seen.for_each([&](int code) { edges.push_back(static_cast<std::uint16_t>(code)); });
    // 2. Their segments, refined with the group's.
    for (const int code : edges) {
      const int axis = code % 3, p = code / 3;
      const int l[3] = {p / 81, (p / 9) % 9, p % 9};
      int h[3] = {l[0], l[1], l[2]};
      ++h[axis];
      Segment sg;
      sg.a = position(l[0], l[1], l[2]);
      sg.b = position(h[0], h[1], h[2]);
      sg.fa = values[point_index(l[0], l[1], l[2])];
      sg.fb = values[point_index(h[0], h[1], h[2])];
      segs.push_back(sg);
    }
  }
  // 3. The vertices on the boundary, all of the group's at once.
  where.resize(segs.size());
  const std::uint64_t evaluations = refine_segments(solid, segs.data(), segs.size(), opts.tolerance,
                                                    opts.max_refine_steps, where.data());
  std::size_t at = 0;
  for (std::size_t b = 0; b < n; ++b) {
    BrickVertices& o = out[b];
    o.positions.resize(o.codes.size());
    for (auto& p : o.positions) {
      p = {static_cast<float>(where[at][0]), static_cast<float>(where[at][1]),
           static_cast<float>(where[at][2])};
      ++at;
    }
  }
  if (n > 0) out[0].evaluations = evaluations;
}

BrickPlan plan_brick(const BrickCoord& at, std::vector<std::uint32_t> cells, const Solid& solid,
                     const GridGeometry& geo, const BrickMeshOptions& opts,
                     const BrickNeighbours& around) {
  const CubeTables& t = cube();
  BrickPlan out;
  out.cells = std::move(cells);
  const int base[3] = {at.x * kBrick, at.y * kBrick, at.z * kBrick};
  Lookup lookup(around);
  // The vertices' positions (the first pass's, out of cache by now) asked for at once.
  for (int dir = 0; dir < 8; ++dir)
    if (around.codes[dir] && around.positions[dir])
      prefetch_bytes(around.positions[dir],
                     around.codes[dir]->size() * sizeof(std::array<float, 3>));
  auto point_of = [&](int code) {
    const auto [dir, index] = lookup(code);
    const std::array<float, 3>& p = around.positions[dir][index];
    return Pos{p[0], p[1], p[2]};
  };
  // The triangles of the cell so far, and the candidates for one loop (a thread's scratch,
  // cleared before each use).
  thread_local std::vector<Triangle> placed, fresh;
  thread_local std::vector<std::vector<std::uint8_t>> options;
  thread_local std::vector<std::pair<double, std::size_t>> by_area;
  for (const std::uint32_t cell : out.cells) {
    const int c = static_cast<int>(cell >> 16);
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    const CellCase& cc = cell_case_at(static_cast<std::uint16_t>(cell & 0xffff));
    // The cell's corners as its vertices' coordinates hold them (a vertex keeps the coordinates
    // of its edge's corner exactly, rounded to float like them).
    auto cell_corner = [&](int up) {
      Pos p;
      for (int k = 0; k < 3; ++k)
        p[k] = static_cast<float>(geo.origin[k] + (base[k] + ci[k] + up) * geo.voxel);
      return p;
    };
    placed.clear();
    bool cell_ok = true;
    for (int L = 0; L < cc.loops; ++L) {
      const int len = cc.length[L];
      Pos pts[12];
      for (int q = 0; q < len; ++q) pts[q] = point_of(code_of(t, ci, cc.edge[L][q]));
      auto triangles_of = [&](const std::uint8_t* tri, int n) {
        fresh.clear();
        for (int q = 0; q < n; ++q)
          fresh.push_back({pts[tri[3 * q]], pts[tri[3 * q + 1]], pts[tri[3 * q + 2]]});
      };
      auto choose = [&](const std::uint8_t* tri, int n) {
        LoopChoice choice;
        choice.cell = static_cast<std::uint16_t>(c);
        choice.loop = static_cast<std::uint8_t>(L);
        choice.count = static_cast<std::uint8_t>(n);
        std::copy(tri, tri + 3 * n, choice.tri);
        out.choices.push_back(choice);
      };
      // A cell's first loop keeps the table's triangles when it has one, or when they are proved
      // embedded by looking along an axis (usually), without building them; else (and for the
      // loops after it, which must miss it) its triangles are tested pair by pair.
      if (placed.empty() && cc.triangles[L] > 0 &&
          (cc.triangles[L] == 1 ||
           (cc.view_axis[L] < 3 && loop_embedded(cc, L, pts, cell_corner(0), cell_corner(1))))) {
        out.triangles += cc.triangles[L];
        if (L + 1 < cc.loops) {
          triangles_of(cc.tri[L], cc.triangles[L]);
          placed.insert(placed.end(), fresh.begin(), fresh.end());
        }
        continue;
      }
      bool done = false;
      if (cc.triangles[L] > 0) {
        triangles_of(cc.tri[L], cc.triangles[L]);
        if (embedded(fresh, placed)) {
          done = true;
        } else if (len <= 9) {
          // The other triangulations, least area first.
          options.clear();
          all_triangulations(cc.edge[L], len, 500, options);
          by_area.clear();
          for (std::size_t o = 0; o < options.size(); ++o) {
            triangles_of(options[o].data(), static_cast<int>(options[o].size() / 3));
            double a = 0;
            for (const Triangle& tr : fresh) a += area(tr);
            by_area.emplace_back(a, o);
          }
          std::sort(by_area.begin(), by_area.end());
          for (const auto& [a, o] : by_area) {
            const auto& tri = options[o];
            const int n = static_cast<int>(tri.size() / 3);
            triangles_of(tri.data(), n);
            if (!embedded(fresh, placed)) continue;
            choose(tri.data(), n);
            done = true;
            break;
          }
        }
      }
      if (!done) {
        // Around a centre vertex inside the cell.
        const Pos lo{geo.origin[0] + (base[0] + ci[0]) * geo.voxel,
                     geo.origin[1] + (base[1] + ci[1]) * geo.voxel,
                     geo.origin[2] + (base[2] + ci[2]) * geo.voxel};
        const Pos centre = centre_of(solid, geo, lo, pts, len, opts.tolerance, &out.evaluations);
        const std::array<float, 3> stored{static_cast<float>(centre[0]),
                                          static_cast<float>(centre[1]),
                                          static_cast<float>(centre[2])};
        const Pos at{stored[0], stored[1], stored[2]};
        fresh.clear();
        for (int q = 0; q < len; ++q) fresh.push_back({at, pts[q], pts[(q + 1) % len]});
        if (!embedded(fresh, placed)) cell_ok = false;
        if (cc.triangles[L] > 0) choose(nullptr, 0);  // not the table's choice
        out.centres.push_back(stored);
      }
      placed.insert(placed.end(), fresh.begin(), fresh.end());
      out.triangles += static_cast<std::uint32_t>(fresh.size());
    }
    if (!cell_ok) ++out.unmended;
  }
  return out;
}

BrickFaces brick_triangles(const BrickPlan& plan, const MeshTarget& target) {
  const CubeTables& t = cube();
  // The border lists grow in the thread's scratch and are copied out at their size.
  thread_local BrickFaces out;
  for (auto& list : out.border) list.clear();
  Lookup lookup(target.around);
  auto vertex_of = [&](int code) {
    const auto [dir, index] = lookup(code);
    return static_cast<std::uint32_t>(target.around.base[dir] + index);
  };
  std::size_t face = target.face_base, centre = target.centre_base, choice = 0;
  for (const std::uint32_t cell : plan.cells) {
    const int c = static_cast<int>(cell >> 16);
    const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
    const CellCase& cc = cell_case_at(static_cast<std::uint16_t>(cell & 0xffff));
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
      const std::uint8_t* tris = cc.tri[L];
      int n = cc.triangles[L];
      if (choice < plan.choices.size() && plan.choices[choice].cell == c &&
          plan.choices[choice].loop == L) {
        tris = plan.choices[choice].tri;
        n = plan.choices[choice].count;
        ++choice;
      }
      if (n > 0) {
        for (int q = 0; q < n; ++q)
          target.triangles[face++] = {ids[tris[3 * q]], ids[tris[3 * q + 1]], ids[tris[3 * q + 2]]};
        continue;
      }
      const std::uint32_t cid = static_cast<std::uint32_t>(centre++);
      for (int q = 0; q < len; ++q) target.triangles[face++] = {cid, ids[q], ids[(q + 1) % len]};
    }
  }
  if (face != target.face_base + plan.triangles)
    throw std::logic_error("extract: the second pass made another number of triangles");
  BrickFaces faces;
  for (int d = 0; d < 6; ++d) faces.border[d].assign(out.border[d].begin(), out.border[d].end());
  return faces;
}

}  // namespace qjulia::detail
