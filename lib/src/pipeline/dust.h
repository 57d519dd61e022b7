#pragma once
// Dust removal on the extracted mesh, from the components the bricks measured.
#include "qjulia/base/mesh.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/surface/extract.h"
#include "surface/part.h"

namespace qjulia::detail {

/// Removes the components of |volume| < min_volume (and their vertices) from `mesh`, and
/// updates stats.measure, face_component and component_bbox to describe what is left, without
/// measuring the mesh again. Requires stats.measure_valid.
CleanReport remove_dust(TriMesh& mesh, ExtractStats& stats, double min_volume);

/// The same on a rank's part of a distributed mesh (extract_part()): rank 0 decides from the
/// whole mesh's components, every rank removes its faces, and the ranks agree on the vertices
/// they share and on the new numbering, which is one process's. Updates `part`; the measures
/// on rank 0 (the report is complete there); face_component is cleared. Collective.
CleanReport remove_dust_part(TriMesh& mesh, ExtractStats& stats, double min_volume, MeshPart& part);

}  // namespace qjulia::detail
