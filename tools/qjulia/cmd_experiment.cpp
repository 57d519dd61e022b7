// qjulia experiment NAME: reproducible experiments that compare the escape and the cut-off
// methods (table1: the paper's table 1 on Newton's cubic; cardioid: both methods on h^2 + c
// with c in the main cardioid, as the iteration count grows).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli.h"
#include "commands.h"
#include "files.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/base/error.h"
#include "qjulia/pipeline/pipeline.h"
#include "qjulia/render/render.h"

namespace qjulia::cli {

namespace {

constexpr const char* kHelp = R"(usage: qjulia experiment NAME [options]

experiments:
  table1     the paper's table 1: Newton's cubic T(h) = (2h^3+1)/(3h^2) with the escape method
             at bailout 0.8, 1, 2, 4 (columns) and 5, 12, 24 iterations (rows), against the
             cut-off method (preset newton-cubic). Writes DIR/table1.md, DIR/table1.csv and a
             contact sheet DIR/table1.png.
  cardioid   h^2 + c, c = -0.2 + 0.1i (inside the main cardioid): the escape surface (from
             outside) and the cut-off surface (from inside) close in on the Julia set as the
             iterations grow. Writes DIR/cardioid.md, DIR/cardioid.csv and the plot
             DIR/cardioid.png.

options:
  --resolution N    voxels along the longest side of the box (default 96)
  --out DIR         output directory (default: the current directory)
  --samples N       random surface samples per surface for the distances (default 200000)
  --iterations LIST cardioid only: the iteration counts, comma-separated
                    (default 4,5,6,7,8,10,12,16,24,32)
)";

// ---------------------------------------------------------------------------------------------
// Output helpers

std::string fmt(double x, const char* f = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ---------------------------------------------------------------------------------------------
// A little raster drawing for contact-sheet labels and the plot: no plotting library needed.

using Rgb = std::array<std::uint8_t, 3>;

Image blank(int w, int h, Rgb background) {
  Image im;
  im.width = w;
  im.height = h;
  im.rgb.resize(static_cast<std::size_t>(w) * h * 3);
  for (std::size_t i = 0; i < im.rgb.size(); i += 3)
    for (int k = 0; k < 3; ++k) im.rgb[i + k] = background[k];
  return im;
}

void put(Image& im, int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= im.width || y >= im.height) return;
  const std::size_t i = (static_cast<std::size_t>(y) * im.width + x) * 3;
  for (int k = 0; k < 3; ++k) im.rgb[i + k] = c[k];
}

void fill_rect(Image& im, int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) put(im, x, y, c);
}

// A line `width` pixels wide (DDA); every `dash`-th run of 6 pixels is skipped when dash > 0.
void line(Image& im, double x0, double y0, double x1, double y1, Rgb c, int width = 2,
          bool dashed = false) {
  const int steps =
      std::max(1, static_cast<int>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))));
  for (int s = 0; s <= steps; ++s) {
    if (dashed && (s / 6) % 2) continue;
    const double t = static_cast<double>(s) / steps;
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0)));
    const int y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
    for (int dy = 0; dy < width; ++dy)
      for (int dx = 0; dx < width; ++dx) put(im, x + dx - width / 2, y + dy - width / 2, c);
  }
}

