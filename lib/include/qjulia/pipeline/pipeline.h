#pragma once
/// @file pipeline.h
/// The whole `qjulia mesh` job as one call: sample -> extract -> clean -> decimate -> print.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/base/memory.h"
#include "qjulia/base/mesh.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/decimate.h"
#include "qjulia/pipeline/estimate.h"

namespace qjulia {

/// Progress of a stage: its name ("sample", "extract", ...) and the fraction done. Return false
/// to cancel.
using StageProgressFn = std::function<bool(const std::string& stage, double fraction)>;

/// Options of run_pipeline().
struct PipelineOptions {
  bool dense = false;      ///< evaluate every grid point (validation path)
  bool keep_grid = false;  ///< keep the sampled grid in the result (for --vdb)
  StageProgressFn progress;
  /// Checked by every stage; when requested, run_pipeline() throws Cancelled.
  const CancelToken* cancel = nullptr;
  /// The memory the run may use, bytes; the smallest of it, MemAvailable, the cgroup limit and
  /// the address-space limit applies. A run whose estimated peak exceeds it throws TooLarge
  /// before it starts (estimate.h).
  std::optional<std::size_t> max_memory;
  /// The formats the mesh will be written in and whether a preview is rendered: for the
  /// estimate, and so that a mesh too large for its format is refused before the work.
  std::vector<MeshFormat> outputs;
  bool preview = false;
  /// False: the mesh may come without normals where making them is left to the writer (a PLY
  /// writer makes them while its faces go to the disk); they are then the same. A clean() of a
  /// mesh that the extraction could not measure still makes them first, and keeps them.
  bool normals = true;
};

/// Figures of one run, the content of --stats.
struct RunStats {
  /// Classifier calls that filled the grid (the sampling stage); compare with
  /// dense_evaluations, the calls a dense grid needs.
  std::uint64_t evaluations = 0;
  /// Classifier calls that moved vertices onto the boundary and coloured them (the same for a
  /// sparse and a dense grid).
  std::uint64_t refine_evaluations = 0;
  std::uint64_t dense_evaluations = 0;  ///< grid points of a dense grid
  std::uint64_t crossing_cells = 0;
  /// Cells whose triangles cross one another whatever triangulation was tried (0: the
  /// extracted surface is embedded, free of self-intersections).
  std::uint64_t unembedded_cells = 0;
  double voxel_size = 0;
  std::array<int, 3> grid_points{0, 0, 0};
  MeshMeasure measure;                                  ///< of the final mesh
  std::vector<std::pair<std::string, double>> timings;  ///< seconds per stage, in order
  std::size_t peak_rss_bytes = 0;
  std::optional<CleanReport> clean;
  std::optional<DecimateReport> decimate;
  std::optional<std::size_t> self_intersections;
  RunEstimate estimate;             ///< made before the run
  std::size_t memory_limit = 0;     ///< the effective limit it was checked against, bytes
  std::string memory_limit_source;  ///< MemoryLimits::describe()
  double scale = 1.0;               ///< factor applied by print.size_mm
  std::string unit;                 ///< "mm" when scaled for printing
  /// The longest side of the mesh's bounding box before print.min_thickness_mm thickened it,
  /// in the mesh's units (0 without thickening): a thickness above it thickens every part.
  double extent_before_thickening = 0;
  /// One rank of a distributed run (run_pipeline_distributed()).
  struct Rank {
    std::uint64_t bricks = 0;       ///< bricks it sampled
    std::uint64_t evaluations = 0;  ///< classifier calls, sampling and refinement
    std::uint64_t bytes_sent = 0;   ///< to other ranks
    double seconds = 0;             ///< from the start to the mesh's parts, wall clock
    double busy_seconds = 0;        ///< of which not waiting for other ranks
  };
  std::vector<Rank> ranks;  ///< by rank; empty in a run of one process
  bool gathered = false;    ///< a distributed run's mesh was gathered to rank 0
};

/// The result of run_pipeline().
struct PipelineResult {
  TriMesh mesh;
  RunStats stats;
  std::optional<SampledGrid> grid;  ///< when keep_grid
};

/// Runs every stage of `params`.
/// @throws InvalidInput for invalid params; TooLarge (an InvalidInput) for a run the estimate
/// refuses, or one that runs out of memory all the same (its message names the stage, the peak,
/// the estimate and the limit); Cancelled when progress returns false.
PipelineResult run_pipeline(const Params& params, const PipelineOptions& opts = {});

/// The --stats JSON of a run (docs/design.md's keys and more).
std::string stats_to_json(const RunStats& stats, const Params& params);

/// What to tell a user whose parameters give an empty solid (no grid point of the box, or of
/// its part the clip planes keep, is in the solid), without a hint.
std::string empty_solid_message(const Params& params);

/// True when the run's dust removal took every component of a surface it did extract.
bool removed_as_dust(const RunStats& stats);

/// What to tell a user whose run gave no faces: that every component was below the dust
/// threshold (with the largest one's volume and the threshold), or empty_solid_message().
std::string empty_mesh_message(const Params& params, const RunStats& stats);

/// The library version, "MAJOR.MINOR.PATCH".
const char* version();

}  // namespace qjulia
