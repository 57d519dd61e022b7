#pragma once
/// @file print.h
/// Making a mesh printable: scaling to a size in millimetres and thickening thin parts.
#include <array>
#include <cstddef>
#include <optional>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia {

/// The longest side of the bounding box of the vertices the faces of `mesh` use (0 without
/// faces), in the mesh's units.
double longest_side(const TriMesh& mesh);

/// Scales `mesh` uniformly about the origin so its longest bounding-box side is `length`.
/// @throws InvalidInput when length <= 0, validate_mesh() refuses the mesh, or it is empty or
///         flat.
/// @return the scale factor applied.
double scale_to_longest_side(TriMesh& mesh, double length);

/// Options of thicken().
struct ThickenOptions {
  double min_thickness = 0.0;  ///< thicken parts thinner than this, in the mesh's units
  double voxel_size = 0.0;     ///< resolution of the level set used; 0 = min_thickness / 4
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// Thickens the parts of a closed mesh thinner than opts.min_thickness (OpenVDB level-set
/// morphology), leaving thicker parts as they are. Returns a closed, manifold, outward mesh.
/// The result is the zero level of  S u dilate(S \ dilate(open(S, r), 1.5 voxels), r)  with
/// r = min_thickness / 2: a wall of thickness t < min_thickness becomes t + min_thickness thick;
/// thicker parts are re-meshed on the level-set grid (within about a voxel of the input).
/// Components (enclosed voids included) of |volume| < r^3 are removed from the result.
/// @throws InvalidInput when min_thickness <= 0, voxel_size < 0 or the grid would exceed
/// ~2^31 voxels per axis.
TriMesh thicken(const TriMesh& mesh, const ThickenOptions& opts);

/// Options of printability().
struct PrintabilityOptions {
  bool check_self_intersections = false;  ///< run count_self_intersections (CGAL; ~1 s/1M faces)
  bool millimetres = true;                ///< the mesh is in mm: fill volume_cm3
  /// Checked between the steps; when requested, printability() throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// Whether a mesh can be printed as it is.
struct PrintabilityReport {
  bool closed = false;    ///< no boundary and no non-manifold edge
  bool manifold = false;  ///< no non-manifold edge or vertex
  bool oriented = false;  ///< neighbouring faces agree on orientation
  bool outward = false;   ///< total signed volume > 0
  std::size_t boundary_edges = 0;
  std::size_t nonmanifold_edges = 0;
  std::size_t nonmanifold_vertices = 0;
  std::optional<std::size_t> self_intersections;  ///< set when checked
  std::size_t components = 0;                     ///< vertex-connected
  double volume = 0;                              ///< signed, model units^3
  std::optional<double> volume_cm3;               ///< volume / 1000 when millimetres
  double area = 0;                                ///< model units^2
  std::array<double, 3> bbox_min{0, 0, 0};        ///< model units (mm when millimetres)
  std::array<double, 3> bbox_max{0, 0, 0};
  std::array<double, 3> size{0, 0, 0};  ///< bbox_max - bbox_min
  /// closed, manifold, oriented, outward and (when checked) free of self-intersections.
  bool printable() const {
    return closed && manifold && oriented && outward &&
           (!self_intersections || *self_intersections == 0);
  }
};

/// Measures what a slicer cares about (from measure(); a face with a repeated index makes the
/// mesh not closed). O(F log F), plus the self-intersection test if asked.
/// @throws Cancelled when opts.cancel is requested.
PrintabilityReport printability(const TriMesh& mesh, const PrintabilityOptions& opts = {});

}  // namespace qjulia
