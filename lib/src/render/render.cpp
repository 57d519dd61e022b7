// Preview images: a tiled z-buffer rasterizer with deferred shading, PNG I/O, contact sheets.
//
// Determinism: every pass writes disjoint outputs (vertices, chunks of triangles, tiles, rows)
// and each tile draws its triangles in index order with a strict depth test, so the image does
// not depend on how TBB schedules the work or on the thread count. There are no reductions.
#include "qjulia/render/render.h"

#include <fcntl.h>
#include <png.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "render/font5x7.h"

namespace qjulia {
namespace {

using Vec3 = std::array<double, 3>;

constexpr int kSubBits = 8;  // sub-pixel precision of the rasterizer (1/256 pixel)
constexpr std::int64_t kSubOne = std::int64_t{1} << kSubBits;
constexpr int kTile = 64;             // tile side in (super)samples
constexpr std::size_t kChunk = 8192;  // triangles per binning chunk (fixed: determinism)
constexpr std::uint32_t kNoFace = 0xffffffffu;
constexpr int kMaxSide = 16384;         // output pixels per side
constexpr int kMaxSamplesSide = 32768;  // samples per side (fixed-point range)

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 normalized(const Vec3& v) {
  const double n = std::sqrt(dot(v, v));
  return n > 0 ? Vec3{v[0] / n, v[1] / n, v[2] / n} : Vec3{0, 0, 0};
}

bool finite3(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

void require(bool ok, const std::string& message) {
  if (!ok) throw InvalidInput("render: " + message);
}

void validate_options(const RenderOptions& o) {
  require(o.width >= 1 && o.width <= kMaxSide && o.height >= 1 && o.height <= kMaxSide,
          "size " + std::to_string(o.width) + "x" + std::to_string(o.height) +
              " is out of range (1..16384 per side)");
  require(o.supersample >= 1 && o.supersample <= 8, "supersample must be 1..8");
  require(std::max(o.width, o.height) * o.supersample <= kMaxSamplesSide,
          "size times supersample must be at most 32768 per side");
  require(o.ambient >= 0 && o.ambient <= 1, "ambient must be in [0, 1]");
  require(o.specular >= 0 && o.specular <= 1, "specular must be in [0, 1]");
  require(o.shininess >= 1 && o.shininess <= 10000, "shininess must be in [1, 10000]");
  require(o.margin >= 0 && o.margin <= 0.45, "margin must be in [0, 0.45]");
  for (double c : o.color) require(c >= 0 && c <= 1, "color components must be in [0, 1]");
  for (double r : o.rotate_deg) require(std::isfinite(r), "rotation angles must be finite");
  for (std::size_t i = 0; i < o.lights.size(); ++i) {
    const Vec3& l = o.lights[i];
    require(finite3(l) && dot(l, l) > 0,
            "light " + std::to_string(i + 1) + " must be a finite non-zero direction");
  }
}

void validate(const TriMesh& mesh, const RenderOptions& o) {
  validate_options(o);
  validate_mesh(mesh, "render");
}

/// R = Rz * Ry * Rx: rotation about X first, then Y, then Z (degrees).
std::array<Vec3, 3> rotation_matrix(const std::array<double, 3>& deg) {
  const double k = M_PI / 180.0;
  const double cx = std::cos(deg[0] * k), sx = std::sin(deg[0] * k);
  const double cy = std::cos(deg[1] * k), sy = std::sin(deg[1] * k);
  const double cz = std::cos(deg[2] * k), sz = std::sin(deg[2] * k);
  return {{{cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx},
           {sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx},
           {-sy, cy * sx, cy * cx}}};
}

Vec3 rotate_by(const std::array<Vec3, 3>& m, const Vec3& v) {
  return {dot(m[0], v), dot(m[1], v), dot(m[2], v)};
}

/// floor(a / b) for b > 0.
std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/// Screen-space vertex: fixed-point position (1/256 sample, y down) and view depth.
struct ScreenVertex {
  std::int32_t x, y;
  float z;  // larger is nearer the viewer
};

/// The samples (inclusive range) whose centres may lie in the triangle; empty when x0 > x1.
struct SampleBox {
  int x0, y0, x1, y1;
};

SampleBox sample_box(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c, int w,
                     int h) {
  const std::int64_t half = kSubOne / 2;
  const std::int64_t minx = std::min({a.x, b.x, c.x}), maxx = std::max({a.x, b.x, c.x});
  const std::int64_t miny = std::min({a.y, b.y, c.y}), maxy = std::max({a.y, b.y, c.y});
  // Sample i has its centre at i * 256 + 128.
  SampleBox box{static_cast<int>(std::max<std::int64_t>(0, -floor_div(half - minx, kSubOne))),
                static_cast<int>(std::max<std::int64_t>(0, -floor_div(half - miny, kSubOne))),
                static_cast<int>(std::min<std::int64_t>(w - 1, floor_div(maxx - half, kSubOne))),
                static_cast<int>(std::min<std::int64_t>(h - 1, floor_div(maxy - half, kSubOne)))};
  return box;
}

/// Edge function of a -> b at p (fixed point): > 0 on the inner side of a triangle with
/// positive area.
inline std::int64_t edge(const ScreenVertex& a, const ScreenVertex& b, std::int64_t px,
                         std::int64_t py) {
  return (std::int64_t{b.x} - a.x) * (py - a.y) - (std::int64_t{b.y} - a.y) * (px - a.x);
}

/// Top-left style ownership of a shared edge: exactly one of a->b and b->a owns it, so
/// neighbouring triangles neither both draw nor both miss a sample on their common edge.
inline bool owns_edge(const ScreenVertex& a, const ScreenVertex& b) {
  const std::int64_t dx = std::int64_t{b.x} - a.x, dy = std::int64_t{b.y} - a.y;
  return dy > 0 || (dy == 0 && dx < 0);
}

struct Framebuffer {
  int w = 0, h = 0;
  std::vector<float> depth;
  std::vector<std::uint32_t> face;
};

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
  if (box.x0 > box.x1 || box.y0 > box.y1) return;
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

/// The shading model of render(), for one sample; returns linear RGB (unclamped).
struct Shader {
  const RenderOptions& opts;
  std::vector<Vec3> lights;

  Vec3 shade(const Vec3& n, const Vec3& albedo) const {
    double diffuse = 0, spec = 0;
    for (const Vec3& l : lights) {
      const double nl = dot(n, l);
      if (nl <= 0) continue;
      diffuse += nl;
      if (opts.shading == Shading::kPhong) {
        const double rz = 2 * nl * n[2] - l[2];  // (reflected l) . view, view = +z
        if (rz > 0) spec += std::pow(rz, opts.shininess);
      }
    }
    const double k = opts.ambient + (1 - opts.ambient) * std::min(1.0, diffuse);
    const double s = opts.shading == Shading::kPhong ? opts.specular * spec : 0.0;
    return {albedo[0] * k + s, albedo[1] * k + s, albedo[2] * k + s};
  }
};

std::uint8_t to_byte(double v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

}  // namespace

void check_render_options(const RenderOptions& opts) { validate_options(opts); }

std::array<double, 3> default_light() {
  const Vec3 l = normalized({-0.5, 0.6, 1.0});
  return l;
}

Image render(const TriMesh& mesh, const RenderOptions& opts) {
  validate(mesh, opts);
  Image image;
  image.width = opts.width;
  image.height = opts.height;
  image.rgb.resize(static_cast<std::size_t>(opts.width) * opts.height * 3);
  for (std::size_t i = 0; i < image.rgb.size(); i += 3)
    std::copy(opts.background.begin(), opts.background.end(), image.rgb.begin() + i);

  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  if (nf == 0) return image;

  // Vertices used by some face decide the framing (stray vertices are ignored).
  std::vector<char> used(nv, 0);
  for (const auto& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;

  const auto rot = rotation_matrix(opts.rotate_deg);
  Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    const auto& p = mesh.positions[v];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double{p[k]});
      hi[k] = std::max(hi[k], double{p[k]});
    }
  }
  // View space: rotated about the model's bounding-box centre.
  const Vec3 model_centre{(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
  std::vector<Vec3> view(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const auto& p = mesh.positions[v];
      view[v] = rotate_by(rot, sub({p[0], p[1], p[2]}, model_centre));
    }
  });

