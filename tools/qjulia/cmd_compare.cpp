// qjulia compare A B: measures of two surfaces (mesh files or parameter sets) and the two-sided
// Hausdorff distance between them.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "cli.h"
#include "commands.h"
#include "files.h"
#include "progress_bar.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::cli {

namespace {

constexpr const char* kHelp = R"(usage: qjulia compare A B [options]

A and B are mesh files (.glb .gltf .obj .ply .stl .3mf), parameter files (.json, or
--params FILE) or presets (--preset NAME), in the order given; any two of them, e.g.
  qjulia compare a.glb b.ply
  qjulia compare --preset newton-cubic --preset newton-escape --resolution 128
The parameter flags (--resolution, --iterations, ...) apply to both parameter sets.

options:
  --json FILE       write the measures and distances as JSON
  --colored FILE    write A with its per-vertex distance to B as a colour ramp
                    (blue = 0 ... red = the largest distance; the range is in the metadata)
  --samples N       surface samples per surface: every vertex, then area-proportional random
                    points up to N, 0..100000000 (default 1000000)
  --threads T       worker threads of meshing and comparing, 1..1024 (default: all cores)
  --max-memory SIZE the memory meshing a parameter set or reading a mesh file may use, e.g. 4G
                    or 512M (K, M, G, T = 2^10..2^40 bytes; at least 1M); default: what the
                    system has free
  --quiet           no progress bar
)";

// One of the two surfaces and where it comes from.
struct Source {
  enum Kind { kMesh, kParamsFile, kPreset } kind;
  std::string value;
  std::string label() const { return kind == kPreset ? "preset " + value : value; }
};

bool ends_with_json(const std::string& s) {
  if (s.size() < 5) return false;
  std::string ext = s.substr(s.size() - 5);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".json";
}

const OptionSpec* find_spec(const std::vector<OptionSpec>& specs, const std::string& name) {
  for (const auto& s : specs)
    if (s.name == name) return &s;
  return nullptr;
}

// The surfaces in command-line order (ParsedArgs keeps positionals and options apart, so the
// order is taken from the tokens).
std::vector<Source> sources_in_order(const Tokens& tokens, const std::vector<OptionSpec>& specs) {
  std::vector<Source> out;
  bool only_positional = false;
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const std::string& t = tokens[i];
    if (t == "--" && !only_positional) {
      only_positional = true;
    } else if (!only_positional && t.rfind("--", 0) == 0 && t.size() > 2) {
      const std::size_t eq = t.find('=');
      const std::string name = t.substr(2, eq == std::string::npos ? std::string::npos : eq - 2);
      const OptionSpec* spec = find_spec(specs, name);
      std::string value;
      if (spec && spec->takes_value && eq == std::string::npos) {
        if (i + 1 < tokens.size()) value = tokens[++i];
      } else if (eq != std::string::npos) {
        value = t.substr(eq + 1);
      }
      if (name == "preset") out.push_back({Source::kPreset, value});
      if (name == "params") out.push_back({Source::kParamsFile, value});
    } else {
      out.push_back({ends_with_json(t) ? Source::kParamsFile : Source::kMesh, t});
    }
  }
  return out;
}

// A mesh file, with any failure to read it reported as bad input naming the file.
TriMesh load_mesh(const std::string& path, std::optional<std::size_t> max_memory) {
  try {
    ReadOptions ro;
    ro.max_memory = max_memory;
    return read_mesh(path, ro);
  } catch (const InvalidInput&) {
    throw;
  } catch (const std::exception& e) {
    throw InvalidInput(path + ": " + e.what());
  }
}

// The parameters of a parameter source: the shared flags apply, the other surface's --preset /
// --params do not. Checked before any meshing starts, so a typo fails at once.
Params params_of(const Source& s, const ParsedArgs& args) {
  ParsedArgs own;
  for (const auto& [name, value] : args.options)
    if (name != "preset" && name != "params") own.options.emplace_back(name, value);
  if (s.kind == Source::kPreset) own.options.emplace_back("preset", s.value);
  return params_from_args(own, s.kind == Source::kParamsFile ? s.value : "");
}

TriMesh make_mesh(const Source& s, const std::optional<Params>& params, bool quiet,
                  std::optional<std::size_t> max_memory, const CancelToken& cancel) {
  if (!params) return load_mesh(s.value, max_memory);
  ProgressBar bar(quiet);
  PipelineOptions opts;
  opts.progress = bar.callback();
  opts.cancel = &cancel;
  opts.max_memory = max_memory;
  PipelineResult r = run_pipeline(*params, opts);
  bar.finish();
  return std::move(r.mesh);
}

