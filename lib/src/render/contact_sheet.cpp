// Contact sheets: a grid of equal slots, each an image centred over its caption.
#include "qjulia/render/contact_sheet.h"

#include <algorithm>

#include "qjulia/base/error.h"
#include "qjulia/render/text.h"

namespace qjulia {

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
  const int n = static_cast<int>(cells.size());
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;
  if (static_cast<double>(cols) * cell_w * rows * cell_h > 1e9)
    throw InvalidInput("contact_sheet: the sheet would exceed 1e9 pixels");
  Image sheet = make_image(cols * cell_w, rows * cell_h, opts.background);
  const int last_row_cells = n - (rows - 1) * cols;
  for (int i = 0; i < n; ++i) {
    const int row = i / cols;
    // Cell origin; a short last row is shifted by half the missing width when centred.
    const int shift = opts.center_last_row && row == rows - 1 && last_row_cells < cols
                          ? (cols - last_row_cells) * cell_w / 2
                          : 0;
    const int cx = (i % cols) * cell_w + shift, cy = row * cell_h;
    const Image& img = cells[i].first;
    blit(sheet, img, cx + pad + (slot_w - img.width) / 2, cy + pad + (slot_h - img.height) / 2);
    // Keep neighbouring captions apart.
    const std::string text = fit_text(cells[i].second, cell_w - std::max(2, pad), ts);
    draw_text(sheet, cx + (cell_w - text_width(text, ts)) / 2, cy + pad + slot_h + pad / 2, text,
              opts.text_color, ts);
  }
  return sheet;
}

}  // namespace qjulia