// A 3x5 pixel font: five rows of three bits (4 = left column) per character.
const std::uint8_t* glyph(char ch) {
  static const std::uint8_t kDigits[10][5] = {
      {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
      {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 2, 2, 2}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
  static const std::uint8_t kLetters[26][5] = {
      {2, 5, 7, 5, 5}, {6, 5, 6, 5, 6}, {3, 4, 4, 4, 3}, {6, 5, 5, 5, 6}, {7, 4, 6, 4, 7},
      {7, 4, 6, 4, 4}, {3, 4, 5, 5, 3}, {5, 5, 7, 5, 5}, {7, 2, 2, 2, 7}, {1, 1, 1, 5, 2},
      {5, 5, 6, 5, 5}, {4, 4, 4, 4, 7}, {5, 7, 5, 5, 5}, {5, 7, 7, 5, 5}, {2, 5, 5, 5, 2},
      {6, 5, 6, 4, 4}, {2, 5, 5, 6, 3}, {6, 5, 6, 5, 5}, {3, 4, 2, 1, 6}, {7, 2, 2, 2, 2},
      {5, 5, 5, 5, 7}, {5, 5, 5, 5, 2}, {5, 5, 7, 7, 5}, {5, 5, 2, 5, 5}, {5, 5, 2, 2, 2},
      {7, 1, 2, 4, 7}};
  static const std::uint8_t kDot[5] = {0, 0, 0, 0, 2}, kMinus[5] = {0, 0, 7, 0, 0},
                            kEq[5] = {0, 7, 0, 7, 0}, kSlash[5] = {1, 1, 2, 4, 4},
                            kOpen[5] = {2, 4, 4, 4, 2}, kClose[5] = {2, 1, 1, 1, 2},
                            kGt[5] = {4, 2, 1, 2, 4}, kComma[5] = {0, 0, 0, 2, 4},
                            kColon[5] = {0, 2, 0, 2, 0}, kBlank[5] = {0, 0, 0, 0, 0};
  if (ch >= '0' && ch <= '9') return kDigits[ch - '0'];
  if (ch >= 'a' && ch <= 'z') ch = static_cast<char>(ch - 'a' + 'A');
  if (ch >= 'A' && ch <= 'Z') return kLetters[ch - 'A'];
  switch (ch) {
    case '.':
      return kDot;
    case '-':
      return kMinus;
    case '=':
      return kEq;
    case '/':
      return kSlash;
    case '(':
      return kOpen;
    case ')':
      return kClose;
    case '>':
      return kGt;
    case ',':
      return kComma;
    case ':':
      return kColon;
    default:
      return kBlank;
  }
}

int text_width(const std::string& s, int scale) { return static_cast<int>(s.size()) * 4 * scale; }

void text(Image& im, int x, int y, const std::string& s, Rgb c, int scale = 2) {
  for (char ch : s) {
    const std::uint8_t* g = glyph(ch);
    for (int row = 0; row < 5; ++row)
      for (int col = 0; col < 3; ++col)
        if (g[row] & (4 >> col))
          fill_rect(im, x + col * scale, y + row * scale, x + (col + 1) * scale,
                    y + (row + 1) * scale, c);
    x += 4 * scale;
  }
}

void blit(Image& dst, const Image& src, int x0, int y0) {
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < src.width; ++x) {
      const std::size_t i = (static_cast<std::size_t>(y) * src.width + x) * 3;
      put(dst, x0 + x, y0 + y, {src.rgb[i], src.rgb[i + 1], src.rgb[i + 2]});
    }
}

// ---------------------------------------------------------------------------------------------
// Runs

struct Options {
  int resolution = 96;
  std::string out = ".";
  std::size_t samples = 200000;
  std::vector<int> iterations;  // cardioid
};

struct Run {
  TriMesh mesh;
  MeshMeasure measure;
  double seconds = 0;
};

Run mesh_of(const Params& p) {
  const auto t0 = std::chrono::steady_clock::now();
  PipelineResult r = run_pipeline(p);
  Run run;
  run.seconds = seconds_since(t0);
  run.mesh = std::move(r.mesh);
  run.measure = measure(run.mesh);
  return run;
}

// Distances between two runs, or nothing when either is empty.
std::optional<CompareResult> distances(const TriMesh& a, const TriMesh& b, std::size_t samples) {
  if (a.triangles.empty() || b.triangles.empty()) return std::nullopt;
  CompareOptions o;
  o.samples = samples;
  CompareResult r = compare(a, b, o);
  r.a_vertex_distance.clear();
  return r;
}

double voxel_size(const Params& p) {
  double longest = 0;
  for (int k = 0; k < 3; ++k) longest = std::max(longest, p.bounds.max[k] - p.bounds.min[k]);
  return longest / p.resolution;
}

std::string bounds_text(const Params& p) {
  std::string s = "[";
  for (int k = 0; k < 3; ++k)
    s += (k ? ", " : "") + fmt(p.bounds.min[k]) + ".." + fmt(p.bounds.max[k]);
  return s + "]";
}

// ---------------------------------------------------------------------------------------------
// table1

int run_table1(const Options& o) {
  const std::vector<double> bailouts = {0.8, 1, 2, 4};
  const std::vector<int> iterations = {5, 12, 24};
  Params base = preset("newton-cubic");
  base.resolution = o.resolution;
  validate(base);

  std::fprintf(stderr, "table1: cut-off reference (preset newton-cubic, resolution %d)\n",
               o.resolution);
  const Run cut = mesh_of(base);
  if (cut.mesh.triangles.empty())
    throw std::runtime_error("table1: the cut-off reference surface is empty");

  struct Cell {
    double bailout;
    int iterations;
    Run run;
    std::optional<CompareResult> d;
  };
  std::vector<Cell> cells;
  for (int n : iterations)
    for (double r : bailouts) {
      Params p = base;
      p.method = Method::kEscape;
      p.bailout = r;
      p.iterations = n;
      Cell c{r, n, mesh_of(p), std::nullopt};
      c.d = distances(c.run.mesh, cut.mesh, o.samples);
      std::fprintf(stderr,
                   "table1: escape R=%g N=%d: %zu faces, volume %.4g, hausdorff %s (%.1f s)\n", r,
                   n, c.run.measure.faces, c.run.measure.volume,
                   c.d ? fmt(c.d->hausdorff).c_str() : "n/a (empty)", c.run.seconds);
      cells.push_back(std::move(c));
    }

  // CSV: one row per surface, the cut-off reference first.
  std::ostringstream csv;
  csv << "method,bailout,iterations,resolution,vertices,faces,volume,area,components,closed,"
         "hausdorff_to_cutoff,escape_to_cutoff_max,escape_to_cutoff_mean,cutoff_to_escape_max,"
         "cutoff_to_escape_mean\n";
  auto csv_row = [&](const char* method, double r, int n, const MeshMeasure& m,
                     const std::optional<CompareResult>& d) {
    csv << method << ',' << r << ',' << n << ',' << o.resolution << ',' << m.vertices << ','
        << m.faces << ',' << fmt(m.volume, "%.6g") << ',' << fmt(m.area, "%.6g") << ','
        << m.components.size() << ',' << (m.closed ? "true" : "false") << ',';
    if (d)
      csv << fmt(d->hausdorff, "%.6g") << ',' << fmt(d->a_to_b.max, "%.6g") << ','
          << fmt(d->a_to_b.mean, "%.6g") << ',' << fmt(d->b_to_a.max, "%.6g") << ','
          << fmt(d->b_to_a.mean, "%.6g") << '\n';
    else
      csv << ",,,,\n";
  };
  csv_row("cutoff", base.bailout, base.iterations, cut.measure, CompareResult{});
  for (const auto& c : cells) csv_row("escape", c.bailout, c.iterations, c.run.measure, c.d);

  // Markdown: one table per quantity, rows = iterations, columns = bailout, as in the paper.
  std::ostringstream md;
  md << "# Table 1: the escape method on Newton's cubic, against the cut-off method\n\n"
     << "T(h) = (2h^3+1)/(3h^2), slice (r, i, j) at k = 0, box " << bounds_text(base)
     << ", resolution " << o.resolution << " (voxel " << fmt(voxel_size(base)) << ").\n"
     << "Reference: the cut-off method (preset newton-cubic: " << base.iterations
     << " iterations, cut-off rate " << fmt(base.bailout) << "): volume " << fmt(cut.measure.volume)
     << ", area " << fmt(cut.measure.area) << ", " << cut.measure.components.size()
     << " component(s), " << cut.measure.faces << " faces.\n"
     << "Made by `qjulia experiment table1 --resolution " << o.resolution << "`.\n";
  auto grid = [&](const std::string& title, auto value) {
    md << "\n### " << title << "\n\n| iterations \\ bailout |";
    for (double r : bailouts) md << " R = " << fmt(r) << " |";
    md << "\n|---|";
    for (std::size_t i = 0; i < bailouts.size(); ++i) md << "---:|";
    md << "\n";
    for (int n : iterations) {
      md << "| " << n << " |";
      for (const auto& c : cells)
        if (c.iterations == n) md << ' ' << value(c) << " |";
      md << "\n";
    }
  };
  grid("Hausdorff distance to the cut-off surface",
       [](const Cell& c) { return c.d ? fmt(c.d->hausdorff) : std::string("empty"); });
  grid("Volume (cut-off: " + fmt(cut.measure.volume) + ")",
       [](const Cell& c) { return fmt(c.run.measure.volume); });
  grid("Area (cut-off: " + fmt(cut.measure.area) + ")",
       [](const Cell& c) { return fmt(c.run.measure.area); });
  grid("Components (cut-off: " + std::to_string(cut.measure.components.size()) + ")",
       [](const Cell& c) { return std::to_string(c.run.measure.components.size()); });

  // The contact sheet: the 3 x 4 escape grid and the cut-off surface below, as in the paper.
  std::string sheet_note;
  const int tile = 220, label = 22, cols = 4, rows = 3;
  const std::string png = o.out + "/table1.png";
  try {
    RenderOptions ro;
    ro.width = ro.height = tile;
    ro.rotate_deg = {-20, 25, 0};
    Image sheet = blank(cols * tile, (rows + 1) * (tile + label), {255, 255, 255});
    auto draw = [&](const Run& run, const std::string& caption, int x, int y) {
      if (!run.mesh.triangles.empty())
        blit(sheet, render(run.mesh, ro), x, y + label);
      else
        text(sheet, x + tile / 2 - text_width("EMPTY", 2) / 2, y + label + tile / 2, "EMPTY",
             {120, 120, 120});
      text(sheet, x + tile / 2 - text_width(caption, 2) / 2, y + 5, caption, {0, 0, 0});
    };
    for (std::size_t i = 0; i < cells.size(); ++i)
      draw(cells[i].run,
           "ESCAPE R=" + fmt(cells[i].bailout) + " N=" + std::to_string(cells[i].iterations),
           static_cast<int>(i % cols) * tile, static_cast<int>(i / cols) * (tile + label));
    draw(cut, "CUT-OFF N=" + std::to_string(base.iterations) + " R=" + fmt(base.bailout),
         (cols * tile - tile) / 2, rows * (tile + label));
    write_png(png, sheet);
    sheet_note =
        "Contact sheet: table1.png (rows: 5, 12, 24 iterations; columns: bailout 0.8, "
        "1, 2, 4; bottom: the cut-off method). Each picture is framed on its own "
        "surface.\n";
  } catch (const std::exception& e) {
    sheet_note = std::string("Contact sheet skipped: ") + e.what() + "\n";
    std::fprintf(stderr, "table1: contact sheet skipped (%s)\n", e.what());
  }
  md << "\n" << sheet_note;

  write_file_atomic(o.out + "/table1.csv", csv.str());
  write_file_atomic(o.out + "/table1.md", md.str());
  std::fputs(md.str().c_str(), stdout);
  std::printf("\nwrote %s/table1.md, %s/table1.csv%s\n", o.out.c_str(), o.out.c_str(),
              sheet_note.rfind("Contact sheet:", 0) == 0 ? (", " + png).c_str() : "");
  return 0;
}

// ---------------------------------------------------------------------------------------------
// cardioid

// The faces of the components of `m` that stay off the box walls: the cut-off solid of h^2 + c
// also holds the escaping exterior, whose surface is the box; its inner surface faces J.
TriMesh inner_part(const TriMesh& m, const Params& p) {
  std::vector<uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : m.triangles) {
    const uint32_t a = find(t[0]), b = find(t[1]), c = find(t[2]);
    parent[b] = a;
    parent[find(c)] = find(a);
  }
  const double eps = 0.5 * voxel_size(p);
  std::vector<char> touches(m.positions.size(), 0);
  for (uint32_t v = 0; v < m.positions.size(); ++v)
    for (int k = 0; k < 3; ++k)
      if (m.positions[v][k] <= p.bounds.min[k] + eps || m.positions[v][k] >= p.bounds.max[k] - eps)
        touches[find(v)] = 1;
  TriMesh out;
  std::vector<uint32_t> remap(m.positions.size(), UINT32_MAX);
  for (const auto& t : m.triangles) {
    if (touches[find(t[0])]) continue;
    std::array<uint32_t, 3> f;
    for (int k = 0; k < 3; ++k) {
      if (remap[t[k]] == UINT32_MAX) {
        remap[t[k]] = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(m.positions[t[k]]);
      }
      f[k] = remap[t[k]];
    }
    out.triangles.push_back(f);
  }
  return out;
}

