// The z-buffer pass: binning into tiles without atomics, then one task per tile.
//
// Determinism: every pass writes disjoint outputs (chunks of triangles, tiles) and each tile
// draws its triangles in index order with a strict depth test, so the buffer does not depend on
// how TBB schedules the work or on the thread count. There are no reductions.
#include "render/raster.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

namespace qjulia::detail {
namespace {

constexpr int kTile = 64;             // tile side in samples
constexpr std::size_t kChunk = 8192;  // triangles per binning chunk (fixed: determinism)

/// floor(a / b) for b > 0.
std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/// The samples (inclusive range) whose centres may lie in the triangle; empty when x0 > x1.
struct SampleBox {
  int x0, y0, x1, y1;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

SampleBox sample_box(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c, int w,
                     int h) {
  const std::int64_t half = kSubOne / 2;
  const std::int64_t minx = std::min({a.x, b.x, c.x}), maxx = std::max({a.x, b.x, c.x});
  const std::int64_t miny = std::min({a.y, b.y, c.y}), maxy = std::max({a.y, b.y, c.y});
  // Sample i has its centre at i * 256 + 128.
  return {static_cast<int>(std::max<std::int64_t>(0, -floor_div(half - minx, kSubOne))),
          static_cast<int>(std::max<std::int64_t>(0, -floor_div(half - miny, kSubOne))),
          static_cast<int>(std::min<std::int64_t>(w - 1, floor_div(maxx - half, kSubOne))),
          static_cast<int>(std::min<std::int64_t>(h - 1, floor_div(maxy - half, kSubOne)))};
}

/// Top-left style ownership of a shared edge: exactly one of a->b and b->a owns it, so
/// neighbouring triangles neither both draw nor both miss a sample on their common edge.
bool owns_edge(const ScreenVertex& a, const ScreenVertex& b) {
  const std::int64_t dx = std::int64_t{b.x} - a.x, dy = std::int64_t{b.y} - a.y;
  return dy > 0 || (dy == 0 && dx < 0);
}

void rasterize_triangle(std::uint32_t f, ScreenVertex a, ScreenVertex b, ScreenVertex c,
                        const SampleBox& tile, Framebuffer& fb) {
  std::int64_t area = edge(a, b, c.x, c.y);
  if (area == 0) return;
  if (area < 0) {
    std::swap(b, c);
    area = -area;
  }
  SampleBox box = sample_box(a, b, c, fb.w, fb.h);
  box.x0 = std::max(box.x0, tile.x0);
  box.y0 = std::max(box.y0, tile.y0);
  box.x1 = std::min(box.x1, tile.x1);
  box.y1 = std::min(box.y1, tile.y1);
  if (box.empty()) return;
  // Non-owned edges need a strictly positive edge function: test w + bias > 0 with bias 1 for
  // owned edges (w >= 0) and 0 otherwise (w > 0).
  const std::int64_t bias0 = owns_edge(b, c) ? 1 : 0;
  const std::int64_t bias1 = owns_edge(c, a) ? 1 : 0;
  const std::int64_t bias2 = owns_edge(a, b) ? 1 : 0;
  const std::int64_t px0 = std::int64_t{box.x0} * kSubOne + kSubOne / 2;
  const std::int64_t py0 = std::int64_t{box.y0} * kSubOne + kSubOne / 2;
  std::int64_t row0 = edge(b, c, px0, py0), row1 = edge(c, a, px0, py0),
               row2 = edge(a, b, px0, py0);
  // Steps of the edge functions per sample in x and y.
  const std::int64_t sx0 = -(std::int64_t{c.y} - b.y) * kSubOne,
                     sy0 = (std::int64_t{c.x} - b.x) * kSubOne;
  const std::int64_t sx1 = -(std::int64_t{a.y} - c.y) * kSubOne,
                     sy1 = (std::int64_t{a.x} - c.x) * kSubOne;
  const std::int64_t sx2 = -(std::int64_t{b.y} - a.y) * kSubOne,
                     sy2 = (std::int64_t{b.x} - a.x) * kSubOne;
  const double inv_area = 1.0 / static_cast<double>(area);
  for (int y = box.y0; y <= box.y1; ++y) {
    std::int64_t w0 = row0, w1 = row1, w2 = row2;
    std::size_t idx = static_cast<std::size_t>(y) * fb.w + box.x0;
    for (int x = box.x0; x <= box.x1; ++x, ++idx) {
      if ((w0 + bias0) > 0 && (w1 + bias1) > 0 && (w2 + bias2) > 0) {
        const float z =
            static_cast<float>((static_cast<double>(w0) * a.z + static_cast<double>(w1) * b.z +
                                static_cast<double>(w2) * c.z) *
                               inv_area);
        if (z > fb.depth[idx]) {  // strict: the earlier face wins a tie
          fb.depth[idx] = z;
          fb.face[idx] = f;
        }
      }
      w0 += sx0;
      w1 += sx1;
      w2 += sx2;
    }
    row0 += sy0;
    row1 += sy1;
    row2 += sy2;
  }
}

/// Per tile, the faces that may cover it, in increasing face order.
struct TileBins {
  int tiles_x = 0, tiles_y = 0;
  std::vector<std::size_t> begin;  ///< tiles + 1 offsets into faces
  std::vector<std::uint32_t> faces;
  std::size_t tiles() const { return static_cast<std::size_t>(tiles_x) * tiles_y; }
};

// Fixed chunks of triangles count their tiles, a prefix sum orders the lists by (tile, chunk),
// the chunks fill them: no atomics, and each tile's list is in face order.
TileBins bin_triangles(const TriMesh& mesh, const std::vector<ScreenVertex>& screen, int w, int h) {
  TileBins bins;
  bins.tiles_x = (w + kTile - 1) / kTile;
  bins.tiles_y = (h + kTile - 1) / kTile;
  const std::size_t ntiles = bins.tiles();
  const std::size_t nf = mesh.triangles.size();
  const std::size_t nchunks = (nf + kChunk - 1) / kChunk;
  auto for_each_tile = [&](std::size_t f, auto&& fn) {
    const auto& t = mesh.triangles[f];
    const ScreenVertex &a = screen[t[0]], &b = screen[t[1]], &c = screen[t[2]];
    if (edge(a, b, c.x, c.y) == 0) return;
    const SampleBox box = sample_box(a, b, c, w, h);
    if (box.empty()) return;
    for (int ty = box.y0 / kTile; ty <= box.y1 / kTile; ++ty)
      for (int tx = box.x0 / kTile; tx <= box.x1 / kTile; ++tx)
        fn(static_cast<std::size_t>(ty) * bins.tiles_x + tx);
  };
  auto for_each_chunk = [&](auto&& fn) {
    tbb::parallel_for(std::size_t{0}, nchunks, [&](std::size_t chunk) {
      for (std::size_t f = chunk * kChunk; f < std::min(nf, (chunk + 1) * kChunk); ++f)
        fn(chunk, f);
    });
  };
  std::vector<std::uint32_t> counts(nchunks * ntiles, 0);
  for_each_chunk([&](std::size_t chunk, std::size_t f) {
    for_each_tile(f, [&](std::size_t tile) { ++counts[chunk * ntiles + tile]; });
  });
  std::vector<std::size_t> cursor(nchunks * ntiles);
  bins.begin.assign(ntiles + 1, 0);
  std::size_t total = 0;
  for (std::size_t tile = 0; tile < ntiles; ++tile) {
    bins.begin[tile] = total;
    for (std::size_t chunk = 0; chunk < nchunks; ++chunk) {
      cursor[chunk * ntiles + tile] = total;
      total += counts[chunk * ntiles + tile];
    }
  }
  bins.begin[ntiles] = total;
  bins.faces.resize(total);
  for_each_chunk([&](std::size_t chunk, std::size_t f) {
    for_each_tile(f, [&](std::size_t tile) {
      bins.faces[cursor[chunk * ntiles + tile]++] = static_cast<std::uint32_t>(f);
    });
  });
  return bins;
}

}  // namespace

Framebuffer rasterize(const TriMesh& mesh, const std::vector<ScreenVertex>& screen, int w, int h,
                      const CancelToken* cancel) {
  const TileBins bins = bin_triangles(mesh, screen, w, h);
  throw_if_cancelled(cancel);
  Framebuffer fb;
  fb.w = w;
  fb.h = h;
  fb.depth.assign(static_cast<std::size_t>(w) * h, -std::numeric_limits<float>::infinity());
  fb.face.assign(static_cast<std::size_t>(w) * h, kNoFace);
  tbb::parallel_for(std::size_t{0}, bins.tiles(), [&](std::size_t tile) {
    if (cancel && cancel->requested()) return;
    const int tx = static_cast<int>(tile % bins.tiles_x),
              ty = static_cast<int>(tile / bins.tiles_x);
    const SampleBox tbox{tx * kTile, ty * kTile, std::min(w, (tx + 1) * kTile) - 1,
                         std::min(h, (ty + 1) * kTile) - 1};
    for (std::size_t i = bins.begin[tile]; i < bins.begin[tile + 1]; ++i) {
      const std::uint32_t f = bins.faces[i];
      const auto& t = mesh.triangles[f];
      rasterize_triangle(f, screen[t[0]], screen[t[1]], screen[t[2]], tbox, fb);
    }
  });
  throw_if_cancelled(cancel);
  return fb;
}

}  // namespace qjulia::detail
