#pragma once
/// @file text.h
/// Text in images: the one embedded bitmap font (5x7 glyphs with descenders, printable ASCII)
/// that captions, labels and charts use.
#include <string>

#include "qjulia/render/image.h"

namespace qjulia {

/// Width in pixels of `text` drawn by draw_text() at `scale`.
int text_width(const std::string& text, int scale = 1);
/// Height in pixels of one line of text at `scale`: 9 * scale (7 rows above the baseline, 2
/// for descenders).
int text_height(int scale = 1);

/// Draws `text` with its top-left corner at (x, y) in the embedded 5x7 font (one blank column
/// between glyphs; a UTF-8 sequence or any other non-printable character shows as one '?'),
/// each font pixel a scale x scale square; clipped to the image.
/// @throws InvalidInput when `image` is inconsistent or scale < 1.
void draw_text(Image& image, int x, int y, const std::string& text, const Rgb& color,
               int scale = 1);

/// `text` cut so that it is at most `max_width` pixels wide at `scale`: unchanged when it fits,
/// else shortened and ending in "..".
std::string fit_text(const std::string& text, int max_width, int scale = 1);

}  // namespace qjulia
