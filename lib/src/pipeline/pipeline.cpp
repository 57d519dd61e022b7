#include "qjulia/pipeline/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <new>
#include <nlohmann/json.hpp>

#include "base/distribution.h"
#include "base/mesh_json.h"
#include "base/vdb_module.h"
#include "grid/grid_impl.h"
#include "io/part_writer.h"
#include "io/threemf_module.h"
#include "pipeline/dust.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/field/classify.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/decimate.h"
#include "qjulia/mesh/print.h"
#include "qjulia/pipeline/distributed.h"
#include "qjulia/surface/extract.h"
#include "surface/part.h"

namespace qjulia {
namespace {

class StageTimer {
 public:
  StageTimer(RunStats& stats, const StageProgressFn& progress, const CancelToken* cancel)
      : stats_(stats), progress_(progress), cancel_(cancel) {}

  // Starts `stage` and returns its ProgressFn.
  ProgressFn start(const std::string& stage) {
    stage_ = stage;
    begin_ = std::chrono::steady_clock::now();
    throw_if_cancelled(cancel_);
    if (progress_ && !progress_(stage, 0.0)) throw Cancelled();
    return [this, stage](double f) {
      return !(cancel_ && cancel_->requested()) && (!progress_ || progress_(stage, f));
    };
  }
  void stop() {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin_).count();
    stats_.timings.emplace_back(stage_, s);
  }
  // The stage started last.
  const std::string& stage() const { return stage_; }

