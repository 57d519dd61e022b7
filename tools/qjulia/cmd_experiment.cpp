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
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli.h"
#include "commands.h"
#include "files.h"
#include "qjulia/base/error.h"
#include "qjulia/base/mesh.h"
#include "qjulia/grid/sample.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"
#include "qjulia/render/contact_sheet.h"
#include "qjulia/render/image.h"
#include "qjulia/render/plot.h"
#include "qjulia/render/render.h"
#include "qjulia/render/text.h"

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
  --resolution N    voxels along the longest side of the box, 8..1024 (default 96)
  --out DIR         output directory (default: the current directory)
  --samples N       random surface samples per surface for the distances, 0..100000000
                    (default 200000)
  --iterations LIST cardioid only: the iteration counts, comma-separated, each 1..10000
                    (default 4,5,6,7,8,10,12,16,24,32)
  --threads T       worker threads, 1..1024 (default: all cores)
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
// Runs

struct Options {
  int resolution = 96;
  std::string out = ".";
  std::size_t samples = 200000;
  std::vector<int> iterations;  // cardioid
  const CancelToken* cancel = nullptr;
};

struct Run {
  TriMesh mesh;
  MeshMeasure measure;
  double seconds = 0;
  std::string empty_because;  // why the mesh is empty, when it is
};

Run mesh_of(const Params& p, const Options& o) {
  const auto t0 = std::chrono::steady_clock::now();
  PipelineOptions popts;
  popts.cancel = o.cancel;
  PipelineResult r = run_pipeline(p, popts);
  Run run;
  run.seconds = seconds_since(t0);
  run.mesh = std::move(r.mesh);
  run.measure = measure(run.mesh);
  if (run.mesh.triangles.empty()) run.empty_because = empty_mesh_message(p, r.stats);
  return run;
}

// Distances between two runs, or nothing when either is empty.
std::optional<CompareResult> distances(const TriMesh& a, const TriMesh& b, const Options& o) {
  if (a.triangles.empty() || b.triangles.empty()) return std::nullopt;
  CompareOptions copts;
  copts.samples = o.samples;
  copts.cancel = o.cancel;
  CompareResult r = compare(a, b, copts);
  r.a_vertex_distance.clear();
  return r;
}

// Draws a figure and writes it to `path`. A figure that cannot be drawn or written is left out
// (the tables do not depend on it): its error is returned. A cancellation is not swallowed.
std::optional<std::string> write_figure(const std::string& path,
                                        const std::function<Image()>& draw) {
  try {
    write_png(path, draw());
    return std::nullopt;
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    return std::string(e.what());
  }
}

double voxel_size(const Params& p) { return grid_geometry(p).voxel; }

std::string bounds_text(const Params& p) {
  std::string s = "[";
  for (int k = 0; k < 3; ++k)
    s += (k ? ", " : "") + fmt(p.bounds.min[k]) + ".." + fmt(p.bounds.max[k]);
  return s + "]";
}

// ---------------------------------------------------------------------------------------------
// table1

// The paper's table: the escape method at every (bailout, iterations) against the cut-off
// reference.
struct Table1 {
  const std::vector<double> bailouts = {0.8, 1, 2, 4};
  const std::vector<int> iterations = {5, 12, 24};
  Params base;  // the cut-off reference: preset newton-cubic
  Run cut;
  struct Cell {
    double bailout;
    int iterations;
    Run run;
    std::optional<CompareResult> d;  // to the cut-off surface; none when empty
  };
  std::vector<Cell> cells;  // row by row: iterations, then bailout
};

