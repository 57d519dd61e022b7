#pragma once
/// @file image.h
/// 8-bit RGB images: the type every drawing function of the render stage returns, the few
/// pixel operations they share, and PNG files.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace qjulia {

/// One pixel: red, green, blue, 0..255.
using Rgb = std::array<std::uint8_t, 3>;

/// An 8-bit RGB image, row-major, top row first.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3
};

/// An image of `width` x `height` pixels (0 x 0 is allowed), every pixel `background`.
/// @throws InvalidInput when a side is negative.
Image make_image(int width, int height, const Rgb& background);

/// Checks that `image` has at least one pixel and rgb.size() == width * height * 3.
/// @throws InvalidInput starting with `what` otherwise.
void check_image(const Image& image, const std::string& what);

/// Sets the pixels x0 <= x < x1, y0 <= y < y1 to `color`; the part outside the image is
/// skipped.
void fill_rect(Image& image, int x0, int y0, int x1, int y1, const Rgb& color);

/// Copies `src` into `dst` with its top-left corner at (x, y); the part outside `dst` is
/// skipped.
void blit(Image& dst, const Image& src, int x, int y);

/// Whether `path` ends in .png (any case): the images render and --preview write and read.
bool is_png_path(const std::string& path);

/// Writes a PNG through the library's atomic writer (a temporary file beside `path`, renamed at
/// the end): 8-bit RGB, or 8-bit greyscale when every pixel is grey (same pixels, smaller file).
/// @throws InvalidInput when image.rgb does not hold width * height * 3 bytes or when `path`
///         cannot be created (no such directory, read-only, ...); std::runtime_error when
///         encoding or writing fails.
void write_png(const std::string& path, const Image& image);

/// Reads an 8-bit (or any libpng-convertible) PNG as RGB; alpha is composited over white.
/// @throws InvalidInput naming the file when it cannot be read or is not a PNG.
Image read_png(const std::string& path);

}  // namespace qjulia