 private:
  RunStats& stats_;
  const StageProgressFn& progress_;
  const CancelToken* cancel_;
  std::string stage_;
  std::chrono::steady_clock::time_point begin_;
};

// The figures of the sampled grid (summed over the ranks of a distributed run).
void record_grid(const SampledGrid& grid, Comm* comm, RunStats& stats) {
  auto total = [&](std::uint64_t v) { return comm ? comm->sum(v) : v; };
  stats.evaluations = total(grid.evaluations());
  stats.dense_evaluations = grid.dense_evaluations();
  stats.crossing_cells = total(grid.crossing_cells());
  stats.voxel_size = grid.voxel_size();
  stats.grid_points = grid.points();
}

// A run's std::bad_alloc (an allocation that the address-space limit, or the system, refused)
// as a TooLarge: one line that names the stage, what the process held, and the estimate and the
// limit it was checked against, and the CLI's exit code of a run too large (2), not a bare
// "std::bad_alloc". Every stage's memory is released as the exception unwinds, before the message
// is built. One process's runs only: a rank of a distributed run that runs out of memory is alone
// in it, and ends the job (qjulia-mpi), since the other ranks may be waiting for it.
template <class Stages>
auto with_memory_message(const Params& params, const RunStats& stats, const StageTimer& timer,
                         Stages&& stages) -> decltype(stages()) {
  try {
    return stages();
  } catch (const std::bad_alloc&) {
    std::string what = "resolution " + std::to_string(params.resolution) +
                       " ran out of memory in the " + timer.stage() + " stage (peak " +
                       format_bytes(static_cast<double>(peak_rss_bytes())) + " resident";
    if (stats.estimate.peak_bytes)
      what += "; estimated " + format_bytes(static_cast<double>(stats.estimate.peak_bytes)) +
              ", limit " + stats.memory_limit_source;
    throw TooLarge(what + "); a lower --resolution, or more memory, may fit");
  }
}

// What the run does besides sampling, extracting and cleaning, for the estimate.
RunPlan run_plan(const PipelineOptions& opts) {
  RunPlan plan;
  plan.outputs = opts.outputs;
  plan.dense = opts.dense;
  plan.keep_grid = opts.keep_grid;
  plan.preview = opts.preview;
  plan.cancel = opts.cancel;
  return plan;
}

// The estimate of the run and the limit it is checked against (described, then `where`), in
// `stats`; refuses the run when it does not fit (check_run).
void estimate_and_check(const Solid& solid, const RunPlan& plan, const PipelineOptions& opts,
                        RunStats& stats, const std::string& where = "") {
  const Params& params = solid.classifier().params();
  const MemoryLimits limits = memory_limits(opts.max_memory);
  RunPlan limited = plan;
  limited.limit = limits.effective();
  stats.estimate = estimate_run(solid, limited);
  stats.memory_limit = limited.limit;
  stats.memory_limit_source = limits.describe() + where;
  check_run(params, limited, stats.estimate, limits);
}

// Whether the stages hand the memory they free back to the system between their passes
// (malloc_trim). That keeps a large run's peak down, and costs time: one madvise per free run of
// pages, on one thread, and the pages faulted in again (classic-julia at 256 on one thread ran
// in 0.31 s without, 0.375 s with). A run estimated at 256 MB or less, and at most half the
// memory it may use, keeps what it frees.
bool return_free_memory(const RunStats& stats) {
  constexpr std::size_t kSmallRun = std::size_t(256) << 20;
  return stats.estimate.peak_bytes > kSmallRun ||
         stats.estimate.peak_bytes > stats.memory_limit / 2;
}

// The extraction's options; starts its stage.
ExtractOptions extract_options(const Params& params, const PipelineOptions& opts,
                               StageTimer& timer) {
  ExtractOptions eopts;
  eopts.color = params.mesh.color;
  eopts.cancel = opts.cancel;
  eopts.progress = timer.start("extract");
  return eopts;
}

// The stages after the dust, on the whole mesh: printing (scale first, the thickness is in
// millimetres; thicken, then decimate, so the face budget holds for the final mesh), the
// self-intersection check, the normals and the measures. `known`: the measures of `mesh`
// while they stay true.
void finish_mesh(const Params& params, const PipelineOptions& opts, TriMesh& mesh,
                 std::optional<MeshMeasure>& known, RunStats& stats, StageTimer& timer) {
  if (params.print.size_mm) {
    timer.start("scale");
    stats.scale = scale_to_longest_side(mesh, *params.print.size_mm);
    stats.unit = "mm";
    // The scaled positions are rounded to floats again: the written mesh is measured anew.
    known.reset();
    timer.stop();
  }
  if (params.print.min_thickness_mm) {
    ThickenOptions topts;
    // Without --size the mesh is in model units, read as millimetres.
    topts.min_thickness = *params.print.min_thickness_mm;
    topts.cancel = opts.cancel;
    stats.extent_before_thickening = longest_side(mesh);
    topts.progress = timer.start("thicken");
    mesh = thicken(mesh, topts);
    known.reset();
    timer.stop();
  }
  if (params.mesh.faces || params.mesh.max_error) {
    DecimateOptions dopts;
    dopts.faces = params.mesh.faces;
    dopts.method = params.mesh.decimate == Decimation::kQuality ? DecimateMethod::kQuality
                                                                : DecimateMethod::kFast;
    // max_error is in model units; the mesh may have been scaled to millimetres.
    if (params.mesh.max_error) dopts.max_error = *params.mesh.max_error * stats.scale;
    dopts.avoid_self_intersections = params.print.check;
    dopts.cancel = opts.cancel;
    dopts.progress = timer.start("decimate");
    DecimateReport dreport;
    mesh = decimate(mesh, dopts, &dreport);
    known.reset();
    timer.stop();
    stats.decimate = dreport;
  }
  if (params.print.check) {
    timer.start("check");
    stats.self_intersections = count_self_intersections(mesh);
    timer.stop();
  }
  if (opts.normals && mesh.normals.size() != mesh.positions.size()) compute_normals(mesh);

  timer.start("measure");
  stats.measure = known ? std::move(*known) : measure(mesh);
  timer.stop();
}

}  // namespace

const char* version() { return QJULIA_VERSION; }

std::string empty_solid_message(const Params& params) {
  return params.mesh.clip.empty()
             ? "the solid is empty with these parameters (no grid point of the box is in it)"
             : "the solid is empty with these parameters (no grid point of the box on the kept "
               "side of the clip planes is in it)";
}

bool removed_as_dust(const RunStats& stats) {
  return stats.clean && stats.clean->components_before > 0 && stats.clean->components_after == 0;
}

