#pragma once
/// @file hausdorff.h
/// Sample-based distances between triangle meshes (own spatial hash; multi-threaded).
#include <cstddef>

#include "qjulia/base/mesh.h"

namespace qjulia::detail {

/// Sampling budget of hausdorff_distance().
struct HausdorffOptions {
  std::size_t max_samples = 500'000;  ///< per direction; vertices are strided beyond this
};

/// One-sided distances, model units.
struct HausdorffResult {
  double a_to_b = 0;  ///< max over samples of A of the distance to B
  double b_to_a = 0;
  double distance() const { return a_to_b > b_to_a ? a_to_b : b_to_a; }
};

/// Two-sided Hausdorff distance estimated by sampling: each side's vertices when it is at least
/// as fine as the other, else points on its faces spaced like the other side's edges. Distances
/// to a mesh of < 1.5M faces are exact (spatial hash of faces); to a larger one they are taken to
/// the faces around the nearest vertex (an upper bound, exact on well-shaped meshes).
/// Unreferenced vertices are ignored.
HausdorffResult hausdorff_distance(const TriMesh& a, const TriMesh& b,
                                   const HausdorffOptions& opts = {});

}  // namespace qjulia::detail