std::string fmt(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

void print_table(const CompareResult& r, const std::string& na, const std::string& nb) {
  auto row = [](const std::string& name, const std::string& a, const std::string& b) {
    std::printf("  %-20s %-38s %s\n", name.c_str(), a.c_str(), b.c_str());
  };
  auto bbox = [](const std::array<double, 3>& v) {
    return fmt(v[0]) + ", " + fmt(v[1]) + ", " + fmt(v[2]);
  };
  auto n = [](std::size_t x) { return std::to_string(x); };
  row("", "A", "B");
  row("source", na, nb);
  row("vertices", n(r.a.vertices), n(r.b.vertices));
  // Files that split vertices at seams: the measures merge them (said, where it happened).
  if (r.a_welded || r.b_welded) row("  merged at seams", n(r.a_welded), n(r.b_welded));
  row("faces", n(r.a.faces), n(r.b.faces));
  row("area", fmt(r.a.area), fmt(r.b.area));
  row("volume", fmt(r.a.volume), fmt(r.b.volume));
  row("components", n(r.a.components.size()), n(r.b.components.size()));
  row("genus per component", genus_summary(r.a, 3), genus_summary(r.b, 3));
  row("euler (whole mesh)", std::to_string(r.a.euler), std::to_string(r.b.euler));
  row("boundary edges", n(r.a.boundary_edges), n(r.b.boundary_edges));
  row("non-manifold edges", n(r.a.nonmanifold_edges), n(r.b.nonmanifold_edges));
  row("bbox min", bbox(r.a.bbox_min), bbox(r.b.bbox_min));
  row("bbox max", bbox(r.a.bbox_max), bbox(r.b.bbox_max));
  std::printf("\n  %-20s %-12s %-12s %-12s %s\n", "distance", "max", "mean", "rms", "samples");
  for (const auto& [name, d] :
       {std::pair<const char*, const DirectedDistance&>{"A -> B", r.a_to_b}, {"B -> A", r.b_to_a}})
    std::printf("  %-20s %-12s %-12s %-12s %zu\n", name, fmt(d.max).c_str(), fmt(d.mean).c_str(),
                fmt(d.rms).c_str(), d.samples);
  double diag = 0;
  for (int k = 0; k < 3; ++k) {
    const double e =
        std::max(r.a.bbox_max[k], r.b.bbox_max[k]) - std::min(r.a.bbox_min[k], r.b.bbox_min[k]);
    diag += e * e;
  }
  diag = std::sqrt(diag);
  std::printf("\n  Hausdorff distance   %s", fmt(r.hausdorff).c_str());
  if (diag > 0) std::printf("  (%.3g%% of the bounding-box diagonal)", 100 * r.hausdorff / diag);
  std::printf("\n");
}

}  // namespace

int cmd_compare(const Tokens& tokens, const CancelToken& cancel) {
  std::vector<OptionSpec> specs = param_option_specs();
  if (!find_spec(specs, "params")) specs.push_back({"params", true});
  specs.push_back({"json", true});
  specs.push_back({"colored", true});
  specs.push_back({"samples", true});
  specs.push_back({"threads", true});
  specs.push_back({"max-memory", true});
  if (!find_spec(specs, "quiet")) specs.push_back({"quiet", false});
  if (!find_spec(specs, "help")) specs.push_back({"help", false});
  const ParsedArgs args = parse_args(tokens, specs, "compare");
  if (args.has("help")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  const std::vector<Source> sources = sources_in_order(tokens, specs);
  if (sources.size() != 2)
    throw InvalidInput("needs two surfaces (mesh files, parameter files or --preset NAME), got " +
                       std::to_string(sources.size()) + " (see 'qjulia compare --help')");
  CompareOptions opts;
  opts.cancel = &cancel;
  if (auto s = args.get("samples"))
    opts.samples = static_cast<std::size_t>(parse_int(*s, "--samples", kSamplesRange));
  const ThreadLimit threads(args);
  const std::optional<std::size_t> max_memory = max_memory_from_args(args);
  const bool quiet = args.has("quiet");
  const std::string json_path = args.output_file("json").value_or("");
  const std::string colored_path = args.output_file("colored").value_or("");
  if (!colored_path.empty()) format_from_path(colored_path);  // a bad extension fails now
  // The outputs are checked now: never an input (--colored A would replace A), a directory
  // or a device.
  OutputFiles files;
  for (const Source& s : sources)
    if (s.kind != Source::kPreset) files.add_mesh_input(s.value);
  if (!json_path.empty()) files.claim(json_path);
  if (!colored_path.empty())
    for (const auto& f : output_files(colored_path)) files.claim(f);

  std::array<std::optional<Params>, 2> params;
  for (int i = 0; i < 2; ++i) {
    if (sources[i].kind != Source::kMesh) {
      params[i] = params_of(sources[i], args);
    } else if (!std::ifstream(sources[i].value, std::ios::binary)) {
      throw InvalidInput(sources[i].value + ": cannot open the file (missing or unreadable)");
    }
  }
  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  const auto t0 = Clock::now();
  const TriMesh a = make_mesh(sources[0], params[0], quiet, max_memory, cancel);
  const double time_a = since(t0);
  const auto t1 = Clock::now();
  const TriMesh b = make_mesh(sources[1], params[1], quiet, max_memory, cancel);
  const double time_b = since(t1);
  const auto t2 = Clock::now();
  if (a.triangles.empty()) throw InvalidInput(sources[0].label() + ": the surface is empty");
  if (b.triangles.empty()) throw InvalidInput(sources[1].label() + ": the surface is empty");

  ProgressBar bar(quiet);
  opts.progress = [&bar](double f) {
    bar.update("compare", f);
    return true;
  };
  const CompareResult r = compare(a, b, opts);
  bar.finish();

  const double time_compare = since(t2);
  print_table(r, sources[0].label(), sources[1].label());
  std::printf("  time                 A %.2f s (%s), B %.2f s (%s), compare %.2f s\n", time_a,
              params[0] ? "meshed" : "read", time_b, params[1] ? "meshed" : "read", time_compare);
  throw_if_cancelled(&cancel);
  if (!json_path.empty()) {
    write_file_atomic(json_path, compare_to_json(r, sources[0].label(), sources[1].label()));
    files.add(json_path);
  }
  if (!colored_path.empty()) {
    TriMesh colored = a;
    const double hi = r.a_to_b.max > 0 ? r.a_to_b.max : 1.0;
    colored.colors = distance_colors(r.a_vertex_distance, 0.0, hi);
    ExportOptions eo;
    eo.cancel = &cancel;
    eo.params_json = compare_legend_json(0.0, hi, sources[0].label(), sources[1].label());
    write_mesh(colored_path, colored, eo);
  }
  files.commit();
  return 0;
}

}  // namespace qjulia::cli