std::string empty_mesh_message(const Params& params, const RunStats& stats) {
  if (!removed_as_dust(stats)) return empty_solid_message(params);
  const CleanReport& c = *stats.clean;
  auto g = [](double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return std::string(buf);
  };
  const std::string n = std::to_string(c.components_before);
  return "every component of the surface is smaller than the dust threshold (" +
         (c.components_before == 1 ? std::string("its one component has volume ")
                                   : "the largest of its " + n + " components has volume ") +
         g(c.largest_removed_volume) + ", the threshold is " + g(c.min_component_volume) +
         " model units^3" +
         (params.mesh.min_component
              ? std::string(", from --min-component); a smaller --min-component keeps them (0 "
                            "keeps every component)")
              : ", " + g(kDefaultDustVoxels) +
                    " voxel^3 by default); --min-component 0 keeps every component, and a "
                    "higher resolution makes the voxel smaller");
}

PipelineResult run_pipeline(const Params& params, const PipelineOptions& opts) {
  const Solid solid(params);  // validates and compiles, once for the whole run
  // The modules the run will need (OpenVDB's, lib3mf's): a missing one stops the run before the
  // work.
  if (opts.keep_grid || params.print.min_thickness_mm) detail::vdb_api();
  if (std::find(opts.outputs.begin(), opts.outputs.end(), MeshFormat::k3mf) != opts.outputs.end())
    detail::threemf_api();
  PipelineResult result;
  RunStats& stats = result.stats;
  StageTimer timer(stats, opts.progress, opts.cancel);
  with_memory_message(params, stats, timer, [&] {
    // What the run will need, before it starts.
    {
      timer.start("estimate");
      estimate_and_check(solid, run_plan(opts), opts, stats);
      timer.stop();
    }

    SampleOptions sopts;
    sopts.dense = opts.dense;
    sopts.cancel = opts.cancel;
    sopts.return_free_memory = return_free_memory(stats);
    sopts.progress = timer.start("sample");
    SampledGrid grid = sample(solid, sopts);
    timer.stop();
    record_grid(grid, nullptr, stats);

    ExtractOptions eopts = extract_options(params, opts, timer);
    eopts.return_free_memory = sopts.return_free_memory;
    eopts.memory_limit = stats.memory_limit;
    eopts.normals = false;  // made after the dust, below
    ExtractStats estats;
    TriMesh mesh =
        opts.keep_grid ? extract(grid, eopts, &estats) : extract(std::move(grid), eopts, &estats);
    timer.stop();
    stats.refine_evaluations = estats.evaluations;
    stats.unembedded_cells = estats.unembedded_cells;

    // Dust: the extracted mesh is closed, manifold and free of duplicate vertices, and its
    // components are measured, so only the small ones go (the measures follow). A mesh whose
    // bricks did not check out goes through the general clean().
    CleanReport creport;
    std::optional<MeshMeasure> known;  // the measures of `mesh` while they stay true
    {
      const ProgressFn progress = timer.start("clean");
      const double voxel = stats.voxel_size;
      if (estats.measure_valid) {
        const double threshold = params.mesh.min_component
                                     ? *params.mesh.min_component
                                     : kDefaultDustVoxels * voxel * voxel * voxel;
        creport = detail::remove_dust(mesh, estats, threshold);
        known = std::move(estats.measure);
        std::vector<std::uint32_t>().swap(estats.face_component);  // not needed any more
        // The normals of what is left (eopts.normals): the same sums, in the memory the faces'
        // components held; or by the writer.
        if (opts.normals && mesh.normals.size() != mesh.positions.size()) compute_normals(mesh);
      } else {
        // Before the general clean(), which keeps the normals of the vertices it keeps (as when
        // the extraction made them).
        if (mesh.normals.size() != mesh.positions.size()) compute_normals(mesh);
        CleanOptions copts;
        copts.min_component_volume = params.mesh.min_component;
        copts.voxel_size = voxel;
        copts.cancel = opts.cancel;
        copts.progress = progress;
        mesh = clean(mesh, copts, &creport);
      }
    }
    timer.stop();
    stats.clean = creport;

    finish_mesh(params, opts, mesh, known, stats, timer);
    stats.peak_rss_bytes = peak_rss_bytes();
    result.mesh = std::move(mesh);
    if (opts.keep_grid) result.grid = std::move(grid);
  });
  return result;
}

