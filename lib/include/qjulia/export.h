#pragma once
/// @file export.h
/// Writing and reading meshes: glTF 2.0 (.glb, .gltf + .bin), OBJ, PLY, STL, 3MF.
#include <string>

#include "qjulia/mesh.h"
#include "qjulia/progress.h"

namespace qjulia {

/// The file formats, chosen by extension.
enum class MeshFormat { kGlb, kGltf, kObj, kPly, kStl, k3mf };

/// The format of `path` by its extension (case-insensitive).
/// @throws InvalidInput naming the extension and the accepted ones.
MeshFormat format_from_path(const std::string& path);

/// Options of write_mesh().
struct ExportOptions {
  /// The complete parameter file (JSON) the mesh was made from; recorded in the file (glTF
  /// asset.extras, PLY/OBJ comments, 3MF metadata) so the mesh can be made again.
  std::string params_json;
  /// Units of the positions: "mm" for printing (3MF unit, STL header), "" for model units.
  std::string unit;
  ProgressFn progress;
};

/// Writes `mesh` to `path` in the format of its extension, through a temporary file that is
/// renamed at the end, so no half-written file is ever left.
/// @throws InvalidInput for an unknown extension; std::runtime_error when writing fails.
void write_mesh(const std::string& path, const TriMesh& mesh, const ExportOptions& opts = {});

/// Reads any format write_mesh() writes (positions, triangles, and normals/colours if present).
/// @throws InvalidInput with the file name and the reason when the file is unreadable or not a
///         valid mesh.
TriMesh read_mesh(const std::string& path);

}  // namespace qjulia
