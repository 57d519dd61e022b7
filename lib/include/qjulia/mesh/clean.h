#pragma once
/// @file clean.h
/// Cleaning: merge duplicate vertices, drop degenerate faces and dust components, keep the mesh
/// closed, manifold and outward.
#include <cstddef>
#include <optional>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia {

/// The default dust threshold in voxels^3 (when CleanOptions::voxel_size is set and
/// min_component_volume is not): components smaller than two voxels are specks supported by
/// one or two grid samples, i.e. below the sampling resolution.
constexpr double kDefaultDustVoxels = 2.0;

/// Options of clean().
struct CleanOptions {
  /// Remove components whose |volume| is below this (model units^3). Unset: a default that
  /// removes sub-voxel specks, computed from `voxel_size`.
  std::optional<double> min_component_volume;
  /// The sampling voxel size (model units), for the default threshold; 0 = no default removal.
  double voxel_size = 0.0;
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// What clean() did.
struct CleanReport {
  std::size_t components_before = 0;
  std::size_t components_after = 0;
  std::size_t removed_components = 0;
  std::size_t removed_faces = 0;
  std::size_t merged_vertices = 0;
  std::size_t degenerate_faces_removed = 0;  ///< repeated-index faces, fins, collapsed needles
  std::size_t degenerate_faces_flipped = 0;  ///< zero-area caps fixed by an edge flip
  double min_component_volume = 0.0;         ///< the threshold used
  double largest_removed_volume = 0.0;       ///< |volume| of the largest component removed
};

/// Cleans `mesh`. Closed, manifold, outward input stays so.
TriMesh clean(const TriMesh& mesh, const CleanOptions& opts = {}, CleanReport* report = nullptr);

/// Counts pairs of faces that intersect other than in their shared vertices or edge
/// (CGAL::Polygon_mesh_processing::self_intersections, multi-threaded). Faces that a halfedge
/// mesh cannot hold (non-manifold) are skipped. Slow: ~5 CPU-seconds for 1.3M faces.
/// @throws InvalidInput when validate_mesh() refuses the mesh.
std::size_t count_self_intersections(const TriMesh& mesh);

}  // namespace qjulia