Image plot(const std::vector<int>& xs, const std::vector<std::vector<double>>& series,
           const std::vector<Rgb>& colors, const std::vector<std::string>& names, double reference,
           const std::string& title) {
  const int w = 900, h = 560, left = 90, right = 30, top = 50, bottom = 70;
  Image im = blank(w, h, {255, 255, 255});
  // y on a log10 scale, whole decades: the distances fall over several of them.
  double ymin = reference, ymax = reference;
  for (const auto& ser : series)
    for (double y : ser)
      if (std::isfinite(y) && y > 0) {
        ymin = std::min(ymin, y);
        ymax = std::max(ymax, y);
      }
  const int d0 = static_cast<int>(std::floor(std::log10(ymin))),
            d1 = std::max(d0 + 1, static_cast<int>(std::ceil(std::log10(ymax))));
  // x on a log2 scale: the iteration counts roughly double.
  const double lx0 = std::log2(std::max(1, xs.front())), lx1 = std::log2(std::max(2, xs.back()));
  auto px = [&](double x) {
    return left + (std::log2(x) - lx0) / std::max(1e-9, lx1 - lx0) * (w - left - right);
  };
  auto py = [&](double y) {
    const double t = (std::log10(std::max(y, std::pow(10.0, d0))) - d0) / (d1 - d0);
    return h - bottom - t * (h - top - bottom);
  };
  // Axes, grid and ticks.
  const Rgb axis{0, 0, 0}, grid_rgb{225, 225, 225};
  for (int d = d0; d <= d1; ++d) {
    const double y = std::pow(10.0, d);
    line(im, left, py(y), w - right, py(y), grid_rgb, 1);
    const std::string label = fmt(y, "%g");
    text(im, left - 8 - text_width(label, 2), static_cast<int>(py(y)) - 5, label, axis);
  }
  for (int x : xs) {
    line(im, px(x), h - bottom, px(x), top, grid_rgb, 1);
    const std::string label = std::to_string(x);
    text(im, static_cast<int>(px(x)) - text_width(label, 2) / 2, h - bottom + 10, label, axis);
  }
  line(im, left, h - bottom, w - right, h - bottom, axis, 2);
  line(im, left, h - bottom, left, top, axis, 2);
  text(im, (w - text_width("ITERATIONS N", 2)) / 2, h - 28, "ITERATIONS N", axis);
  text(im, (w - text_width(title, 3)) / 2, 15, title, axis, 3);
  // The voxel size, dashed: below it the distance is resolution-limited.
  line(im, left, py(reference), w - right, py(reference), {130, 130, 130}, 2, true);
  // The legend, top right.
  for (std::size_t s = 0; s <= series.size(); ++s) {
    const int y = top + 12 + static_cast<int>(s) * 22;
    const int x = w - right - 300;
    if (s < series.size()) {
      fill_rect(im, x, y - 2, x + 28, y + 3, colors[s]);
      text(im, x + 40, y - 5, names[s], axis);
    } else {
      line(im, x, y, x + 28, y, {130, 130, 130}, 2, true);
      text(im, x + 40, y - 5, "ONE VOXEL", axis);
    }
  }
  for (std::size_t s = 0; s < series.size(); ++s) {
    for (std::size_t i = 0; i + 1 < xs.size(); ++i)
      if (std::isfinite(series[s][i]) && std::isfinite(series[s][i + 1]))
        line(im, px(xs[i]), py(series[s][i]), px(xs[i + 1]), py(series[s][i + 1]), colors[s], 3);
    for (std::size_t i = 0; i < xs.size(); ++i)
      if (std::isfinite(series[s][i]))
        fill_rect(im, static_cast<int>(px(xs[i])) - 4, static_cast<int>(py(series[s][i])) - 4,
                  static_cast<int>(px(xs[i])) + 5, static_cast<int>(py(series[s][i])) + 5,
                  colors[s]);
  }
  return im;
}

