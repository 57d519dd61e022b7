#pragma once
// Whether two triangles of one cell cross: the test that keeps the extracted surface embedded
// (no self-intersections), as slicers and boolean tools need.
#include <array>

namespace qjulia::detail {

using Triangle = std::array<std::array<double, 3>, 3>;

/// True when the triangles meet other than in the corners or the edge they have in common, by
/// exact predicates on the coordinates as given (round them as the mesh stores them first): a
/// shared edge counts when the two lie in one plane on the same side of it (a fold), a shared
/// corner when the edge opposite it in either meets the other. The rules of CGAL's
/// self-intersection test, so a mesh built from pairs that pass it passes that test.
bool triangles_cross(const Triangle& a, const Triangle& b);

}  // namespace qjulia::detail
