#pragma once
// Moving vertices onto the exact boundary: root finding along segments, many at once, through
// the batched classifier.
#include <array>
#include <cstddef>
#include <cstdint>

#include "qjulia/field/classify.h"

namespace qjulia::detail {

/// A segment with one end in the solid (value <= 0) and one outside.
struct Segment {
  std::array<double, 3> a, b;  ///< ends, model units
  float fa = 0, fb = 0;        ///< the solid's field at the ends
};

/// Vertices keep this fraction of a segment away from its ends.
constexpr double kEndMargin = 1e-3;

/// Moves one point onto the boundary of the solid per segment: where the outside end is outside
/// only because of the box or a clip plane and the plane's point is in the solid, onto the plane
/// (caps are exactly flat); else by false position with bisection safeguards against the exact
/// classifier, until the bracket is shorter than tol_t (a fraction of the segment) or after
/// max_steps evaluations. All segments advance together, one batched evaluation per step.
/// Results are never closer than kEndMargin to an end.
/// @return the classifier evaluations made
std::uint64_t refine_segments(const Solid& solid, const Segment* segments, std::size_t n,
                              double tol_t, int max_steps, std::array<double, 3>* out);

/// The boundary point nearest c strictly inside the cell [lo, lo + voxel]^3 (a thousandth of a
/// voxel from its walls), along the normal and the 13 directions to a cube's neighbours; c
/// itself when none of those lines crosses the boundary inside the cell.
std::array<double, 3> boundary_in_cell(const Solid& solid, const std::array<double, 3>& c,
                                       const std::array<double, 3>& normal,
                                       const std::array<double, 3>& lo, double voxel, double tol_t,
                                       std::uint64_t* evaluations);

}  // namespace qjulia::detail