  const int ss = opts.supersample;
  const int sw = opts.width * ss, sh = opts.height * ss;
  const double avail = std::min(opts.width, opts.height) * (1 - 2 * opts.margin) * ss;
  double cx = 0, cy = 0, scale = 1;
  if (opts.framing == Framing::kSphere) {
    double r2 = 0;
    for (std::size_t v = 0; v < nv; ++v)
      if (used[v]) r2 = std::max(r2, dot(view[v], view[v]));
    if (r2 > 0) scale = avail / (2 * std::sqrt(r2));
  } else {
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
    for (std::size_t v = 0; v < nv; ++v) {
      if (!used[v]) continue;
      x0 = std::min(x0, view[v][0]);
      x1 = std::max(x1, view[v][0]);
      y0 = std::min(y0, view[v][1]);
      y1 = std::max(y1, view[v][1]);
    }
    cx = (x0 + x1) / 2;
    cy = (y0 + y1) / 2;
    const double margin_px = std::min(opts.width, opts.height) * opts.margin * ss;
    const double sx = (x1 - x0) / (sw - 2 * margin_px), sy = (y1 - y0) / (sh - 2 * margin_px);
    const double extent = std::max(sx, sy);
    if (extent > 0) scale = 1 / extent;
  }

  std::vector<ScreenVertex> screen(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const double px = (view[v][0] - cx) * scale + sw / 2.0;
      const double py = sh / 2.0 - (view[v][1] - cy) * scale;
      screen[v] = {static_cast<std::int32_t>(std::lround(px * kSubOne)),
                   static_cast<std::int32_t>(std::lround(py * kSubOne)),
                   static_cast<float>(view[v][2])};
    }
  });

  // Binning: tile lists hold face indices in increasing order, built without atomics.
  const int tiles_x = (sw + kTile - 1) / kTile, tiles_y = (sh + kTile - 1) / kTile;
  const std::size_t ntiles = static_cast<std::size_t>(tiles_x) * tiles_y;
  const std::size_t nchunks = (nf + kChunk - 1) / kChunk;
  std::vector<std::uint32_t> counts(nchunks * ntiles, 0);
  auto for_each_tile = [&](std::size_t f, auto&& fn) {
    const auto& t = mesh.triangles[f];
    const ScreenVertex &a = screen[t[0]], &b = screen[t[1]], &c = screen[t[2]];
    if (edge(a, b, c.x, c.y) == 0) return;
    const SampleBox box = sample_box(a, b, c, sw, sh);
    if (box.x0 > box.x1 || box.y0 > box.y1) return;
    for (int ty = box.y0 / kTile; ty <= box.y1 / kTile; ++ty)
      for (int tx = box.x0 / kTile; tx <= box.x1 / kTile; ++tx)
        fn(static_cast<std::size_t>(ty) * tiles_x + tx);
  };
  tbb::parallel_for(std::size_t{0}, nchunks, [&](std::size_t chunk) {
    std::uint32_t* cnt = &counts[chunk * ntiles];
    for (std::size_t f = chunk * kChunk; f < std::min(nf, (chunk + 1) * kChunk); ++f)
      for_each_tile(f, [&](std::size_t tile) { ++cnt[tile]; });
  });
  // Offsets ordered by (tile, chunk) so each tile's list is in face order.
  std::vector<std::size_t> cursor(nchunks * ntiles);
  std::vector<std::size_t> tile_begin(ntiles + 1, 0);
  std::size_t total = 0;
  for (std::size_t tile = 0; tile < ntiles; ++tile) {
    tile_begin[tile] = total;
    for (std::size_t chunk = 0; chunk < nchunks; ++chunk) {
      cursor[chunk * ntiles + tile] = total;
      total += counts[chunk * ntiles + tile];
    }
  }
  tile_begin[ntiles] = total;
  std::vector<std::uint32_t> bins(total);
  tbb::parallel_for(std::size_t{0}, nchunks, [&](std::size_t chunk) {
    std::size_t* cur = &cursor[chunk * ntiles];
    for (std::size_t f = chunk * kChunk; f < std::min(nf, (chunk + 1) * kChunk); ++f)
      for_each_tile(f,
                    [&](std::size_t tile) { bins[cur[tile]++] = static_cast<std::uint32_t>(f); });
  });

  Framebuffer fb;
  fb.w = sw;
  fb.h = sh;
  fb.depth.assign(static_cast<std::size_t>(sw) * sh, -std::numeric_limits<float>::infinity());
  fb.face.assign(static_cast<std::size_t>(sw) * sh, kNoFace);
  tbb::parallel_for(std::size_t{0}, ntiles, [&](std::size_t tile) {
    const int tx = static_cast<int>(tile % tiles_x), ty = static_cast<int>(tile / tiles_x);
    const SampleBox tbox{tx * kTile, ty * kTile, std::min(sw, (tx + 1) * kTile) - 1,
                         std::min(sh, (ty + 1) * kTile) - 1};
    for (std::size_t i = tile_begin[tile]; i < tile_begin[tile + 1]; ++i) {
      const std::uint32_t f = bins[i];
      const auto& t = mesh.triangles[f];
      rasterize_triangle(f, screen[t[0]], screen[t[1]], screen[t[2]], tbox, fb);
    }
  });

  // Vertex normals in view space: the mesh's own, else area-weighted face normals.
  const bool smooth = opts.shading != Shading::kSimple;
  std::vector<Vec3> normals;
  if (smooth) {
    normals.assign(nv, Vec3{0, 0, 0});
    if (!mesh.normals.empty()) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
        for (std::size_t v = r.begin(); v != r.end(); ++v) {
          const auto& n = mesh.normals[v];
          const Vec3 m{n[0], n[1], n[2]};
          normals[v] = finite3(m) ? normalized(rotate_by(rot, m)) : Vec3{0, 0, 0};
        }
      });
    } else {
      for (const auto& t : mesh.triangles) {  // serial: a fixed summation order
        const Vec3 fn = cross(sub(view[t[1]], view[t[0]]), sub(view[t[2]], view[t[0]]));
        for (std::uint32_t v : t)
          for (int k = 0; k < 3; ++k) normals[v][k] += fn[k];
      }
    }
  }

  Shader shader{opts, {}};
  if (opts.lights.empty()) shader.lights.push_back(default_light());
  for (const Vec3& l : opts.lights) shader.lights.push_back(normalized(l));
  const bool vertex_colors = opts.use_vertex_colors && !mesh.colors.empty();
  const Vec3 bg{opts.background[0] / 255.0, opts.background[1] / 255.0, opts.background[2] / 255.0};

  auto shade_sample = [&](int sx, int sy) -> Vec3 {
    const std::uint32_t f = fb.face[static_cast<std::size_t>(sy) * sw + sx];
    if (f == kNoFace) return bg;
    const auto& t = mesh.triangles[f];
    const ScreenVertex &a = screen[t[0]], &b = screen[t[1]], &c = screen[t[2]];
    const std::int64_t px = std::int64_t{sx} * kSubOne + kSubOne / 2;
    const std::int64_t py = std::int64_t{sy} * kSubOne + kSubOne / 2;
    // Barycentric weights (orthographic: screen-space weights are the surface's own).
    const double area = static_cast<double>(edge(a, b, c.x, c.y));
    const double wa = static_cast<double>(edge(b, c, px, py)) / area;
    const double wb = static_cast<double>(edge(c, a, px, py)) / area;
    const double wc = 1 - wa - wb;
    Vec3 face_n = normalized(cross(sub(view[t[1]], view[t[0]]), sub(view[t[2]], view[t[0]])));
    const bool back = face_n[2] < 0;
    Vec3 n = face_n;
    if (smooth) {
      const Vec3 &na = normals[t[0]], &nb = normals[t[1]], &nc = normals[t[2]];
      n = normalized({wa * na[0] + wb * nb[0] + wc * nc[0], wa * na[1] + wb * nb[1] + wc * nc[1],
                      wa * na[2] + wb * nb[2] + wc * nc[2]});
      if (dot(n, n) == 0) n = face_n;
      // Normals that disagree with the winding (inverted normals in a file) follow the face.
      if (dot(n, face_n) < 0) n = {-n[0], -n[1], -n[2]};
    }
    if (back) n = {-n[0], -n[1], -n[2]};  // seen from behind: light the visible side
    Vec3 albedo = opts.color;
    if (vertex_colors) {
      const auto &ca = mesh.colors[t[0]], &cb = mesh.colors[t[1]], &cc = mesh.colors[t[2]];
      for (int k = 0; k < 3; ++k)
        albedo[k] = std::clamp(wa * ca[k] + wb * cb[k] + wc * cc[k], 0.0, 1.0);
    }
    const Vec3 s = shader.shade(n, albedo);
    return {std::clamp(s[0], 0.0, 1.0), std::clamp(s[1], 0.0, 1.0), std::clamp(s[2], 0.0, 1.0)};
  };

  const double inv_samples = 1.0 / (ss * ss);
  tbb::parallel_for(0, opts.height, [&](int y) {
    for (int x = 0; x < opts.width; ++x) {
      Vec3 sum{0, 0, 0};
      bool any = false;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          any |= fb.face[static_cast<std::size_t>(y * ss + j) * sw + x * ss + i] != kNoFace;
          const Vec3 s = shade_sample(x * ss + i, y * ss + j);
          for (int k = 0; k < 3; ++k) sum[k] += s[k];
        }
      if (!any) continue;  // keep the exact background bytes
      std::uint8_t* out = &image.rgb[(static_cast<std::size_t>(y) * opts.width + x) * 3];
      for (int k = 0; k < 3; ++k) out[k] = to_byte(sum[k] * inv_samples);
    }
  });
  return image;
}