Table1 mesh_table1(const Options& o) {
  Table1 t;
  t.base = preset("newton-cubic");
  t.base.resolution = o.resolution;
  validate(t.base);
  std::fprintf(stderr, "table1: cut-off reference (preset newton-cubic, resolution %d)\n",
               o.resolution);
  t.cut = mesh_of(t.base, o);
  if (t.cut.mesh.triangles.empty())
    throw InvalidInput("table1: the cut-off reference (newton-cubic at resolution " +
                       std::to_string(o.resolution) + ") has no surface: " + t.cut.empty_because +
                       "; nothing written");
  for (int n : t.iterations)
    for (double r : t.bailouts) {
      Params p = t.base;
      p.method = Method::kEscape;
      p.bailout = r;
      p.iterations = n;
      Table1::Cell c{r, n, mesh_of(p, o), std::nullopt};
      c.d = distances(c.run.mesh, t.cut.mesh, o);
      std::fprintf(stderr,
                   "table1: escape R=%g N=%d: %zu faces, volume %.4g, hausdorff %s (%.1f s)\n", r,
                   n, c.run.measure.faces, c.run.measure.volume,
                   c.d ? fmt(c.d->hausdorff).c_str() : "n/a (empty)", c.run.seconds);
      t.cells.push_back(std::move(c));
    }
  return t;
}

// One row per surface, the cut-off reference first.
std::string table1_csv(const Table1& t, const Options& o) {
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
  csv_row("cutoff", t.base.bailout, t.base.iterations, t.cut.measure, CompareResult{});
  for (const auto& c : t.cells) csv_row("escape", c.bailout, c.iterations, c.run.measure, c.d);
  return csv.str();
}

// One table per quantity, rows = iterations, columns = bailout, as in the paper.
std::string table1_markdown(const Table1& t, const Options& o) {
  const MeshMeasure& cut = t.cut.measure;
  std::ostringstream md;
  md << "# Table 1: the escape method on Newton's cubic, against the cut-off method\n\n"
     << "T(h) = (2h^3+1)/(3h^2), slice (r, i, j) at k = 0, box " << bounds_text(t.base)
     << ", resolution " << o.resolution << " (voxel " << fmt(voxel_size(t.base)) << ").\n"
     << "Reference: the cut-off method (preset newton-cubic: " << t.base.iterations
     << " iterations, cut-off rate " << fmt(t.base.bailout) << "): volume " << fmt(cut.volume)
     << ", area " << fmt(cut.area) << ", " << cut.components.size() << " component(s), "
     << cut.faces << " faces.\n"
     << "Made by `qjulia experiment table1 --resolution " << o.resolution << "`.\n";
  auto grid = [&](const std::string& title, auto value) {
    md << "\n### " << title << "\n\n| iterations \\ bailout |";
    for (double r : t.bailouts) md << " R = " << fmt(r) << " |";
    md << "\n|---|";
    for (std::size_t i = 0; i < t.bailouts.size(); ++i) md << "---:|";
    md << "\n";
    for (int n : t.iterations) {
      md << "| " << n << " |";
      for (const auto& c : t.cells)
        if (c.iterations == n) md << ' ' << value(c) << " |";
      md << "\n";
    }
  };
  using Cell = Table1::Cell;
  grid("Hausdorff distance to the cut-off surface",
       [](const Cell& c) { return c.d ? fmt(c.d->hausdorff) : std::string("empty"); });
  grid("Volume (cut-off: " + fmt(cut.volume) + ")",
       [](const Cell& c) { return fmt(c.run.measure.volume); });
  grid("Area (cut-off: " + fmt(cut.area) + ")",
       [](const Cell& c) { return fmt(c.run.measure.area); });
  grid("Components (cut-off: " + std::to_string(cut.components.size()) + ")",
       [](const Cell& c) { return std::to_string(c.run.measure.components.size()); });
  return md.str();
}