int run_cardioid(const Options& o) {
  std::vector<int> iterations = o.iterations;
  if (iterations.empty()) iterations = {4, 5, 6, 7, 8, 10, 12, 16, 24, 32};
  Params base;
  base.formula = "h^2+c";
  base.constants.clear();
  base.set_constant("c", Quat{-0.2, 0.1, 0, 0});
  base.bounds.min = {-1.6, -1.6, -1.6};
  base.bounds.max = {1.6, 1.6, 1.6};
  base.resolution = o.resolution;
  Params escape = base, cutoff = base;
  escape.method = Method::kEscape;
  escape.bailout = 2;
  cutoff.method = Method::kCutoff;
  cutoff.bailout = 0.01;
  validate(escape);
  validate(cutoff);
  const double voxel = voxel_size(base);

  struct Row {
    int n;
    MeshMeasure escape, inner;
    std::optional<CompareResult> d;
  };
  std::vector<Row> rows;
  for (int n : iterations) {
    escape.iterations = cutoff.iterations = n;
    const Run e = mesh_of(escape);
    Run c = mesh_of(cutoff);
    const TriMesh inner = inner_part(c.mesh, base);
    Row row{n, e.measure, measure(inner), distances(e.mesh, inner, o.samples)};
    std::fprintf(stderr,
                 "cardioid: N=%d: escape %zu faces volume %.4g; cut-off inner %zu faces volume "
                 "%.4g; hausdorff %s (%.1f s)\n",
                 n, row.escape.faces, row.escape.volume, row.inner.faces,
                 std::abs(row.inner.volume), row.d ? fmt(row.d->hausdorff).c_str() : "n/a",
                 e.seconds + c.seconds);
    rows.push_back(std::move(row));
  }

  std::ostringstream csv, md;
  csv << "iterations,resolution,voxel,escape_faces,escape_volume,escape_area,cutoff_faces,"
         "cutoff_volume,cutoff_area,hausdorff,escape_to_cutoff_max,escape_to_cutoff_mean,"
         "cutoff_to_escape_max,cutoff_to_escape_mean\n";
  md << "# Cardioid: escape and cut-off close in on the same Julia set\n\n"
     << "h^2 + c with c = -0.2 + 0.1i (inside the main cardioid: the fixed point is attracting, "
        "multiplier about 0.38), slice (r, i, j) at k = 0, box "
     << bounds_text(base) << ", resolution " << o.resolution << " (voxel " << fmt(voxel)
     << ").\nEscape: bailout 2. Cut-off: rate 0.01; its solid also holds the escaping exterior "
        "(steps grow there), so its surface is the box plus an inner surface around the "
        "converged basin; only the inner surface is compared.\n"
     << "Made by `qjulia experiment cardioid --resolution " << o.resolution << "`.\n\n"
     << "| iterations | escape volume | cut-off inner volume | Hausdorff | escape -> cut-off "
        "mean | cut-off -> escape mean |\n|---:|---:|---:|---:|---:|---:|\n";
  std::vector<double> hausdorff, mean_ec, mean_ce;
  for (const auto& r : rows) {
    const double nan = std::nan("");
    hausdorff.push_back(r.d ? r.d->hausdorff : nan);
    mean_ec.push_back(r.d ? r.d->a_to_b.mean : nan);
    mean_ce.push_back(r.d ? r.d->b_to_a.mean : nan);
    auto g = [](double x) { return std::isfinite(x) ? fmt(x, "%.6g") : std::string(); };
    csv << r.n << ',' << o.resolution << ',' << fmt(voxel, "%.6g") << ',' << r.escape.faces << ','
        << g(r.escape.volume) << ',' << g(r.escape.area) << ',' << r.inner.faces << ','
        << g(std::abs(r.inner.volume)) << ',' << g(r.inner.area) << ',' << g(hausdorff.back())
        << ',' << g(r.d ? r.d->a_to_b.max : nan) << ',' << g(mean_ec.back()) << ','
        << g(r.d ? r.d->b_to_a.max : nan) << ',' << g(mean_ce.back()) << '\n';
    auto m = [](double x) { return std::isfinite(x) ? fmt(x) : std::string("n/a"); };
    md << "| " << r.n << " | " << fmt(r.escape.volume) << " | " << fmt(std::abs(r.inner.volume))
       << " | " << m(hausdorff.back()) << " | " << m(mean_ec.back()) << " | " << m(mean_ce.back())
       << " |\n";
  }
  std::string plot_note;
  const std::string png = o.out + "/cardioid.png";
  try {
    const Image im = plot(iterations, {hausdorff, mean_ec, mean_ce},
                          {{210, 30, 30}, {30, 80, 210}, {20, 150, 60}},
                          {"HAUSDORFF", "MEAN ESCAPE > CUT-OFF", "MEAN CUT-OFF > ESCAPE"}, voxel,
                          "ESCAPE VS CUT-OFF: DISTANCE");
    write_png(png, im);
    plot_note =
        "\nPlot: cardioid.png (log-log; x: iterations; y: distance; red: Hausdorff distance; blue: "
        "mean escape -> cut-off; green: mean cut-off -> escape; dashed grey: one "
        "voxel).\n";
  } catch (const std::exception& e) {
    plot_note = std::string("\nPlot skipped: ") + e.what() + "\n";
    std::fprintf(stderr, "cardioid: plot skipped (%s)\n", e.what());
  }
  md << plot_note;
  write_file_atomic(o.out + "/cardioid.csv", csv.str());
  write_file_atomic(o.out + "/cardioid.md", md.str());
  std::fputs(md.str().c_str(), stdout);
  std::printf("\nwrote %s/cardioid.md, %s/cardioid.csv%s\n", o.out.c_str(), o.out.c_str(),
              plot_note.rfind("\nPlot:", 0) == 0 ? (", " + png).c_str() : "");
  return 0;
}

}  // namespace

