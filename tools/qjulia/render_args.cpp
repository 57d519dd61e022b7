// The command-line options that shape a rendering.
#include "render_args.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <tuple>

#include "qjulia/base/error.h"

namespace qjulia::cli {

std::vector<OptionSpec> render_option_specs(const std::string& prefix) {
  std::vector<OptionSpec> specs = {
      {"shading", true},          {"light", true},   {"ambient", true}, {"specular", true},
      {"shininess", true},        {"rotate", true},  {"size", true},    {"background", true},
      {"base-color", true},       {"framing", true}, {"margin", true},  {"supersample", true},
      {"no-vertex-colors", false}};
  for (auto& s : specs) s.name = prefix + s.name;
  return specs;
}

std::string render_options_help(const std::string& prefix) {
  // {flag and value, description lines}
  const std::string r = ", " + to_string(kRotationRange) + " degrees";
  const std::vector<std::pair<std::string, std::vector<std::string>>> rows = {
      {"shading simple|lambert|phong",
       {"flat facets | smooth diffuse | smooth diffuse + highlight (phong)"}},
      {"light x,y,z",
       {"direction towards a light in view space (x right, y up, z towards",
        "the viewer), components " + to_string(kLightComponentRange) + ", not all 0;",
        "repeatable (-0.5,0.6,1)"}},
      {"ambient A", {"ambient share " + to_string(kAmbientRange) + " (0.15)"}},
      {"specular S", {"highlight strength " + to_string(kSpecularRange) + " (0.4)"}},
      {"shininess E", {"Phong exponent " + to_string(kShininessRange) + " (32)"}},
      {"rotate rx,ry,rz", {"rotation about X, then Y, then Z" + r + " (0,0,0)"}},
      {"size WxH",
       {"image size in pixels, or N for N x N, sides " + to_string(kImageSideRange) +
        " (800x800)"}},
      {"background COLOR", {"#rrggbb, #rgb or r,g,b in 0..255 (#ffffff)"}},
      {"base-color COLOR", {"surface colour without vertex colours (#ccc7bd)"}},
      {"no-vertex-colors", {"ignore the mesh's vertex colours"}},
      {"framing box|sphere",
       {"fit the projected box (tight) or the sphere around the mesh (same",
        "scale for every rotation) (box)"}},
      {"margin M",
       {"empty border, fraction of the smaller side " + to_string(kMarginRange) + " (0.05)"}},
      {"supersample N",
       {"N x N samples per pixel, " + to_string(kSupersampleRange) + "; size times N at most " +
        std::to_string(kMaxSamplesPerSide) + " (1)"}}};
  const std::size_t width = 28;  // the column of the descriptions in every --help
  std::string out;
  for (const auto& [flag, lines] : rows) {
    const std::string head = "  --" + prefix + flag;
    std::size_t i = 0;
    if (head.size() + 1 > width) {
      out += head + "\n";  // too long: the description starts on the next line
    } else {
      out += head + std::string(width - head.size(), ' ') + lines[i++] + "\n";
    }
    for (; i < lines.size(); ++i) out += std::string(width, ' ') + lines[i] + "\n";
  }
  return out;
}

std::pair<int, int> parse_image_size(const std::string& text, const std::string& what) {
  const auto x = text.find_first_of("xX");
  auto side = [&](const std::string& s) {
    try {
      return static_cast<int>(parse_int(s, what, kImageSideRange));
    } catch (const InvalidInput&) {
      throw InvalidInput(what + ": '" + text + "' must be WxH or N with sides in " +
                         to_string(kImageSideRange));
    }
  };
  if (x == std::string::npos) {
    const int n = side(text);
    return {n, n};
  }
  return {side(text.substr(0, x)), side(text.substr(x + 1))};
}

std::array<std::uint8_t, 3> parse_color(const std::string& text, const std::string& what) {
  const std::string bad =
      what + ": '" + text + "' is not a colour (#rrggbb, #rgb or r,g,b with 0..255)";
  if (!text.empty() && text[0] == '#') {
    const std::string hex = text.substr(1);
    if (hex.size() != 6 && hex.size() != 3) throw InvalidInput(bad);
    for (char c : hex)
      if (!std::isxdigit(static_cast<unsigned char>(c))) throw InvalidInput(bad);
    std::array<std::uint8_t, 3> rgb{};
    for (int k = 0; k < 3; ++k) {
      const std::string part =
          hex.size() == 6 ? hex.substr(2 * k, 2) : std::string(2, hex[static_cast<std::size_t>(k)]);
      rgb[k] = static_cast<std::uint8_t>(std::stoi(part, nullptr, 16));
    }
    return rgb;
  }
  std::vector<double> v;
  try {
    v = parse_doubles(text, 3, what, {0, 255});
  } catch (const InvalidInput&) {
    throw InvalidInput(bad);
  }
  std::array<std::uint8_t, 3> rgb{};
  for (int k = 0; k < 3; ++k) {
    if (v[k] != std::floor(v[k])) throw InvalidInput(bad);
    rgb[k] = static_cast<std::uint8_t>(v[k]);
  }
  return rgb;
}

RenderOptions render_options_from_args(const ParsedArgs& args, const std::string& prefix) {
  RenderOptions o;
  auto flag = [&](const char* name) { return "--" + prefix + name; };
  auto get = [&](const char* name) { return args.get(prefix + name); };
  if (auto s = get("shading")) {
    if (*s == "simple") {
      o.shading = Shading::kSimple;
    } else if (*s == "lambert") {
      o.shading = Shading::kLambert;
    } else if (*s == "phong") {
      o.shading = Shading::kPhong;
    } else {
      throw InvalidInput(flag("shading") + ": '" + *s + "' is not simple, lambert or phong");
    }
  }
  for (const std::string& l : args.all(prefix + "light")) {
    const auto v = parse_doubles(l, 3, flag("light"), kLightComponentRange);
    o.lights.push_back({v[0], v[1], v[2]});
  }
  if (auto s = get("ambient")) o.ambient = parse_double(*s, flag("ambient"), kAmbientRange);
  if (auto s = get("specular")) o.specular = parse_double(*s, flag("specular"), kSpecularRange);
  if (auto s = get("shininess")) o.shininess = parse_double(*s, flag("shininess"), kShininessRange);
  if (auto s = get("rotate")) {
    const auto v = parse_doubles(*s, 3, flag("rotate"), kRotationRange);
    o.rotate_deg = {v[0], v[1], v[2]};
  }
  if (auto s = get("size")) std::tie(o.width, o.height) = parse_image_size(*s, flag("size"));
  if (auto s = get("background")) o.background = parse_color(*s, flag("background"));
  if (auto s = get("base-color")) {
    const auto c = parse_color(*s, flag("base-color"));
    o.color = {c[0] / 255.0, c[1] / 255.0, c[2] / 255.0};
  }
  if (args.has(prefix + "no-vertex-colors")) o.use_vertex_colors = false;
  if (auto s = get("framing")) {
    if (*s == "box") {
      o.framing = Framing::kBox;
    } else if (*s == "sphere") {
      o.framing = Framing::kSphere;
    } else {
      throw InvalidInput(flag("framing") + ": '" + *s + "' is not box or sphere");
    }
  }
  if (auto s = get("margin")) o.margin = parse_double(*s, flag("margin"), kMarginRange);
  if (auto s = get("supersample")) {
    o.supersample = static_cast<int>(parse_int(*s, flag("supersample"), kSupersampleRange));
  }
  try {
    check_render_options(o);
  } catch (const InvalidInput& e) {
    // "render: ambient must be in [0, 1]" -> "--ambient: ambient must be in [0, 1]".
    std::string what = e.what();
    if (what.rfind("render: ", 0) == 0) what = what.substr(8);
    const std::string field = what.substr(0, what.find(' '));
    const std::vector<std::pair<std::string, std::string>> flags = {
        {"color", "base-color"}, {"rotation", "rotate"},   {"light", "light"},
        {"ambient", "ambient"},  {"specular", "specular"}, {"shininess", "shininess"},
        {"margin", "margin"},    {"size", "size"},         {"supersample", "supersample"}};
    for (const auto& [name, flag_name] : flags)
      if (field == name) throw InvalidInput("--" + prefix + flag_name + ": " + what);
    throw InvalidInput(what);
  }
  return o;
}

}  // namespace qjulia::cli