// The 3 x 4 escape grid and the cut-off surface centred below, as in the paper; each picture
// framed on its own surface.
Image table1_sheet(const Table1& t, const Options& o) {
  RenderOptions ro;
  ro.width = ro.height = 220;
  ro.rotate_deg = {-20, 25, 0};
  ro.cancel = o.cancel;
  auto picture = [&](const Run& run, const std::string& caption) {
    if (!run.mesh.triangles.empty()) return std::make_pair(render(run.mesh, ro), caption);
    Image empty = make_image(ro.width, ro.height, ro.background);
    const std::string text = "empty";
    draw_text(empty, (ro.width - text_width(text, 2)) / 2, (ro.height - text_height(2)) / 2, text,
              {120, 120, 120}, 2);
    return std::make_pair(std::move(empty), caption);
  };
  std::vector<std::pair<Image, std::string>> pictures;
  for (const auto& c : t.cells)
    pictures.push_back(
        picture(c.run, "escape R=" + fmt(c.bailout) + " N=" + std::to_string(c.iterations)));
  pictures.push_back(picture(
      t.cut, "cut-off N=" + std::to_string(t.base.iterations) + " R=" + fmt(t.base.bailout)));
  ContactSheetOptions sheet;
  sheet.center_last_row = true;
  return contact_sheet(pictures, static_cast<int>(t.bailouts.size()), sheet);
}

int run_table1(const Options& o) {
  const Table1 t = mesh_table1(o);
  OutputFiles written;  // removed again unless every file is written
  const std::string png = o.out + "/table1.png";
  const auto sheet_failed = write_figure(png, [&] { return table1_sheet(t, o); });
  if (!sheet_failed) written.add(png);
  if (sheet_failed)
    std::fprintf(stderr, "table1: contact sheet skipped (%s)\n", sheet_failed->c_str());
  const std::string md =
      table1_markdown(t, o) + "\n" +
      (sheet_failed ? "Contact sheet skipped: " + *sheet_failed + "\n"
                    : "Contact sheet: table1.png (rows: 5, 12, 24 iterations; columns: bailout "
                      "0.8, 1, 2, 4; bottom: the cut-off method). Each picture is framed on its "
                      "own surface.\n");
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"table1.csv", table1_csv(t, o)}, {"table1.md", md}}) {
    write_file_atomic(o.out + "/" + name, text);
    written.add(o.out + "/" + name);
  }
  throw_if_cancelled(o.cancel);
  written.commit();
  std::fputs(md.c_str(), stdout);
  std::printf("\nwrote %s/table1.md, %s/table1.csv%s\n", o.out.c_str(), o.out.c_str(),
              sheet_failed ? "" : (", " + png).c_str());
  return 0;
}

// ---------------------------------------------------------------------------------------------
// cardioid

