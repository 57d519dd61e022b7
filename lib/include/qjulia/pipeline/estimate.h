#pragma once
/// @file estimate.h
/// What a run will need before it starts: the size of its mesh and its peak memory, from two
/// quick samplings at lower resolutions, and whether the output formats can hold the mesh.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/base/memory.h"
#include "qjulia/base/progress.h"
#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia {

/// What the run does besides sampling, extracting and cleaning (which every run does).
struct RunPlan {
  std::vector<MeshFormat> outputs;  ///< the formats the mesh is written in
  bool dense = false;               ///< every grid point evaluated
  bool keep_grid = false;           ///< the grid kept and written (--vdb)
  bool preview = false;             ///< a picture rendered
  int ranks = 1;                    ///< processes of a distributed run
  bool gathered = false;            ///< ... whose mesh is gathered to rank 0
  /// The memory the run may use, when known (0: not known). From 2048 on, a run whose first
  /// probes already estimate more than twice this is estimated from them alone (it is refused
  /// either way), without the larger probe.
  std::size_t limit = 0;
  const CancelToken* cancel = nullptr;
};

/// The estimate of a run.
struct RunEstimate {
  int resolution = 0;                 ///< of the run
  int probe_resolution = 0;           ///< the finer of the two samplings it extrapolates from
  std::uint64_t probe_cells = 0;      ///< crossing cells found there
  std::uint64_t probe_bricks = 0;     ///< and bricks
  double exponent = 2;                ///< crossing cells grow as resolution^exponent
  double brick_exponent = 2;          ///< the sampled bricks as resolution^brick_exponent
  double surface_extent = 0;          ///< longest side of the probe's surface box, model units
  std::uint64_t cells = 0;            ///< crossing cells expected at `resolution`
  std::uint64_t faces = 0;            ///< faces of the extracted mesh
  std::uint64_t vertices = 0;         ///< and vertices
  std::uint64_t thickened_faces = 0;  ///< faces after --min-thickness (0: no thickening)
  std::uint64_t final_faces = 0;      ///< faces written (after thickening and decimation)
  std::size_t peak_bytes = 0;         ///< peak resident memory of the run (of its largest rank)
  std::size_t largest_output = 0;     ///< bytes of the largest output file
};

/// Samples `params` at two lower resolutions (at most 1/4 of the run's and 256, or 512 from 2048
/// on unless plan.limit says the run is refused either way; sampling only) and extrapolates the
/// crossing cells and the bricks by the power laws between them; the memory model's
/// coefficients are measured on this machine's builds (docs/design.md, "Memory").
/// @throws InvalidInput for invalid params; Cancelled.
RunEstimate estimate_run(const Params& params, const RunPlan& plan);
/// The same for the solid of a run, whose compiled formula the probes reuse.
RunEstimate estimate_run(const Solid& solid, const RunPlan& plan);

/// The peak memory of the same run at another resolution, by the same extrapolation.
RunEstimate estimate_at(const Params& params, const RunPlan& plan, const RunEstimate& base,
                        int resolution);

/// The largest resolution whose estimated peak fits in `bytes` and whose mesh every output
/// format of `plan` can hold (0 when none does).
int largest_fitting_resolution(const Params& params, const RunPlan& plan, const RunEstimate& base,
                               std::size_t bytes);

/// Refuses the run before it starts: TooLarge when the estimated peak exceeds the effective
/// limit (the message gives the estimate, the limit and the largest resolution that fits, in
/// memory and in the output formats); TooLarge too when an output format cannot hold the mesh
/// (GLB's 4 GiB, 32-bit indices), naming a format that can.
void check_run(const Params& params, const RunPlan& plan, const RunEstimate& estimate,
               const MemoryLimits& limits);

}  // namespace qjulia
