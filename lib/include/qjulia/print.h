#pragma once
/// @file print.h
/// Making a mesh printable: scaling to a size in millimetres and thickening thin parts.
#include <cstddef>

#include "qjulia/mesh.h"
#include "qjulia/progress.h"

namespace qjulia {

/// Scales `mesh` uniformly about the origin so its longest bounding-box side is `length`.
/// @throws InvalidInput when length <= 0 or the mesh is empty or flat.
/// @return the scale factor applied.
double scale_to_longest_side(TriMesh& mesh, double length);

/// Options of thicken().
struct ThickenOptions {
  double min_thickness = 0.0;  ///< thicken parts thinner than this, in the mesh's units
  double voxel_size = 0.0;     ///< resolution of the level set used; 0 = min_thickness / 4
  ProgressFn progress;
};

/// Thickens the parts of a closed mesh thinner than opts.min_thickness (OpenVDB level-set
/// morphology), leaving thicker parts as they are. Returns a closed, manifold, outward mesh.
/// @throws InvalidInput when min_thickness <= 0.
TriMesh thicken(const TriMesh& mesh, const ThickenOptions& opts);

}  // namespace qjulia