int cmd_experiment(const Tokens& tokens) {
  const std::vector<OptionSpec> specs = {{"resolution", true},
                                         {"out", true},
                                         {"samples", true},
                                         {"iterations", true},
                                         {"help", false}};
  const ParsedArgs args = parse_args(tokens, specs, "experiment");
  if (args.has("help")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  if (args.positional.size() != 1)
    throw InvalidInput(
        "expects one experiment name: table1 or cardioid (see 'qjulia "
        "experiment --help')");
  const std::string name = args.positional[0];
  Options o;
  if (auto r = args.get("resolution")) {
    const long long n = parse_int(*r, "--resolution");
    if (n < 8 || n > 1024) throw InvalidInput("--resolution must be in 8..1024");
    o.resolution = static_cast<int>(n);
  }
  if (auto s = args.get("samples")) {
    const long long n = parse_int(*s, "--samples");
    if (n < 0 || n > 100000000) throw InvalidInput("--samples must be in 0..100000000");
    o.samples = static_cast<std::size_t>(n);
  }
  if (auto it = args.get("iterations")) {
    if (name != "cardioid") throw InvalidInput("--iterations is an option of 'cardioid' only");
    for (double x : parse_doubles(*it, 0, "--iterations")) {
      if (x < 1 || x > 10000 || x != std::floor(x))
        throw InvalidInput("--iterations takes whole numbers in 1..10000, got " + fmt(x));
      o.iterations.push_back(static_cast<int>(x));
    }
    std::sort(o.iterations.begin(), o.iterations.end());
    o.iterations.erase(std::unique(o.iterations.begin(), o.iterations.end()), o.iterations.end());
  }
  o.out = args.get("out").value_or(".");
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (!std::filesystem::is_directory(o.out))
    throw InvalidInput("--out " + o.out + ": cannot create the directory");
  if (name == "table1") return run_table1(o);
  if (name == "cardioid") return run_cardioid(o);
  throw InvalidInput("unknown experiment '" + name + "' (known: table1, cardioid)");
}

}  // namespace qjulia::cli
