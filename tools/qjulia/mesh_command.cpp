#include "mesh_command.h"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/io/mesh_io.h"
#include "render_args.h"

namespace qjulia::cli {
namespace {

constexpr const char* kHelp =
    R"help(usage: %s [PARAMS.json | MESH] [options] -o OUT.(glb|gltf|obj|ply|stl|3mf)

Meshes the solid of a quaternionic Julia set. Without parameters: the Newton cubic
(2h^3+1)/(3h^2) with the cut-off method (preset newton-cubic). MESH: a .glb, .gltf, .obj,
.ply or .3mf that qjulia wrote; its recorded parameters are used (an STL's are in its
sidecar, MESH.stl.json).

parameters (override the file or preset; each number must lie in the range shown):
  --preset NAME              start from a built-in preset (qjulia presets)
  --formula F                e.g. "h^2+c", "(2*h^3+1)/(3*h^2)", "p*h^2+q"
  --const NAME=w,x,y,z       a quaternion constant (repeatable); NAME=real for a real one;
                             components -1000000..1000000
  --mode julia|mandelbrot    mandelbrot: the sampled point is c, h0 = --start
  --method escape|cutoff     escape: |h_k| <= R for all k; cutoff: |h_k - h_k-1| >= R for all k
  --iterations N             N, 1..100000
  --bailout R                R, 1e-12..1e+12
  --resolution N             voxels along the longest side of the box, 1..1000000 (what fits
                             in memory is checked before sampling)
  --bounds x0,y0,z0,x1,y1,z1 the sampled box, -1000000..1000000, x0 < x1, y0 < y1, z0 < z1
  --axes rmn --fixed W       which quaternion components x, y, z are; the fourth is W,
                             -1000000..1000000
  --start w,x,y,z            h0 in Mandelbrot mode, components -1000000..1000000
mesh:
  --color iterations|basin|none   per-vertex colours
  --faces N                  decimate to at most N faces, 4..1000000000
  --max-error E              decimate within distance E (model units), 1e-09..1000000
  --decimate fast|quality    how: fast (the default), edge collapses that keep the components
                             and the genus, in parallel; without --max-error they stop above a
                             budget that would move the surface by more than 1%% of its size;
                             quality, OpenMesh's Decimater, a lower error at the same face
                             count, on one thread (4-20x slower; for --max-error alone the
                             fast method is better: OpenMesh bounds only the input's vertices)
  --min-component V          drop components of volume below V (model units^3), 0..1e+18
  --clip nx,ny,nz,d          keep n.x <= d, closed by a flat cap (repeatable); components
                             -1000000..1000000, n not zero
print:
  --size 80mm                scale the longest side to this length (output in mm),
                             0.001..1000000 mm (mm, cm or m)
  --min-thickness 0.8mm      thicken parts thinner than this, 0.001..1000000 mm
  --check                    count self-intersections
run:
  -o, --output OUT           the mesh file; the format follows the extension
  --stats FILE               figures of the run as JSON ('-': on standard output, the
                             summary on standard error)
  --vdb FILE                 the sampled grid as an OpenVDB file
  --preview FILE.png         a preview image of the mesh (--preview-shading, --preview-rotate,
                             ... as for qjulia render; listed below)
  --dense                    evaluate every grid point (validation)
  --threads T                worker threads of every stage, 1..1024 (default: all cores)
  --max-memory SIZE          the memory the run may use, e.g. 4G or 512M (K, M, G, T = 2^10..
                             2^40 bytes; at least 1M); default: what the system has free
  --quiet                    no progress bar
)help";

}  // namespace

#if defined(__SANITIZE_ADDRESS__)
#define QJULIA_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define QJULIA_SANITIZED 1
#endif
#endif

void exit_without_freeing(int code) {
  std::fflush(nullptr);
#ifdef QJULIA_SANITIZED
  std::exit(code);
#else
  std::_Exit(code);
#endif
}

const char* const kEmptySolidHint =
    "; nothing written. Hint: check the bailout, the iterations, the box and the clip planes "
    "(qjulia params shows them)";

std::string nothing_written(const Params& params, const RunStats& stats) {
  return empty_mesh_message(params, stats) +
         (removed_as_dust(stats) ? std::string("; nothing written") : kEmptySolidHint);
}

std::unique_ptr<MeshCommand> parse_mesh_command(const std::vector<std::string>& tokens,
                                                const CancelToken& cancel,
                                                const std::string& program) {
  auto specs = param_option_specs();
  for (const char* name : {"output", "stats", "vdb", "preview", "threads", "max-memory"})
    specs.push_back({name});
  for (const char* name : {"dense", "quiet", "help"}) specs.push_back({name, false});
  const auto preview_specs = render_option_specs("preview-");
  specs.insert(specs.end(), preview_specs.begin(), preview_specs.end());
  auto cmd = std::make_unique<MeshCommand>();
  cmd->program = program;
  cmd->args = parse_args(tokens, specs, "mesh");
  const ParsedArgs& args = cmd->args;
  if (args.has("help")) {
    std::printf(kHelp, program.c_str());
    std::printf("preview (with --preview):\n%s", render_options_help("preview-").c_str());
    return nullptr;
  }
  if (args.positional.size() > 1)
    throw InvalidInput("expected at most one parameter file, got '" + args.positional[1] + "'");
  const auto out = args.output_file("output");
  if (!out) throw InvalidInput("missing -o OUT (e.g. -o julia.glb)");
  cmd->out = *out;
  format_from_path(cmd->out);  // an unknown extension fails before any work
  cmd->params = params_from_args(args, args.positional.empty() ? "" : args.positional[0]);
  cmd->params_json = params_to_json(cmd->params);
  if (args.get("decimate") && !cmd->params.mesh.faces && !cmd->params.mesh.max_error)
    std::fprintf(stderr,
                 "%s: note: --decimate chooses how --faces or --max-error is met; without "
                 "either the mesh is not decimated\n",
                 cmd->program.c_str());
  cmd->threads = std::make_unique<ThreadLimit>(args);
  cmd->preview = args.output_file("preview");
  cmd->stats_path = args.output_file("stats");
  cmd->vdb = args.output_file("vdb");
  // Checked before the long run, so a bad value fails at once.
  cmd->preview_options = render_options_from_args(args, "preview-");
  cmd->preview_options.cancel = &cancel;
  if (cmd->preview) check_render_options(cmd->preview_options);
  // Every output is checked before the long run: not an input, not a directory or device.
  OutputFiles& written = cmd->written;
  if (!args.positional.empty()) written.add_input(args.positional[0]);
  for (const auto& f : output_files(cmd->out)) written.claim(f);
  if (format_from_path(cmd->out) == MeshFormat::kStl) written.claim(cmd->out + ".json");
  for (const char* name : {"vdb", "preview"})
    if (args.get(name) == "-")
      throw InvalidInput(std::string("--") + name + " takes a file name ('-' is not standard " +
                         "output here: only --stats writes there)");
  if (cmd->preview && !is_png_path(*cmd->preview))
    throw InvalidInput("--preview: '" + *cmd->preview + "' must end in .png (the image is a PNG)");
  auto extension = [](const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
  };
  if (cmd->vdb && extension(*cmd->vdb) != ".vdb")
    throw InvalidInput("--vdb: '" + *cmd->vdb + "' must end in .vdb (the grid is an OpenVDB file)");
  for (const char* name : {"vdb", "preview", "stats"})
    if (auto f = args.get(name); f && *f != "-") written.claim(*f);

  PipelineOptions& popts = cmd->pipeline;
  popts.dense = args.has("dense");
  popts.keep_grid = cmd->vdb.has_value();
  popts.max_memory = max_memory_from_args(args);
  popts.outputs = {format_from_path(cmd->out)};
  popts.preview = cmd->preview.has_value();
  popts.cancel = &cancel;
  return cmd;
}

void finish_mesh_command(MeshCommand& cmd, RunStats& stats, const TriMesh* mesh,
                         const CancelToken& cancel) {
  OutputFiles& written = cmd.written;
  for (const auto& f : output_files(cmd.out)) written.add(f);  // .gltf comes with its .bin
  std::string sidecar;
  if (format_from_path(cmd.out) == MeshFormat::kStl) {
    // STL has no room for the parameters: they go into a sidecar file.
    sidecar = cmd.out + ".json";
    write_file_atomic(sidecar, cmd.params_json);
    written.add(sidecar);
  }
  if (cmd.preview) {
    write_png(*cmd.preview, render(*mesh, cmd.preview_options));
    written.add(*cmd.preview);
  }
  const bool stats_out = cmd.stats_path == "-";
  std::string stats_json;
  if (cmd.stats_path) {
    stats.peak_rss_bytes = peak_rss_bytes();
    stats_json = stats_to_json(stats, cmd.params);
    if (!stats_out) {
      write_file_atomic(*cmd.stats_path, stats_json);
      written.add(*cmd.stats_path);
    }
  }
  throw_if_cancelled(&cancel);  // a signal during the last writes still removes every file
  written.commit();

  // With the stats on standard output, the summary goes to standard error.
  FILE* const summary = stats_out ? stderr : stdout;
  const MeshMeasure& m = stats.measure;
  std::fprintf(summary, "mesh:  %s (%zu vertices, %zu faces, %s, %s, volume %.6g, area %.6g)\n",
               cmd.out.c_str(), m.vertices, m.faces, m.closed ? "closed" : "OPEN",
               m.manifold ? "manifold" : "NON-MANIFOLD", m.volume, m.area);
  if (!sidecar.empty()) std::fprintf(summary, "parameters: %s\n", sidecar.c_str());
  if (cmd.stats_path && !stats_out) std::fprintf(summary, "stats: %s\n", cmd.stats_path->c_str());
  if (cmd.vdb) std::fprintf(summary, "grid:  %s\n", cmd.vdb->c_str());
  if (cmd.preview) std::fprintf(summary, "preview: %s\n", cmd.preview->c_str());
  if (const auto& t = cmd.params.print.min_thickness_mm;
      t && stats.extent_before_thickening > 0 && *t > stats.extent_before_thickening)
    std::fprintf(stderr,
                 "%s: note: --min-thickness %g mm is more than the whole model (%.3g %s across "
                 "before thickening): every part of it was thickened%s\n",
                 cmd.program.c_str(), *t, stats.extent_before_thickening,
                 stats.unit == "mm" ? "mm" : "model units",
                 stats.unit == "mm" ? "" : " (without --size, model units are read as mm)");
  if (stats.decimate && !stats.decimate->target_reached) {
    const auto& d = *stats.decimate;
    const auto& mp = cmd.params.mesh;
    const bool fast = mp.decimate == Decimation::kFast;
    if (mp.faces && d.faces_after > static_cast<std::size_t>(*mp.faces)) {
      const char* why =
          fast ? (mp.max_error ? "no collapse left keeps the topology within --max-error"
                               : "no collapse left keeps the topology and moves the surface by "
                                 "less than 1% of its bounding box's diagonal")
               : (mp.max_error ? "no collapse left keeps the genus, stays within --max-error and "
                                 "turns a face by less than 45 degrees"
                               : "no collapse left keeps the genus and turns a face by less than "
                                 "45 degrees");
      std::fprintf(stderr,
                   "%s: note: decimation stopped at %zu faces, above the %lld asked for (%s)%s\n",
                   cmd.program.c_str(), d.faces_after, *mp.faces, why,
                   fast && !mp.max_error ? "; a --max-error above that lets it go further" : "");
    } else {
      std::fprintf(stderr,
                   "%s: note: the decimated mesh is %.3g from the input, above --max-error%s\n",
                   cmd.program.c_str(), d.hausdorff,
                   fast ? ""
                        : " (the quality method bounds only the input's vertices; the fast "
                          "method holds such bounds)");
    }
  }
  double total = 0;
  for (const auto& [stage, s] : stats.timings) total += s;
  // The dense path (--dense, and grids of at most 32 points a side) evaluates each brick's 9^3
  // points, its faces shared with the neighbours among them: more calls than grid points.
  const bool over = stats.evaluations > stats.dense_evaluations;
  std::fprintf(summary,
               over ? "evaluations: %llu grid (%.2fx the %llu grid points: each brick's 9^3, its "
                      "shared faces evaluated again) + %llu refinement, %.2f s\n"
                    : "evaluations: %llu grid (%.2f%% of %llu dense) + %llu refinement, %.2f s\n",
               static_cast<unsigned long long>(stats.evaluations),
               (over ? 1.0 : 100.0) * stats.evaluations / stats.dense_evaluations,
               static_cast<unsigned long long>(stats.dense_evaluations),
               static_cast<unsigned long long>(stats.refine_evaluations), total);
  if (stats_out) {
    std::fwrite(stats_json.data(), 1, stats_json.size(), stdout);
    if (stats_json.empty() || stats_json.back() != '\n') std::fputc('\n', stdout);
    std::fflush(stdout);
  }
}

}  // namespace qjulia::cli
