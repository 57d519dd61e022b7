// The bitmap font's text: widths, drawing, fitting.
#include "qjulia/render/text.h"

#include "qjulia/base/error.h"
#include "render/font5x7.h"

namespace qjulia {
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

void draw_text(Image& image, int x, int y, const std::string& text, const Rgb& color, int scale) {
  check_image(image, "draw_text");
  if (scale < 1) throw InvalidInput("draw_text: scale must be at least 1");
  const std::string chars = glyph_chars(text);
  for (std::size_t i = 0; i < chars.size(); ++i) {
    const std::uint8_t* g = detail::glyph(chars[i]);
    const int gx = x + static_cast<int>(i) * detail::kGlyphAdvance * scale;
    for (int row = 0; row < detail::kGlyphHeight; ++row)
      for (int col = 0; col < detail::kGlyphWidth; ++col)
        if (g[row] & (0x10 >> col))
          fill_rect(image, gx + col * scale, y + row * scale, gx + (col + 1) * scale,
                    y + (row + 1) * scale, color);
  }
}

std::string fit_text(const std::string& text, int max_width, int scale) {
  if (text_width(text, scale) <= max_width) return text;
  std::string cut = glyph_chars(text);
  while (!cut.empty() && text_width(cut + "..", scale) > max_width) cut.pop_back();
  return cut + "..";
}

}  // namespace qjulia
