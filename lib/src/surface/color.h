#pragma once
// Per-vertex colours from the orbits of points just off the surface.
#include <cstdint>

#include "qjulia/base/mesh.h"
#include "qjulia/field/classify.h"

namespace qjulia::detail {

/// Sets mesh.colors by `mode` (iterations or basin) from the orbit of a point one voxel off the
/// surface along the vertex normal (mesh.normals must be set). Returns the orbits computed.
std::uint64_t colorize(TriMesh& mesh, const Solid& solid, double voxel, ColorMode mode);

}  // namespace qjulia::detail
