// Preview images: the camera and its framing, the z-buffer pass (raster.h), then deferred
// shading of every sample and the average of the supersamples.
//
// Determinism: every pass writes disjoint outputs (vertices, tiles, rows), and the vertex
// normals are summed in face order at each vertex (base's area_weighted_normals), so the image does
// not depend on how TBB schedules the work or on the thread count.
#include "qjulia/render/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "base/geometry.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "render/raster.h"

namespace qjulia {
namespace {

using detail::Framebuffer;
using detail::kNoFace;
using detail::kSubOne;
using detail::ScreenVertex;
using Vec3 = detail::Vec3d;
using Mat3 = std::array<Vec3, 3>;
using detail::to_vec3d;

bool finite3(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

void require(bool ok, const std::string& message) {
  if (!ok) throw InvalidInput("render: " + message);
}

void require_in(double v, const ValueRange& range, const std::string& name) {
  require(range.contains(v), name + " must be in " + to_string(range));
}

void validate_options(const RenderOptions& o) {
  require(kImageSideRange.contains(o.width) && kImageSideRange.contains(o.height),
          "size " + std::to_string(o.width) + "x" + std::to_string(o.height) +
              " is out of range (" + to_string(kImageSideRange) + " per side)");
  require_in(o.supersample, kSupersampleRange, "supersample");
  require(
      std::max(o.width, o.height) * o.supersample <= kMaxSamplesPerSide,
      "size times supersample must be at most " + std::to_string(kMaxSamplesPerSide) + " per side");
  require_in(o.ambient, kAmbientRange, "ambient");
  require_in(o.specular, kSpecularRange, "specular");
  require_in(o.shininess, kShininessRange, "shininess");
  require_in(o.margin, kMarginRange, "margin");
  for (double c : o.color) require_in(c, kColorComponentRange, "color components");
  for (double r : o.rotate_deg) require_in(r, kRotationRange, "rotation angles (degrees)");
  for (std::size_t i = 0; i < o.lights.size(); ++i) {
    const std::string name = "light " + std::to_string(i + 1);
    for (double c : o.lights[i]) require_in(c, kLightComponentRange, name + " components");
    const Vec3 l = to_vec3d(o.lights[i]);
    require(dot(l, l) > 0, name + " must be a non-zero direction");
  }
}

void validate(const TriMesh& mesh, const RenderOptions& o) {
  validate_options(o);
  validate_mesh(mesh, "render");
}

/// R = Rz * Ry * Rx: rotation about X first, then Y, then Z (degrees).
Mat3 rotation_matrix(const std::array<double, 3>& deg) {
  const double k = M_PI / 180.0;
  const double cx = std::cos(deg[0] * k), sx = std::sin(deg[0] * k);
  const double cy = std::cos(deg[1] * k), sy = std::sin(deg[1] * k);
  const double cz = std::cos(deg[2] * k), sz = std::sin(deg[2] * k);
  return {{{cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx},
           {sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx},
           {-sy, cy * sx, cy * cx}}};
}

Vec3 rotate_by(const Mat3& m, const Vec3& v) { return {dot(m[0], v), dot(m[1], v), dot(m[2], v)}; }

template <typename Fn>
void parallel_for_vertices(std::size_t n, Fn&& fn) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) fn(v);
  });
}

/// Where the mesh lands: view-space positions (rotated about the bounding-box centre of the
/// vertices some face uses) and their fixed-point positions in the sample buffer.
struct Projection {
  Mat3 rotation;
  int sw = 0, sh = 0;  ///< sample buffer size: the image times supersample
  std::vector<Vec3> view;
  std::vector<ScreenVertex> screen;
};

/// Offset and scale from view space to samples: the frame of opts.framing fills the image
/// minus the margin. `used` marks the vertices some face uses (stray vertices are ignored).
struct Frame {
  double cx = 0, cy = 0, scale = 1;
};

Frame fit_frame(const std::vector<Vec3>& view, const std::vector<char>& used,
                const RenderOptions& opts) {
  const int ss = opts.supersample;
  const int side = std::min(opts.width, opts.height);
  Frame frame;
  if (opts.framing == Framing::kSphere) {
    double r2 = 0;
    for (std::size_t v = 0; v < view.size(); ++v)
      if (used[v]) r2 = std::max(r2, dot(view[v], view[v]));
    if (r2 > 0) frame.scale = side * (1 - 2 * opts.margin) * ss / (2 * std::sqrt(r2));
    return frame;
  }
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  for (std::size_t v = 0; v < view.size(); ++v) {
    if (!used[v]) continue;
    x0 = std::min(x0, view[v][0]);
    x1 = std::max(x1, view[v][0]);
    y0 = std::min(y0, view[v][1]);
    y1 = std::max(y1, view[v][1]);
  }
  frame.cx = (x0 + x1) / 2;
  frame.cy = (y0 + y1) / 2;
  const double margin_px = side * opts.margin * ss;
  const double sx = (x1 - x0) / (opts.width * ss - 2 * margin_px);
  const double sy = (y1 - y0) / (opts.height * ss - 2 * margin_px);
  const double extent = std::max(sx, sy);
  if (extent > 0) frame.scale = 1 / extent;
  return frame;
}