// ------------------------------------------------------------------------- distributed runs

bool stays_distributed(const Params& params, MeshFormat output, bool preview) {
  return detail::part_writable(output) && !preview && !params.mesh.faces &&
         !params.mesh.max_error && !params.print.size_mm && !params.print.min_thickness_mm &&
         !params.print.check;
}

DistributedRun::DistributedRun() = default;
DistributedRun::~DistributedRun() = default;
DistributedRun::DistributedRun(DistributedRun&&) noexcept = default;
DistributedRun& DistributedRun::operator=(DistributedRun&&) noexcept = default;

namespace {

// The whole mesh on rank 0 from the ranks' parts: positions in the whole mesh's numbering,
// faces in rank order.
TriMesh gather_mesh(TriMesh& mine, const detail::MeshPart& part, Comm& comm) {
  Packer p;
  p.put(part.edge_first);
  p.put(part.edges);
  p.put(part.centre_first);
  p.put(part.vertices_total);
  p.put_vector(mine.positions);
  p.put_vector(mine.normals);
  p.put_vector(mine.colors);
  p.put_vector(mine.triangles);
  mine = TriMesh();
  std::vector<std::string> to(comm.size());
  to[0] = std::move(p.data);
  std::vector<std::string> from = comm.exchange(to);
  TriMesh whole;
  if (comm.rank() != 0) return whole;
  for (std::string& bytes : from) {
    Unpacker u(bytes);
    const auto edge_first = u.get<std::uint64_t>(), edges = u.get<std::uint64_t>(),
               centre_first = u.get<std::uint64_t>(), total = u.get<std::uint64_t>();
    const auto positions = u.get_vector<std::array<float, 3>>();
    const auto normals = u.get_vector<std::array<float, 3>>();
    const auto colors = u.get_vector<std::array<float, 3>>();
    const auto triangles = u.get_vector<std::array<std::uint32_t, 3>>();
    whole.positions.resize(total);
    whole.normals.resize(total);
    if (!colors.empty()) whole.colors.resize(total);
    for (std::size_t l = 0; l < positions.size(); ++l) {
      const std::size_t v = l < edges ? edge_first + l : centre_first + (l - edges);
      whole.positions[v] = positions[l];
      whole.normals[v] = normals[l];
      if (!colors.empty()) whole.colors[v] = colors[l];
    }
    whole.triangles.insert(whole.triangles.end(), triangles.begin(), triangles.end());
    std::string().swap(bytes);
  }
  return whole;
}

}  // namespace

