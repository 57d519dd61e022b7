#pragma once
// Dust removal on the extracted mesh, from the components the bricks measured.
#include "qjulia/base/mesh.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/surface/extract.h"

namespace qjulia::detail {

/// Removes the components of |volume| < min_volume (and their vertices) from `mesh`, and
/// updates stats.measure, face_component and component_bbox to describe what is left, without
/// measuring the mesh again. Requires stats.measure_valid.
CleanReport remove_dust(TriMesh& mesh, ExtractStats& stats, double min_volume);

}  // namespace qjulia::detail
