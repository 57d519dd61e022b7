// qjulia render: preview images of meshes, and contact sheets of several meshes or views.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"
#include "commands.h"
#include "files.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/render/contact_sheet.h"
#include "qjulia/render/render.h"
#include "qjulia/render/text.h"
#include "render_args.h"

namespace qjulia::cli {
namespace {

constexpr const char* kRenderUsage =
    R"(usage: qjulia render MESH... -o OUT.png [options]

Draws MESH (any format qjulia writes: glb, gltf, obj, ply, stl, 3mf) with an orthographic
camera looking down -z, framed automatically. Several inputs, or several --view, make a contact
sheet with one captioned cell each; inputs ending in .png are placed in the sheet as they are.

options:
  -o, --output OUT.png      the image (written atomically)
  --view rx,ry,rz           one cell per view (rotation as --rotate); repeatable
  --columns N               cells per row of a contact sheet, 1..1000 (ceil(sqrt(cells)))
  --caption TEXT            caption of the next cell (the file name); repeatable
  --threads T               worker threads, 1..1024 (all cores)
)";

std::string format_view(const std::array<double, 3>& r) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%g,%g,%g", r[0], r[1], r[2]);
  return buf;
}

}  // namespace

int cmd_render(const Tokens& tokens, const CancelToken& cancel) {
  std::vector<OptionSpec> specs = render_option_specs();
  for (const char* name : {"output", "view", "columns", "caption", "threads"})
    specs.push_back({name, true});
  specs.push_back({"help", false});
  const ParsedArgs args = parse_args(tokens, specs, "render");
  if (args.has("help")) {
    std::fputs(kRenderUsage, stdout);
    std::fputs(render_options_help().c_str(), stdout);
    return 0;
  }
  if (args.positional.empty())
    throw InvalidInput("no input mesh given (usage: render MESH -o OUT.png)");
  const auto out = args.output_file("output");
  if (!out) throw InvalidInput("-o OUT.png is required");
  if (!is_png_path(*out)) throw InvalidInput("-o: '" + *out + "' must end in .png");

  const ThreadLimit threads(args);
  RenderOptions base = render_options_from_args(args);
  base.cancel = &cancel;
  std::vector<std::array<double, 3>> views;
  for (const std::string& v : args.all("view")) {
    const auto d = parse_doubles(v, 3, "--view", kRotationRange);
    views.push_back({d[0], d[1], d[2]});
  }
  if (views.empty()) views.push_back(base.rotate_deg);

  std::optional<int> columns_option;
  if (auto c = args.get("columns"))
    columns_option = static_cast<int>(parse_int(*c, "--columns", {1, 1000}));

  for (const std::string& input : args.positional) {
    std::error_code ec;
    const auto kind = std::filesystem::status(input, ec).type();
    if (kind == std::filesystem::file_type::not_found || ec)
      throw InvalidInput("input '" + input + "': no such file");
    if (kind == std::filesystem::file_type::directory)
      throw InvalidInput("input '" + input + "': is a directory, not a mesh file");
    if (kind != std::filesystem::file_type::regular)
      throw InvalidInput("input '" + input + "': is not a regular file (a device or a pipe)");
  }
  OutputFiles files;  // -o is checked now: never an input, a directory or a device
  for (const std::string& input : args.positional) files.add_mesh_input(input);
  files.claim(*out);

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<Image, std::string>> cells;
  std::size_t faces = 0;
  for (const std::string& input : args.positional) {
    const std::string stem = std::filesystem::path(input).stem().string();
    if (is_png_path(input)) {
      cells.emplace_back(read_png(input), stem);
      continue;
    }
    const TriMesh mesh = read_mesh(input);
    faces += mesh.face_count();
    for (const auto& view : views) {
      RenderOptions o = base;
      o.rotate_deg = view;
      cells.emplace_back(render(mesh, o), views.size() > 1 ? stem + " " + format_view(view) : stem);
    }
  }
  const auto captions = args.all("caption");
  if (captions.size() > cells.size())
    throw InvalidInput("--caption: " + std::to_string(captions.size()) + " captions for " +
                       std::to_string(cells.size()) + " cells");
  for (std::size_t i = 0; i < captions.size(); ++i) cells[i].second = captions[i];

  Image image;
  if (cells.size() == 1 && !args.has("caption") && !args.has("columns")) {
    image = std::move(cells[0].first);
  } else {
    const int columns = columns_option.value_or(
        static_cast<int>(std::ceil(std::sqrt(static_cast<double>(cells.size())))));
    ContactSheetOptions sheet;
    sheet.background = base.background;
    // Captions at double size when they all fit their cells, else at the font's own size.
    int cell_width = 0;
    for (const auto& cell : cells) cell_width = std::max(cell_width, cell.first.width);
    for (const auto& cell : cells)
      if (text_width(cell.second, 2) > cell_width + sheet.padding) sheet.text_scale = 1;
    const double luma =
        0.3 * base.background[0] + 0.59 * base.background[1] + 0.11 * base.background[2];
    if (luma < 128) sheet.text_color = {230, 230, 230};  // light text on a dark sheet
    image = contact_sheet(cells, columns, sheet);
  }
  throw_if_cancelled(&cancel);  // a signal while the cells were assembled
  write_png(*out, image);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s: %dx%d, %zu cell(s), %zu faces, %.2f s\n", out->c_str(), image.width,
              image.height, cells.size(), faces, seconds);
  return 0;
}

}  // namespace qjulia::cli