DistributedRun run_pipeline_distributed(const Params& params, const PipelineOptions& opts,
                                        Comm& comm) {
  const auto started = std::chrono::steady_clock::now();
  if (opts.keep_grid)
    throw InvalidInput(
        "--vdb is not available across ranks (the grid is not gathered); run "
        "qjulia mesh on one machine for the grid");
  const Solid solid(params);  // every rank validates alike
  DistributedRun run;
  RunStats& stats = run.result.stats;
  StageTimer timer(stats, opts.progress, opts.cancel);
  const bool gather =
      opts.outputs.size() != 1 || !stays_distributed(params, opts.outputs.front(), opts.preview);
  // The estimate on rank 0, for the largest rank (rank 0 when the mesh is gathered); the
  // verdict is every rank's.
  timer.start("estimate");
  detail::on_rank_zero(comm, [&] {
    RunPlan plan = run_plan(opts);
    plan.ranks = comm.size();
    plan.gathered = gather;
    estimate_and_check(solid, plan, opts, stats, " (rank 0)");
  });
  timer.stop();
  // Whether the ranks hand back the memory they free, and the limit their passes keep to: rank
  // 0's verdict from the estimate of the largest rank, the same on every rank.
  bool give_back = true;
  std::uint64_t memory_limit = 0;
  {
    Packer p;
    if (comm.rank() == 0) {
      p.put<std::uint8_t>(return_free_memory(stats));
      p.put<std::uint64_t>(stats.memory_limit);
    }
    comm.broadcast(p.data);
    Unpacker u(p.data);
    give_back = u.get<std::uint8_t>() != 0;
    memory_limit = u.get<std::uint64_t>();
  }

  detail::Distribution dist;
  dist.comm = &comm;
  const double wait_before = comm.wait_seconds;
  SampleOptions sopts;
  sopts.dense = opts.dense;
  sopts.cancel = opts.cancel;
  sopts.distribution = &dist;
  sopts.return_free_memory = give_back;
  sopts.progress = timer.start("sample");
  SampledGrid grid = sample(solid, sopts);
  timer.stop();
  RunStats::Rank me;
  me.bricks = grid.impl().bricks.size();
  me.evaluations = grid.evaluations();
  record_grid(grid, &comm, stats);

  ExtractOptions eopts = extract_options(params, opts, timer);
  eopts.return_free_memory = give_back;
  eopts.memory_limit = memory_limit;
  ExtractStats estats;
  auto part = std::make_unique<detail::MeshPart>();
  TriMesh mesh = detail::extract_part(std::move(grid), eopts, estats, *part);
  timer.stop();
  me.evaluations += estats.evaluations;
  stats.refine_evaluations = comm.sum(estats.evaluations);
  stats.unembedded_cells = estats.unembedded_cells;

  // Dust, across the ranks (the measures are rank 0's); a mesh whose bricks did not check out
  // is gathered and cleaned by clean() on rank 0.
  std::optional<MeshMeasure> known;
  timer.start("clean");
  const bool valid = estats.measure_valid;
  if (valid) {
    const double voxel = stats.voxel_size;
    const double threshold = params.mesh.min_component ? *params.mesh.min_component
                                                       : kDefaultDustVoxels * voxel * voxel * voxel;
    stats.clean = detail::remove_dust_part(mesh, estats, threshold, *part);
    if (comm.rank() == 0) known = std::move(estats.measure);
  }
  timer.stop();

  // Every rank's figures, on rank 0.
  me.bytes_sent = comm.bytes_sent;
  me.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  me.busy_seconds = me.seconds - (comm.wait_seconds - wait_before);
  {
    const std::vector<std::string> all =
        comm.allgather(std::string(reinterpret_cast<const char*>(&me), sizeof me));
    for (const std::string& f : all) {
      RunStats::Rank r;
      std::memcpy(&r, f.data(), sizeof r);
      stats.ranks.push_back(r);
    }
  }

  if (!gather && valid) {
    if (comm.rank() == 0) stats.measure = std::move(*known);
    run.part_mesh_ = std::move(mesh);
    run.part_ = std::move(part);
    stats.peak_rss_bytes = peak_rss_bytes();
    return run;
  }
  // The stages that need the whole mesh, on rank 0.
  timer.start("gather");
  TriMesh whole = gather_mesh(mesh, *part, comm);
  timer.stop();
  stats.gathered = true;
  if (comm.rank() == 0) {
    if (!valid) {
      CleanOptions copts;
      copts.min_component_volume = params.mesh.min_component;
      copts.voxel_size = stats.voxel_size;
      copts.cancel = opts.cancel;
      copts.progress = timer.start("clean");
      CleanReport creport;
      whole = clean(whole, copts, &creport);
      stats.clean = creport;
      timer.stop();
    }
    finish_mesh(params, opts, whole, known, stats, timer);
    run.result.mesh = std::move(whole);
  }
  stats.peak_rss_bytes = peak_rss_bytes();
  return run;
}

void write_distributed(const std::string& path, const DistributedRun& run,
                       const ExportOptions& opts, Comm& comm) {
  if (!run.gathered()) {
    detail::write_mesh_part(path, run.part_mesh_, *run.part_, opts);
    return;
  }
  detail::on_rank_zero(comm, [&] { write_mesh(path, run.result.mesh, opts); });
}

