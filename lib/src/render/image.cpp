// Images: construction, the shared pixel operations, PNG files (libpng's simplified API).
#include "qjulia/render/image.h"

#include <png.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"

namespace qjulia {

Image make_image(int width, int height, const Rgb& background) {
  if (width < 0 || height < 0)
    throw InvalidInput("image: size " + std::to_string(width) + "x" + std::to_string(height) +
                       " is negative");
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(static_cast<std::size_t>(width) * height * 3);
  for (std::size_t i = 0; i < image.rgb.size(); i += 3)
    std::copy(background.begin(), background.end(), image.rgb.begin() + i);
  return image;
}

void check_image(const Image& image, const std::string& what) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw InvalidInput(what + ": image of " + std::to_string(image.width) + "x" +
                       std::to_string(image.height) + " pixels has " +
                       std::to_string(image.rgb.size()) + " bytes of RGB data");
}

void fill_rect(Image& image, int x0, int y0, int x1, int y1, const Rgb& color) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, image.width);
  y1 = std::min(y1, image.height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      std::copy(color.begin(), color.end(),
                &image.rgb[(static_cast<std::size_t>(y) * image.width + x) * 3]);
}

void blit(Image& dst, const Image& src, int x, int y) {
  const int x0 = std::max(x, 0), x1 = std::min(x + src.width, dst.width);
  if (x0 >= x1) return;
  for (int row = std::max(y, 0); row < std::min(y + src.height, dst.height); ++row)
    std::copy_n(&src.rgb[(static_cast<std::size_t>(row - y) * src.width + (x0 - x)) * 3],
                (x1 - x0) * 3, &dst.rgb[(static_cast<std::size_t>(row) * dst.width + x0) * 3]);
}

bool is_png_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png";
}

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
  AtomicFile file(path);
  file.write(bytes.data(), size);
  file.commit();
}

Image read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str()))
    throw InvalidInput("read_png: " + path + ": " + png.message);
  png.format = PNG_FORMAT_RGB;
  // The header's size is checked before the pixels are allocated: a 1 kB file may announce
  // gigapixels.
  const std::size_t bytes = PNG_IMAGE_SIZE(png);
  const MemoryLimits limits = memory_limits();
  if (bytes > limits.effective()) {
    png_image_free(&png);
    throw TooLarge("read_png: " + path + ": " + std::to_string(png.width) + "x" +
                   std::to_string(png.height) + " pixels need " + format_bytes(bytes) +
                   ", more than the " + limits.describe() + " available");
  }
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(bytes);
  const png_color white{255, 255, 255};
  if (!png_image_finish_read(&png, &white, image.rgb.data(), 0, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    throw InvalidInput("read_png: " + path + ": " + message);
  }
  return image;
}

}  // namespace qjulia
