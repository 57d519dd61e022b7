#pragma once
/// @file sample.h
/// Sampling the continuous field into a sparse grid (an openvdb::FloatGrid inside).
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"

namespace qjulia {

namespace detail {
struct Distribution;
}

/// Options of sample().
struct SampleOptions {
  /// Evaluate every grid point instead of refining coarse blocks (the validation path).
  bool dense = false;
  /// Progress in [0, 1]; return false to cancel.
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
  /// Hand the memory freed between passes back to the system (malloc_trim): lowers the peak of a
  /// large run, costs time on a small one (run_pipeline decides from its estimate).
  bool return_free_memory = true;
  /// Internal: the ranks of a distributed run (qjulia-mpi); null for one process. The sampler
  /// deals the bricks to the ranks (sets its `first`) and keeps only this rank's.
  detail::Distribution* distribution = nullptr;
};

class Solid;

/// The sampled field on the points of grid_geometry(params), in bricks of 8^3 cells (VDB
/// leaves): the evaluated points hold F, and the cells the surface crosses are known. It keeps
/// the parameters and the solid it was sampled from.
class SampledGrid {
 public:
  SampledGrid();
  ~SampledGrid();
  SampledGrid(SampledGrid&&) noexcept;
  SampledGrid& operator=(SampledGrid&&) noexcept;

  double voxel_size() const;                ///< model units
  std::array<double, 3> origin() const;     ///< position of point (0, 0, 0)
  std::array<int, 3> points() const;        ///< grid points per axis
  std::uint64_t evaluations() const;        ///< classifier calls made by sample()
  std::uint64_t dense_evaluations() const;  ///< points a dense grid has
  std::uint64_t crossing_cells() const;     ///< cells whose corners differ in sign
  std::uint64_t active_voxels() const;      ///< evaluated points stored in the grid
  std::size_t bricks() const;               ///< bricks holding evaluated points
  const Params& params() const;             ///< the parameters it was sampled from
  const Solid& solid() const;               ///< their solid (classifier, box and clips)

  /// Writes the grid as a .vdb file (a FloatGrid named "F", with the parameters and the
  /// field's meaning as metadata): the evaluated points as active voxels, uniform interior
  /// blocks as inactive tiles of -(N + 1), the background N + 1. Written through AtomicFile.
  /// @throws std::runtime_error when the file cannot be written.
  void write_vdb(const std::string& path, const std::string& params_json) const;

  struct Impl;  ///< internal (lib/src/grid/grid_impl.h)
  Impl& impl() { return *impl_; }
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Samples the solid of `params` (box and clip planes included).
/// @throws InvalidInput when params do not validate; Cancelled when progress returns false or
///         opts.cancel is requested.
SampledGrid sample(const Params& params, const SampleOptions& opts = {});

/// Samples `solid` (built, and so validated, once by the caller).
/// @throws Cancelled as sample(params).
SampledGrid sample(const Solid& solid, const SampleOptions& opts = {});

}  // namespace qjulia