// ---------------------------------------------------------------------------------------------
// PNG

namespace {

void check_image(const Image& image, const std::string& what) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw InvalidInput(what + ": image of " + std::to_string(image.width) + "x" +
                       std::to_string(image.height) + " pixels has " +
                       std::to_string(image.rgb.size()) + " bytes of RGB data");
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename.
void write_file_atomically(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  static std::atomic<unsigned> counter{0};
  const std::string tmp =
      path + ".tmp" + std::to_string(::getpid()) + "." + std::to_string(counter.fetch_add(1));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw std::runtime_error("cannot create " + tmp + ": " + std::strerror(errno));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw std::runtime_error("cannot write " + tmp + ": " + std::strerror(err));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0 || std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(err));
  }
}

}  // namespace

void write_png(const std::string& path, const Image& image) {
  check_image(image, "write_png " + path);
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  // An all-grey image (no vertex colours, grey surface and background) is stored as a
  // greyscale PNG: the same pixels in about a third of the data.
  bool grey = true;
  for (std::size_t i = 0; i < image.rgb.size() && grey; i += 3)
    grey = image.rgb[i] == image.rgb[i + 1] && image.rgb[i] == image.rgb[i + 2];
  std::vector<std::uint8_t> grey_pixels;
  const void* pixels = image.rgb.data();
  png.format = PNG_FORMAT_RGB;
  if (grey) {
    grey_pixels.resize(image.rgb.size() / 3);
    for (std::size_t i = 0; i < grey_pixels.size(); ++i) grey_pixels[i] = image.rgb[3 * i];
    pixels = grey_pixels.data();
    png.format = PNG_FORMAT_GRAY;
  }
  png_alloc_size_t size = 0;
  // First call measures, second encodes (libpng's simplified API, no setjmp needed).
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, pixels, 0, nullptr))
    throw std::runtime_error("write_png " + path + ": " + png.message);
  std::vector<std::uint8_t> bytes(size);
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, pixels, 0, nullptr))
    throw std::runtime_error("write_png " + path + ": " + png.message);
  bytes.resize(size);
  write_file_atomically(path, bytes);
}