Projection project(const TriMesh& mesh, const RenderOptions& opts) {
  const std::size_t nv = mesh.positions.size();
  std::vector<char> used(nv, 0);
  for (const auto& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (std::size_t v = 0; v < nv; ++v)
    if (used[v])
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], double{mesh.positions[v][k]});
        hi[k] = std::max(hi[k], double{mesh.positions[v][k]});
      }
  const Vec3 centre{(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};

  Projection p;
  p.rotation = rotation_matrix(opts.rotate_deg);
  p.sw = opts.width * opts.supersample;
  p.sh = opts.height * opts.supersample;
  p.view.resize(nv);
  parallel_for_vertices(nv, [&](std::size_t v) {
    p.view[v] = rotate_by(p.rotation, to_vec3d(mesh.positions[v]) - centre);
  });
  const Frame f = fit_frame(p.view, used, opts);
  p.screen.resize(nv);
  parallel_for_vertices(nv, [&](std::size_t v) {
    const double px = (p.view[v][0] - f.cx) * f.scale + p.sw / 2.0;
    const double py = p.sh / 2.0 - (p.view[v][1] - f.cy) * f.scale;
    p.screen[v] = {static_cast<std::int32_t>(std::lround(px * kSubOne)),
                   static_cast<std::int32_t>(std::lround(py * kSubOne)),
                   static_cast<float>(p.view[v][2])};
  });
  return p;
}

/// Unit vertex normals in view space: the mesh's own, else base's area-weighted ones; (0, 0, 0)
/// where a file's normal is not finite (the face normal is used there).
std::vector<Vec3> view_normals(const TriMesh& mesh, const Mat3& rotation) {
  std::vector<std::array<float, 3>> computed;
  if (mesh.normals.empty()) computed = area_weighted_normals(mesh);
  const auto& source = mesh.normals.empty() ? computed : mesh.normals;
  std::vector<Vec3> normals(source.size());
  parallel_for_vertices(source.size(), [&](std::size_t v) {
    const Vec3 n = to_vec3d(source[v]);
    normals[v] = finite3(n) ? normalized(rotate_by(rotation, n)) : Vec3{0, 0, 0};
  });
  return normals;
}

