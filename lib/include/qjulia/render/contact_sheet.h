#pragma once
/// @file contact_sheet.h
/// Contact sheets: captioned images laid out in a grid.
#include <string>
#include <utility>
#include <vector>

#include "qjulia/render/image.h"

namespace qjulia {

/// Options of contact_sheet().
struct ContactSheetOptions {
  Rgb background{255, 255, 255};
  Rgb text_color{32, 32, 32};
  int padding = 8;               ///< pixels around every cell, 0..1000
  int text_scale = 2;            ///< each font pixel is text_scale^2 image pixels, 1..16
  bool center_last_row = false;  ///< a last row with fewer cells is centred, not left-aligned
};

/// Lays out `cells` (image, caption) in a grid of `columns` columns, row by row; each image is
/// centred in a slot as large as the largest image, with its caption centred below it
/// (embedded 5x7 font, printable ASCII; other characters show as '?'; captions too wide for the
/// cell are cut and end in ".."). Cell: padding + image + padding / 2 + text_height + padding
/// high, image + 2 * padding wide. No cells gives an empty (0 x 0) image.
/// @throws InvalidInput when columns < 1, an option is out of range, a cell's image is
///         inconsistent (rgb size != width * height * 3), or the sheet would exceed 1e9 pixels.
Image contact_sheet(const std::vector<std::pair<Image, std::string>>& cells, int columns,
                    const ContactSheetOptions& opts = {});

}  // namespace qjulia
