// qjulia bench: speed of the pipeline on presets and resolutions.
#include <cstdio>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "malloc_setup.h"
#include "qjulia/base/error.h"
#include "qjulia/field/kernel_speed.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::cli {
namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(item);
  return out;
}

}  // namespace

int cmd_bench(const Tokens& tokens, const CancelToken& cancel) {
  const ParsedArgs args = parse_args(tokens,
                                     {{"presets"},
                                      {"resolutions"},
                                      {"threads"},
                                      {"max-memory"},
                                      {"dense", false},
                                      {"kernel", false},
                                      {"malloc", false},
                                      {"help", false}},
                                     "bench");
  if (args.has("help")) {
    std::puts(
        "usage: qjulia bench [--presets a,b] [--resolutions 256,512] [--threads T]\n"
        "                    [--max-memory SIZE] [--dense] [--kernel] [--malloc]\n"
        "Prints the speed of the compiled formula against a hand-written kernel of the same map\n"
        "(h^2 + c, voxel-iterations per second on one core), then runs the pipeline (sample,\n"
        "extract, clean, measure; no export) and prints figures.\n"
        "Defaults: classic-julia,newton-cubic at 256,512 on all cores.\n"
        "  --kernel             only the malloc lines and the kernel comparison\n"
        "  --malloc             only the malloc lines (huge pages, thresholds)\n"
        "  --resolutions LIST   comma-separated, each 1..1000000\n"
        "  --threads T          worker threads, 1..1024\n"
        "  --max-memory SIZE    the memory a run may use (4G, 512M; at least 1M)");
    return 0;
  }
  const auto presets = split(args.get("presets").value_or("classic-julia,newton-cubic"));
  if (presets.empty()) throw InvalidInput("--presets: expected preset names, a,b (qjulia presets)");
  std::vector<int> resolutions;
  for (const auto& r : split(args.get("resolutions").value_or("256,512")))
    resolutions.push_back(static_cast<int>(parse_int(r, "--resolutions", kResolutionRange)));
  if (resolutions.empty())
    throw InvalidInput("--resolutions: expected resolutions, 1..1000000 each (e.g. 256,512)");
  const ThreadLimit threads(args);
  const int nthreads = threads.threads();
  const auto max_memory = max_memory_from_args(args);
  for (const auto& name : presets) preset(name);  // an unknown name fails before any run
  std::printf("malloc on transparent huge pages: %s\n", malloc_huge_pages_state().c_str());
  std::printf("malloc thresholds: %s\n", malloc_thresholds_state().c_str());
  if (args.has("malloc")) return 0;
  {
    const auto [band, box] = measure_kernel_speed();
    std::printf("kernel of h^2 + c (classic-julia), one core, voxel-iterations per second:\n");
    std::printf("%-24s %9s %14s %14s %8s\n", "batch", "points", "compiled", "reference", "ratio");
    for (const KernelSpeed& k : {band, box})
      std::printf("%-24s %9zu %10.3g (%s) %8.3g (%s) %8.2f\n", k.batch.c_str(), k.points,
                  k.compiled, k.compiled_target.c_str(), k.reference, k.reference_isa.c_str(),
                  k.reference > 0 ? k.compiled / k.reference : 0.0);
    std::fflush(stdout);
    if (args.has("kernel")) return 0;
  }
  std::printf("qjulia %s bench, %d thread(s)%s\n", version(), nthreads,
              args.has("dense") ? ", dense sampling" : "");
  std::printf("%-16s %5s %12s %8s %12s %12s %9s %9s %9s %9s %9s %8s\n", "preset", "res",
              "evaluations", "% dense", "faces", "voxit/s", "sample s", "extract s", "clean s",
              "measure s", "total s", "peak MB");
  for (const auto& name : presets)
    for (int res : resolutions) {
      Params p = preset(name);
      p.resolution = res;
      PipelineOptions opts;
      opts.dense = args.has("dense");
      opts.max_memory = max_memory;
      opts.cancel = &cancel;
      const PipelineResult r = run_pipeline(p, opts);
      const RunStats& s = r.stats;
      auto stage = [&](const char* n) {
        for (const auto& [stage_name, sec] : s.timings)
          if (stage_name == n) return sec;
        return 0.0;
      };
      double total = 0;
      for (const auto& [stage_name, sec] : s.timings) total += sec;
      const double classify_time = stage("sample") + stage("extract");
      // voxel-iterations: all classifier calls (sampling and refinement) times the iteration
      // count, an upper bound of the iterations done, since orbits stop when they escape or
      // converge.
      const double voxit =
          static_cast<double>(s.evaluations + s.refine_evaluations) * p.iterations / classify_time;
      std::printf("%-16s %5d %12llu %8.3f %12zu %12.3g %9.3f %9.3f %9.3f %9.3f %9.3f %8.0f\n",
                  name.c_str(), res, static_cast<unsigned long long>(s.evaluations),
                  100.0 * s.evaluations / s.dense_evaluations, s.measure.faces, voxit,
                  stage("sample"), stage("extract"), stage("clean"), stage("measure"), total,
                  s.peak_rss_bytes / 1048576.0);
      std::fflush(stdout);
    }
  return 0;
}

}  // namespace qjulia::cli