// The faces of the components of `m` that stay off the box walls: the cut-off solid of h^2 + c
// also holds the escaping exterior, whose surface is the box; its inner surface faces J.
TriMesh inner_part(const TriMesh& m, const Params& p) {
  const std::vector<uint32_t> component = face_components(m);
  const double eps = 0.5 * voxel_size(p);
  auto on_wall = [&](uint32_t v) {
    for (int k = 0; k < 3; ++k)
      if (m.positions[v][k] <= p.bounds.min[k] + eps || m.positions[v][k] >= p.bounds.max[k] - eps)
        return true;
    return false;
  };
  std::vector<char> touches;
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    if (component[f] >= touches.size()) touches.resize(component[f] + 1, 0);
    for (uint32_t v : m.triangles[f])
      if (on_wall(v)) touches[component[f]] = 1;
  }
  TriMesh out;
  std::vector<uint32_t> remap(m.positions.size(), UINT32_MAX);
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    if (touches[component[f]]) continue;
    const auto& t = m.triangles[f];
    std::array<uint32_t, 3> face;
    for (int k = 0; k < 3; ++k) {
      if (remap[t[k]] == UINT32_MAX) {
        remap[t[k]] = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(m.positions[t[k]]);
      }
      face[k] = remap[t[k]];
    }
    out.triangles.push_back(face);
  }
  return out;
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
    const Run e = mesh_of(escape, o);
    Run c = mesh_of(cutoff, o);
    const TriMesh inner = inner_part(c.mesh, base);
    Row row{n, e.measure, measure(inner), distances(e.mesh, inner, o)};
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
  OutputFiles written;  // removed again unless every file is written
  const std::string png = o.out + "/cardioid.png";
  const auto plot_failed = write_figure(png, [&] {
    PlotOptions po;
    po.title = "Escape vs cut-off: distance";
    po.x_label = "iterations N";
    po.reference = voxel;
    po.reference_label = "one voxel";
    return log_plot(std::vector<double>(iterations.begin(), iterations.end()),
                    {{"Hausdorff", {210, 30, 30}, hausdorff},
                     {"mean escape -> cut-off", {30, 80, 210}, mean_ec},
                     {"mean cut-off -> escape", {20, 150, 60}, mean_ce}},
                    po);
  });
  const std::string plot_note =
      plot_failed ? "\nPlot skipped: " + *plot_failed + "\n"
                  : "\nPlot: cardioid.png (log-log; x: iterations; y: distance; red: Hausdorff "
                    "distance; blue: mean escape -> cut-off; green: mean cut-off -> escape; "
                    "dashed grey: one voxel).\n";
  if (plot_failed) std::fprintf(stderr, "cardioid: plot skipped (%s)\n", plot_failed->c_str());
  md << plot_note;
  if (!plot_failed) written.add(png);
  for (const auto& [name, text] : {std::pair<std::string, std::string>{"cardioid.csv", csv.str()},
                                   {"cardioid.md", md.str()}}) {
    write_file_atomic(o.out + "/" + name, text);
    written.add(o.out + "/" + name);
  }
  throw_if_cancelled(o.cancel);
  written.commit();
  std::fputs(md.str().c_str(), stdout);
  std::printf("\nwrote %s/cardioid.md, %s/cardioid.csv%s\n", o.out.c_str(), o.out.c_str(),
              plot_failed ? "" : (", " + png).c_str());
  return 0;
}

}  // namespace

int cmd_experiment(const Tokens& tokens, const CancelToken& cancel) {
  const std::vector<OptionSpec> specs = {{"resolution", true}, {"out", true},     {"samples", true},
                                         {"iterations", true}, {"threads", true}, {"help", false}};
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
  o.cancel = &cancel;
  if (auto r = args.get("resolution"))
    o.resolution = static_cast<int>(parse_int(*r, "--resolution", {8, 1024}));
  if (auto s = args.get("samples"))
    o.samples = static_cast<std::size_t>(parse_int(*s, "--samples", kSamplesRange));
  const ThreadLimit threads(args);
  if (auto it = args.get("iterations")) {
    if (name != "cardioid") throw InvalidInput("--iterations is an option of 'cardioid' only");
    for (double x : parse_doubles(*it, 0, "--iterations", {1, 10000})) {
      if (x != std::floor(x))
        throw InvalidInput("--iterations takes whole numbers in 1..10000, got " + fmt(x));
      o.iterations.push_back(static_cast<int>(x));
    }
    std::sort(o.iterations.begin(), o.iterations.end());
    o.iterations.erase(std::unique(o.iterations.begin(), o.iterations.end()), o.iterations.end());
  }
  if (name != "table1" && name != "cardioid")
    throw InvalidInput("unknown experiment '" + name + "' (known: table1, cardioid)");
  o.out = args.output_file("out").value_or(".");
  std::error_code ec;
  const bool existed = std::filesystem::exists(o.out, ec);
  std::filesystem::create_directories(o.out, ec);
  if (!std::filesystem::is_directory(o.out))
    throw InvalidInput("--out " + o.out + ": cannot create the directory");
  try {
    return name == "table1" ? run_table1(o) : run_cardioid(o);
  } catch (...) {
    if (!existed) std::filesystem::remove(o.out, ec);  // made for this run, and still empty
    throw;
  }
}

}  // namespace qjulia::cli
