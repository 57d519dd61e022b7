#pragma once
/// @file render.h
/// Preview images: a deterministic multi-threaded CPU rasterizer with simple Lambertian,
/// Lambertian and Phong shading, and contact sheets.
///
/// Camera: orthographic, looking down -z of the view space (x right, y up, z towards the
/// viewer). The mesh is rotated about its framing centre, then framed automatically (see
/// Framing). Pixel values are the shading values times 255 with no gamma/sRGB encoding, so a
/// pixel's value is proportional to the light it receives.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/base/mesh.h"

namespace qjulia {

/// An 8-bit RGB image, row-major, top row first.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3
};

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

/// Options of render().
struct RenderOptions {
  int width = 800, height = 800;  ///< pixels
  Shading shading = Shading::kPhong;
  std::vector<std::array<double, 3>> lights;  ///< directions towards the lights (view space);
                                              ///< empty = one default light
  double ambient = 0.15;                      ///< 0..1
  double specular = 0.4;                      ///< 0..1 (Phong only)
  std::array<double, 3> rotate_deg{0, 0, 0};  ///< rotation about X, then Y, then Z, degrees
  std::array<std::uint8_t, 3> background{255, 255, 255};

  /// Phong exponent (Phong only), 1..10000.
  double shininess = 32;
  /// Surface colour (linear RGB, 0..1) where the mesh has no vertex colours.
  std::array<double, 3> color{0.80, 0.78, 0.74};
  /// Use the mesh's vertex colours when it has them.
  bool use_vertex_colors = true;
  Framing framing = Framing::kBox;
  /// Empty border on each side, as a fraction of the smaller image side, 0..0.45.
  double margin = 0.05;
  /// Anti-aliasing: each pixel is the mean of supersample^2 shaded samples, 1..8.
  int supersample = 1;
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
///         positions, or normals/colours whose count is neither 0 nor the vertex count.
Image render(const TriMesh& mesh, const RenderOptions& opts = {});

/// Writes a PNG through a temporary file: 8-bit RGB, or 8-bit greyscale when every pixel is grey
/// (same pixels, smaller file). @throws std::runtime_error on failure; InvalidInput when
/// image.rgb does not hold width * height * 3 bytes.
void write_png(const std::string& path, const Image& image);

/// Reads an 8-bit (or any libpng-convertible) PNG as RGB; alpha is composited over white.
/// @throws InvalidInput naming the file when it cannot be read or is not a PNG.
Image read_png(const std::string& path);

/// Options of contact_sheet().
struct ContactSheetOptions {
  std::array<std::uint8_t, 3> background{255, 255, 255};
  std::array<std::uint8_t, 3> text_color{32, 32, 32};
  int padding = 8;     ///< pixels around every cell, 0..1000
  int text_scale = 2;  ///< each font pixel is text_scale^2 image pixels, 1..16
};

/// Lays out `cells` (image, caption) in a grid of `columns` columns, row by row; each image is
/// centred in a slot as large as the largest image, with its caption centred below it
/// (embedded 5x7 font, printable ASCII; other characters show as '?'; captions too wide for the
/// cell are cut and end in ".."). Cell: padding + image + padding / 2 + text_height + padding
/// high, image + 2 * padding wide. No cells gives an empty (0 x 0) image.
/// @throws InvalidInput when columns < 1, an option is out of range, or a cell's image is
///         inconsistent (rgb size != width * height * 3).
Image contact_sheet(const std::vector<std::pair<Image, std::string>>& cells, int columns,
                    const ContactSheetOptions& opts = {});

/// Width in pixels of `text` drawn by draw_text() at `scale`.
int text_width(const std::string& text, int scale = 1);
/// Height in pixels of one line of text at `scale`: 9 * scale (7 rows above the baseline, 2
/// for descenders).
int text_height(int scale = 1);

/// Draws `text` with its top-left corner at (x, y) in the embedded 5x7 font (one blank column
/// between glyphs; a UTF-8 sequence or any other non-printable character shows as one '?'),
/// each font pixel a scale x scale square; clipped to the image.
void draw_text(Image& image, int x, int y, const std::string& text,
               const std::array<std::uint8_t, 3>& color, int scale = 1);

}  // namespace qjulia
