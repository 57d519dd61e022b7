#pragma once
// Writing the mesh of a distributed run without gathering it: every rank writes its own byte
// ranges of one binary PLY or STL file.
#include <string>

#include "qjulia/base/mesh.h"
#include "qjulia/io/mesh_io.h"
#include "surface/part.h"

namespace qjulia::detail {

/// Whether write_mesh_part() writes `format` (binary PLY and STL; the others are gathered).
inline bool part_writable(MeshFormat format) {
  return format == MeshFormat::kPly || format == MeshFormat::kStl;
}

/// Writes the whole mesh, of which this rank holds `part` (its vertices in `mesh`), to `path`:
/// the bytes write_mesh() writes for the whole mesh, each rank writing its vertex and face
/// records at their offsets in the file the Comm opens. The file is a temporary one beside
/// `path` (AtomicFile on rank 0), renamed by rank 0 once every rank wrote its part; on any
/// rank's failure no file is left and every rank throws the same error. Collective.
void write_mesh_part(const std::string& path, const TriMesh& mesh, const MeshPart& part,
                     const ExportOptions& opts);

}  // namespace qjulia::detail
