#pragma once
/// @file render.h
/// Preview images: a deterministic multi-threaded CPU rasterizer with simple Lambertian,
/// Lambertian and Phong shading. Images and PNG files: image.h; captions: text.h; grids of
/// images: contact_sheet.h.
///
/// Camera: orthographic, looking down -z of the view space (x right, y up, z towards the
/// viewer). The mesh is rotated about its framing centre, then framed automatically (see
/// Framing). Pixel values are the shading values times 255 with no gamma/sRGB encoding, so a
/// pixel's value is proportional to the light it receives.
#include <array>
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"  // ValueRange
#include "qjulia/render/image.h"

namespace qjulia {

/// kSimple: flat per-face Lambert (the face normal, so facets show);
/// kLambert: smooth per-pixel Lambert (interpolated vertex normals);
/// kPhong: kLambert plus a white Phong specular highlight.
enum class Shading { kSimple, kLambert, kPhong };

/// How the object is fitted into the image.
enum class Framing {
  kBox,     ///< the bounding box of the rotated, projected mesh fills the image (tight)
  kSphere,  ///< the sphere about the bounding-box centre through the farthest vertex fills the
            ///< image: the same scale for every rotation
};

/// The accepted ranges of RenderOptions; render() and check_render_options() enforce them.
inline constexpr ValueRange kImageSideRange{1, 16384};  ///< width, height (pixels)
inline constexpr ValueRange kSupersampleRange{1, 8};    ///< samples per pixel side
inline constexpr int kMaxSamplesPerSide = 32768;        ///< max(width, height) * supersample
inline constexpr ValueRange kAmbientRange{0, 1};
inline constexpr ValueRange kSpecularRange{0, 1};
inline constexpr ValueRange kShininessRange{1, 10000};
inline constexpr ValueRange kMarginRange{0, 0.45};
inline constexpr ValueRange kColorComponentRange{0, 1};       ///< RenderOptions::color
inline constexpr ValueRange kRotationRange{-3600, 3600};      ///< degrees
inline constexpr ValueRange kLightComponentRange{-1e6, 1e6};  ///< not all three zero

/// Options of render().
struct RenderOptions {
  int width = 800, height = 800;  ///< pixels, kImageSideRange
  Shading shading = Shading::kPhong;
  std::vector<std::array<double, 3>> lights;  ///< directions towards the lights (view space);
                                              ///< empty = one default light
  double ambient = 0.15;                      ///< kAmbientRange
  double specular = 0.4;                      ///< kSpecularRange (Phong only)
  std::array<double, 3> rotate_deg{0, 0, 0};  ///< about X, then Y, then Z; kRotationRange
  Rgb background{255, 255, 255};

  /// Phong exponent (Phong only), kShininessRange.
  double shininess = 32;
  /// Surface colour (linear RGB, 0..1) where the mesh has no vertex colours.
  std::array<double, 3> color{0.80, 0.78, 0.74};
  /// Use the mesh's vertex colours when it has them.
  bool use_vertex_colors = true;
  Framing framing = Framing::kBox;
  /// Empty border on each side, as a fraction of the smaller image side, kMarginRange.
  double margin = 0.05;
  /// Anti-aliasing: each pixel is the mean of supersample^2 shaded samples, kSupersampleRange.
  int supersample = 1;
  /// Checked between the passes and per tile; when requested, render() throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// The default light direction when RenderOptions::lights is empty: upper left, in front.
std::array<double, 3> default_light();

/// Checks `opts` as render() does, without a mesh (for validating options at the door).
/// @throws InvalidInput naming the option and its accepted range.
void check_render_options(const RenderOptions& opts);

/// Renders `mesh` framed automatically. Same input, same pixels, whatever the thread count.
/// Shading of one light l (unit, view space) at unit normal n, base colour a:
///   a * (ambient + (1 - ambient) * min(1, sum_l max(0, n.l))) + specular * sum_l max(0, r.v)^s
/// with v = (0, 0, 1) and r the reflection of l; clamped to [0, 1]. Faces seen from behind
/// are lit as if their normal were flipped (open meshes render sensibly). An empty mesh gives
/// an image of the background colour.
/// @throws InvalidInput for a bad size or option, an out-of-range vertex index, non-finite
///         positions, or normals/colours whose count is neither 0 nor the vertex count;
///         Cancelled when opts.cancel is requested.
Image render(const TriMesh& mesh, const RenderOptions& opts = {});

}  // namespace qjulia