Image read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str()))
    throw InvalidInput("read_png: " + path + ": " + png.message);
  png.format = PNG_FORMAT_RGB;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  const png_color white{255, 255, 255};
  if (!png_image_finish_read(&png, &white, image.rgb.data(), 0, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    throw InvalidInput("read_png: " + path + ": " + message);
  }
  return image;
}

// ---------------------------------------------------------------------------------------------
// Text and contact sheets

namespace {

/// The characters drawn for `text`: bytes, except that a UTF-8 sequence is one '?'.
std::string glyph_chars(const std::string& text) {
  std::string out;
  for (char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x80 && u < 0xc0) continue;  // UTF-8 continuation byte
    out.push_back(u >= 0x80 ? '?' : c);
  }
  return out;
}

}  // namespace

int text_width(const std::string& text, int scale) {
  const std::size_t n = glyph_chars(text).size();
  if (n == 0) return 0;
  return (static_cast<int>(n) * detail::kGlyphAdvance - 1) * scale;
}

int text_height(int scale) { return detail::kGlyphHeight * scale; }

void draw_text(Image& image, int x, int y, const std::string& text,
               const std::array<std::uint8_t, 3>& color, int scale) {
  check_image(image, "draw_text");
  if (scale < 1) throw InvalidInput("draw_text: scale must be at least 1");
  const std::string chars = glyph_chars(text);
  for (std::size_t i = 0; i < chars.size(); ++i) {
    const std::uint8_t* g = detail::glyph(chars[i]);
    const int gx = x + static_cast<int>(i) * detail::kGlyphAdvance * scale;
    for (int row = 0; row < detail::kGlyphHeight; ++row)
      for (int col = 0; col < detail::kGlyphWidth; ++col) {
        if (!(g[row] & (0x10 >> col))) continue;
        for (int dy = 0; dy < scale; ++dy)
          for (int dx = 0; dx < scale; ++dx) {
            const int px = gx + col * scale + dx, py = y + row * scale + dy;
            if (px < 0 || py < 0 || px >= image.width || py >= image.height) continue;
            std::uint8_t* out = &image.rgb[(static_cast<std::size_t>(py) * image.width + px) * 3];
            std::copy(color.begin(), color.end(), out);
          }
      }
  }
}