std::string stats_to_json(const RunStats& s, const Params& params) {
  using nlohmann::json;
  json j;
  j["qjulia_version"] = version();
  j["evaluations"] = s.evaluations;
  j["refine_evaluations"] = s.refine_evaluations;
  j["total_evaluations"] = s.evaluations + s.refine_evaluations;
  j["dense_evaluations"] = s.dense_evaluations;
  j["evaluation_ratio"] =
      s.dense_evaluations ? static_cast<double>(s.evaluations) / s.dense_evaluations : 0.0;
  j["crossing_cells"] = s.crossing_cells;
  j["unembedded_cells"] = s.unembedded_cells;
  j["voxel_size"] = s.voxel_size;
  j["grid_points"] = s.grid_points;
  const MeshMeasure& m = s.measure;
  j.update(detail::measure_to_json(m));
  j["unit"] = s.unit.empty() ? "model" : s.unit;
  j["scale"] = s.scale;
  json timings = json::object();
  double total = 0;
  for (const auto& [stage, seconds] : s.timings) {
    timings[stage] = seconds;
    total += seconds;
  }
  timings["total"] = total;
  j["timings"] = timings;
  j["peak_rss_bytes"] = s.peak_rss_bytes;
  const RunEstimate& e = s.estimate;
  j["estimate"] = {{"peak_bytes", e.peak_bytes},
                   {"faces", e.faces},
                   {"vertices", e.vertices},
                   {"crossing_cells", e.cells},
                   {"exponent", e.exponent},
                   {"brick_exponent", e.brick_exponent},
                   {"probe_resolution", e.probe_resolution},
                   {"largest_output_bytes", e.largest_output},
                   {"memory_limit_bytes", s.memory_limit},
                   {"memory_limit", s.memory_limit_source}};
  if (e.thickened_faces) j["estimate"]["thickened_faces"] = e.thickened_faces;
  if (s.clean) {
    const CleanReport& c = *s.clean;
    j["clean"] = {{"components_before", c.components_before},
                  {"components_after", c.components_after},
                  {"removed_components", c.removed_components},
                  {"removed_faces", c.removed_faces},
                  {"merged_vertices", c.merged_vertices},
                  {"degenerate_faces_removed", c.degenerate_faces_removed},
                  {"degenerate_faces_flipped", c.degenerate_faces_flipped},
                  {"min_component_volume", c.min_component_volume}};
  }
  if (s.decimate) {
    const DecimateReport& d = *s.decimate;
    j["decimate"] = {{"faces_before", d.faces_before},
                     {"faces_after", d.faces_after},
                     {"hausdorff", d.hausdorff},
                     {"target_reached", d.target_reached},
                     {"closed", d.closed},
                     {"manifold", d.manifold}};
    if (d.self_intersections) j["decimate"]["self_intersections"] = *d.self_intersections;
  }
  if (s.self_intersections) j["self_intersections"] = *s.self_intersections;
  if (!s.ranks.empty()) {
    json ranks = json::array();
    double busy_max = 0, busy_sum = 0;
    for (std::size_t r = 0; r < s.ranks.size(); ++r) {
      const RunStats::Rank& k = s.ranks[r];
      ranks.push_back({{"rank", r},
                       {"bricks", k.bricks},
                       {"evaluations", k.evaluations},
                       {"seconds", k.seconds},
                       {"busy_seconds", k.busy_seconds},
                       {"bytes_sent", k.bytes_sent}});
      busy_max = std::max(busy_max, k.busy_seconds);
      busy_sum += k.busy_seconds;
    }
    j["ranks"] = ranks;
    // The slowest rank's work against the mean: 1 when balanced.
    j["load_imbalance"] = busy_sum > 0 ? busy_max * s.ranks.size() / busy_sum : 1.0;
    j["gathered"] = s.gathered;
  }
  if (params.print.size_mm || params.print.min_thickness_mm || params.print.check) {
    json pr;
    pr["closed"] = m.closed;
    pr["manifold"] = m.manifold;
    pr["components"] = m.components.size();
    if (s.self_intersections) pr["self_intersections"] = *s.self_intersections;
    const bool mm = s.unit == "mm";
    pr["volume_cm3"] = mm ? json(m.volume / 1000.0) : json(nullptr);
    pr["bbox_mm"] = mm ? json::array({m.bbox_max[0] - m.bbox_min[0], m.bbox_max[1] - m.bbox_min[1],
                                      m.bbox_max[2] - m.bbox_min[2]})
                       : json(nullptr);
    j["printability"] = pr;
  }
  j["parameters"] = json::parse(params_to_json(params, false));
  return j.dump(2) + "\n";
}

}  // namespace qjulia
