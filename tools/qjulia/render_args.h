#pragma once
// The command-line options that shape a rendering, shared by `qjulia render` and
// `qjulia mesh --preview`.
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"
#include "qjulia/render/render.h"

namespace qjulia::cli {

/// --shading, --light (repeatable), --ambient, --specular, --shininess, --rotate, --size,
/// --background, --base-color, --no-vertex-colors, --framing, --margin, --supersample; each
/// name preceded by `prefix` (e.g. "preview-" inside `qjulia mesh`, whose --size is the print
/// size).
std::vector<OptionSpec> render_option_specs(const std::string& prefix = "");

/// RenderOptions from the options of render_option_specs(prefix); defaults where absent.
/// Every value is checked against its range (render.h) before any work starts.
/// @throws InvalidInput naming the flag and the range.
RenderOptions render_options_from_args(const ParsedArgs& args, const std::string& prefix = "");

/// Help lines describing render_option_specs(prefix), two-space indented.
std::string render_options_help(const std::string& prefix = "");

/// "WxH" or "N" (square), sides in kImageSideRange. @throws InvalidInput naming `what`.
std::pair<int, int> parse_image_size(const std::string& text, const std::string& what);

/// "#rrggbb", "#rgb" or "r,g,b" with integers 0..255. @throws InvalidInput naming `what`.
std::array<std::uint8_t, 3> parse_color(const std::string& text, const std::string& what);

}  // namespace qjulia::cli
