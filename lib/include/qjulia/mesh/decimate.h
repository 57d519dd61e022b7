#pragma once
/// @file decimate.h
/// Decimation to a face budget and/or an error bound, keeping the mesh closed and manifold.
#include <cstddef>
#include <optional>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia {

/// How decimate() simplifies. Both keep a closed manifold mesh closed and manifold, use input
/// vertices only and report the same measured Hausdorff distance.
enum class DecimateMethod {
  /// qjulia's edge collapses by quadric error, in parallel chunks: each keeps the topology (the
  /// link condition) and turns no face over, so the result keeps the input's components and
  /// Euler characteristic; about 1M input faces per second on two cores. With a face budget and
  /// no max_error, no collapse moves the surface by more than 1% of the bounding box's diagonal
  /// (quadric error, per pass): below what the surface can hold, the result stops above the
  /// budget. The default.
  kFast,
  /// OpenMesh's Decimater (ModQuadric order, ModNormalFlipping at 45 degrees, ModHausdorff with
  /// max_error): keeps the genus and gives a lower error at the same face count on fractal
  /// meshes; single-threaded, 4-20x the CPU time.
  kQuality,
};

/// Options of decimate(). At least one of faces / max_error is set.
struct DecimateOptions {
  std::optional<long long> faces;   ///< at most this many faces
  std::optional<double> max_error;  ///< Hausdorff bound to the input, model units
  DecimateMethod method = DecimateMethod::kFast;
  /// Check the result for self-intersections (CGAL, ~1.5 s per 150k output faces) and redo the
  /// decimation keeping the faces around intersecting ones (up to three rounds).
  bool avoid_self_intersections = false;
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// What decimate() did.
struct DecimateReport {
  std::size_t faces_before = 0;
  std::size_t faces_after = 0;
  double hausdorff = 0.0;  ///< two-sided distance between input and output, model units
  /// false when the budget could not be met within the bound (the fast method's shape bound
  /// without max_error) keeping the components and the Euler characteristic
  bool target_reached = true;
  bool closed = true;    ///< the result has no boundary or non-manifold edge (as a closed input)
  bool manifold = true;  ///< the result has no non-manifold edge or vertex and is oriented
  /// Intersecting face pairs left (set when avoid_self_intersections was asked).
  std::optional<std::size_t> self_intersections;
};

/// Decimates `mesh`. @throws InvalidInput when neither bound is set or a bound is not positive.
TriMesh decimate(const TriMesh& mesh, const DecimateOptions& opts,
                 DecimateReport* report = nullptr);

}  // namespace qjulia
