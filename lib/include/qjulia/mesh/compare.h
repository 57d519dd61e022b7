#pragma once
/// @file compare.h
/// Comparing two surfaces: measures of each and the two-sided Hausdorff distance.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia {

/// Distances from the samples of one surface to the other.
struct DirectedDistance {
  double max = 0, mean = 0, rms = 0;
  std::size_t samples = 0;
};

/// The most surface samples compare() takes per surface (made and measured in batches: they are
/// never all in memory).
inline constexpr std::size_t kMostCompareSamples = 100000000;

/// Options of compare().
struct CompareOptions {
  /// Surface samples per unit area is chosen so each surface gets about this many samples
  /// (vertices are always included: every vertex, then area-proportional random points up to
  /// this many in all), at most kMostCompareSamples.
  std::size_t samples = 1000000;
  /// Seed of the random surface samples: the same meshes and seed give the same result.
  std::uint64_t seed = 20260101;
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// The result of compare().
struct CompareResult {
  /// The measures of each surface with its vertices at one position merged (files that split
  /// vertices at seams, as glTF and PLY exporters do, would show every seam as an open edge).
  MeshMeasure a, b;
  std::size_t a_welded = 0, b_welded = 0;  ///< vertices merged into another for the measures
  DirectedDistance a_to_b, b_to_a;
  double hausdorff = 0;                  ///< max(a_to_b.max, b_to_a.max)
  std::vector<float> a_vertex_distance;  ///< per vertex of a, distance to b
};

/// Compares two meshes: measures both (measure(), vertices at the same position merged) and
/// estimates the distances from every vertex
/// and area-proportional random points of each surface (opts.samples in all) to the other (exact
/// point-to-triangle distances through a BVH; multi-threaded; deterministic for a given seed).
/// @throws InvalidInput when either has no faces, an index out of range or a non-finite
///         position, or opts.samples exceeds kMostCompareSamples; Cancelled when opts.progress
///         returns false.
CompareResult compare(const TriMesh& a, const TriMesh& b, const CompareOptions& opts = {});

/// A colour ramp for per-vertex values (blue - cyan - green - yellow - red from `lo` to `hi`;
/// values outside are clamped), as linear RGB in [0, 1] for TriMesh::colors.
std::vector<std::array<float, 3>> distance_colors(const std::vector<float>& values, double lo,
                                                  double hi);

/// The metadata of a mesh coloured by distance_colors(), for ExportOptions::params_json:
/// {"compare": {"legend_min": lo, "legend_max": hi, "a": name_a, "b": name_b}}.
std::string compare_legend_json(double lo, double hi, const std::string& name_a,
                                const std::string& name_b);

/// The genus of the closed components in one line, e.g. "genus 0 x3, 2 x1; 1 open"
/// ("none" without components). With max_groups > 0, at most that many genus values are listed
/// (the most frequent first, then "+K more").
std::string genus_summary(const MeshMeasure& m, std::size_t max_groups = 0);

/// The result as JSON: {"a": {measures}, "b": {...}, "a_to_b": {max, mean, rms, samples},
/// "b_to_a": {...}, "hausdorff": ..}, with `name_a` / `name_b` recorded as "a_name", "b_name".
std::string compare_to_json(const CompareResult& result, const std::string& name_a = "a",
                            const std::string& name_b = "b");

}  // namespace qjulia