Image contact_sheet(const std::vector<std::pair<Image, std::string>>& cells, int columns,
                    const ContactSheetOptions& opts) {
  if (columns < 1) throw InvalidInput("contact_sheet: columns must be at least 1");
  if (opts.padding < 0 || opts.padding > 1000)
    throw InvalidInput("contact_sheet: padding must be in [0, 1000]");
  if (opts.text_scale < 1 || opts.text_scale > 16)
    throw InvalidInput("contact_sheet: text_scale must be in [1, 16]");
  if (cells.empty()) return {};
  int slot_w = 0, slot_h = 0;
  bool captions = false;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    check_image(cells[i].first, "contact_sheet cell " + std::to_string(i + 1));
    slot_w = std::max(slot_w, cells[i].first.width);
    slot_h = std::max(slot_h, cells[i].first.height);
    captions |= !cells[i].second.empty();
  }
  const int pad = opts.padding, ts = opts.text_scale;
  const int caption_h = captions ? pad / 2 + text_height(ts) : 0;
  const int cell_w = slot_w + 2 * pad, cell_h = pad + slot_h + caption_h + pad;
  const int cols = std::min<int>(columns, static_cast<int>(cells.size()));
  const int rows = (static_cast<int>(cells.size()) + cols - 1) / cols;
  Image sheet;
  sheet.width = cols * cell_w;
  sheet.height = rows * cell_h;
  if (static_cast<double>(sheet.width) * sheet.height > 1e9)
    throw InvalidInput("contact_sheet: the sheet would exceed 1e9 pixels");
  sheet.rgb.resize(static_cast<std::size_t>(sheet.width) * sheet.height * 3);
  for (std::size_t i = 0; i < sheet.rgb.size(); i += 3)
    std::copy(opts.background.begin(), opts.background.end(), sheet.rgb.begin() + i);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Image& img = cells[i].first;
    const int x0 = static_cast<int>(i % cols) * cell_w + pad + (slot_w - img.width) / 2;
    const int y0 = static_cast<int>(i / cols) * cell_h + pad + (slot_h - img.height) / 2;
    for (int y = 0; y < img.height; ++y)
      std::copy_n(&img.rgb[static_cast<std::size_t>(y) * img.width * 3], img.width * 3,
                  &sheet.rgb[(static_cast<std::size_t>(y0 + y) * sheet.width + x0) * 3]);
    std::string text = cells[i].second;
    const int max_text = cell_w - std::max(2, pad);  // keep neighbouring captions apart
    if (text_width(text, ts) > max_text) {
      text = glyph_chars(text);
      while (!text.empty() && text_width(text + "..", ts) > max_text) text.pop_back();
      text += "..";
    }
    const int tx = static_cast<int>(i % cols) * cell_w + (cell_w - text_width(text, ts)) / 2;
    const int ty = static_cast<int>(i / cols) * cell_h + pad + slot_h + pad / 2;
    draw_text(sheet, tx, ty, text, opts.text_color, ts);
  }
  return sheet;
}

}  // namespace qjulia