std::uint8_t to_byte(double v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

/// Deferred shading of one sample from the face the z-buffer left there.
class SurfaceShader {
 public:
  SurfaceShader(const TriMesh& mesh, const RenderOptions& opts, const Projection& p,
                const Framebuffer& fb)
      : mesh_(mesh), opts_(opts), p_(p), fb_(fb) {
    if (opts.shading != Shading::kSimple) normals_ = view_normals(mesh, p.rotation);
    if (opts.lights.empty()) lights_.push_back(to_vec3d(default_light()));
    for (const auto& l : opts.lights) lights_.push_back(normalized(to_vec3d(l)));
    vertex_colors_ = opts.use_vertex_colors && !mesh.colors.empty();
    for (int k = 0; k < 3; ++k) background_[k] = opts.background[k] / 255.0;
  }

  /// Linear RGB in [0, 1] of sample (sx, sy).
  Vec3 sample(int sx, int sy) const {
    const std::uint32_t f = fb_.face_at(sx, sy);
    if (f == kNoFace) return background_;
    const auto& t = mesh_.triangles[f];
    const ScreenVertex &a = p_.screen[t[0]], &b = p_.screen[t[1]], &c = p_.screen[t[2]];
    const std::int64_t px = std::int64_t{sx} * kSubOne + kSubOne / 2;
    const std::int64_t py = std::int64_t{sy} * kSubOne + kSubOne / 2;
    // Barycentric weights (orthographic: screen-space weights are the surface's own).
    const double area = static_cast<double>(detail::edge(a, b, c.x, c.y));
    const Vec3 w{static_cast<double>(detail::edge(b, c, px, py)) / area,
                 static_cast<double>(detail::edge(c, a, px, py)) / area, 0};
    const double wc = 1 - w[0] - w[1];
    auto blend = [&](const Vec3& va, const Vec3& vb, const Vec3& vc) {
      return Vec3{w[0] * va[0] + w[1] * vb[0] + wc * vc[0],
                  w[0] * va[1] + w[1] * vb[1] + wc * vc[1],
                  w[0] * va[2] + w[1] * vb[2] + wc * vc[2]};
    };
    const std::vector<Vec3>& view = p_.view;
    const Vec3 face_n = normalized(cross(view[t[1]] - view[t[0]], view[t[2]] - view[t[0]]));
    Vec3 n = face_n;
    if (!normals_.empty()) {
      n = normalized(blend(normals_[t[0]], normals_[t[1]], normals_[t[2]]));
      if (dot(n, n) == 0) n = face_n;
      // Normals that disagree with the winding (inverted normals in a file) follow the face.
      if (dot(n, face_n) < 0) n = -n;
    }
    if (face_n[2] < 0) n = -n;  // seen from behind: light the visible side
    Vec3 albedo = to_vec3d(opts_.color);
    if (vertex_colors_) {
      albedo = blend(to_vec3d(mesh_.colors[t[0]]), to_vec3d(mesh_.colors[t[1]]),
                     to_vec3d(mesh_.colors[t[2]]));
      for (int k = 0; k < 3; ++k) albedo[k] = std::clamp(albedo[k], 0.0, 1.0);
    }
    const Vec3 s = shade(n, albedo);
    return {std::clamp(s[0], 0.0, 1.0), std::clamp(s[1], 0.0, 1.0), std::clamp(s[2], 0.0, 1.0)};
  }

 private:
  /// The shading model of render.h, unclamped.
  Vec3 shade(const Vec3& n, const Vec3& albedo) const {
    double diffuse = 0, spec = 0;
    for (const Vec3& l : lights_) {
      const double nl = dot(n, l);
      if (nl <= 0) continue;
      diffuse += nl;
      if (opts_.shading == Shading::kPhong) {
        const double rz = 2 * nl * n[2] - l[2];  // (reflected l) . view, view = +z
        if (rz > 0) spec += std::pow(rz, opts_.shininess);
      }
    }
    const double k = opts_.ambient + (1 - opts_.ambient) * std::min(1.0, diffuse);
    const double s = opts_.shading == Shading::kPhong ? opts_.specular * spec : 0.0;
    return {albedo[0] * k + s, albedo[1] * k + s, albedo[2] * k + s};
  }

  const TriMesh& mesh_;
  const RenderOptions& opts_;
  const Projection& p_;
  const Framebuffer& fb_;
  std::vector<Vec3> normals_;  // empty for flat shading
  std::vector<Vec3> lights_;
  bool vertex_colors_ = false;
  Vec3 background_{};
};

/// Each pixel: the mean of its supersamples in a fixed order; pixels no face covers keep the
/// exact background bytes.
void resolve(const Framebuffer& fb, const SurfaceShader& shader, const RenderOptions& opts,
             Image& image) {
  const int ss = opts.supersample;
  const double inv_samples = 1.0 / (ss * ss);
  tbb::parallel_for(0, opts.height, [&](int y) {
    if (opts.cancel && opts.cancel->requested()) return;
    for (int x = 0; x < opts.width; ++x) {
      Vec3 sum{0, 0, 0};
      bool any = false;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          any |= fb.face_at(x * ss + i, y * ss + j) != kNoFace;
          const Vec3 s = shader.sample(x * ss + i, y * ss + j);
          for (int k = 0; k < 3; ++k) sum[k] += s[k];
        }
      if (!any) continue;
      std::uint8_t* out = &image.rgb[(static_cast<std::size_t>(y) * opts.width + x) * 3];
      for (int k = 0; k < 3; ++k) out[k] = to_byte(sum[k] * inv_samples);
    }
  });
  throw_if_cancelled(opts.cancel);
}

}  // namespace

void check_render_options(const RenderOptions& opts) { validate_options(opts); }

std::array<double, 3> default_light() {
  const Vec3 l = normalized(Vec3{-0.5, 0.6, 1.0});
  return {l[0], l[1], l[2]};
}

Image render(const TriMesh& mesh, const RenderOptions& opts) {
  validate(mesh, opts);
  Image image = make_image(opts.width, opts.height, opts.background);
  if (mesh.triangles.empty()) return image;
  throw_if_cancelled(opts.cancel);
  const Projection p = project(mesh, opts);
  const Framebuffer fb = detail::rasterize(mesh, p.screen, p.sw, p.sh, opts.cancel);
  const SurfaceShader shader(mesh, opts, p, fb);
  resolve(fb, shader, opts, image);
  return image;
}

}  // namespace qjulia
