#pragma once
/// @file compare.h
/// Comparing two surfaces: measures of each and the two-sided Hausdorff distance.
#include <cstddef>
#include <vector>

#include "qjulia/mesh.h"
#include "qjulia/progress.h"

namespace qjulia {

/// Distances from the samples of one surface to the other.
struct DirectedDistance {
  double max = 0, mean = 0, rms = 0;
  std::size_t samples = 0;
};

/// Options of compare().
struct CompareOptions {
  /// Surface samples per unit area is chosen so each surface gets about this many samples
  /// (vertices are always included).
  std::size_t samples = 1000000;
  ProgressFn progress;
};

/// The result of compare().
struct CompareResult {
  MeshMeasure a, b;
  DirectedDistance a_to_b, b_to_a;
  double hausdorff = 0;                  ///< max(a_to_b.max, b_to_a.max)
  std::vector<float> a_vertex_distance;  ///< per vertex of a, distance to b
};

/// Compares two meshes. @throws InvalidInput when either has no faces.
CompareResult compare(const TriMesh& a, const TriMesh& b, const CompareOptions& opts = {});

}  // namespace qjulia
