#pragma once
/// @file export.h
/// Writing and reading meshes: glTF 2.0 (.glb, .gltf + .bin), OBJ, PLY, STL, 3MF.
#include <string>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

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
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// Writes `mesh` to `path` in the format of its extension, through a temporary file that is
/// renamed at the end, so no half-written file is ever left. Normals are written unit length
/// (computed area-weighted when `mesh.normals` is empty; zero or non-finite ones are replaced);
/// colours are clamped to [0, 1]. A `.gltf` also writes `.bin` beside it (same base name).
/// PLY and OBJ store colours sRGB-encoded (as viewers expect), glTF linear (as its spec says).
/// @throws InvalidInput for an unknown extension, an empty mesh, an index out of range,
///         normals/colours whose count is neither 0 nor #V, non-finite positions, or
///         `opts.params_json` that is not valid JSON; std::runtime_error when writing fails
///         (the directory does not exist, disk full, ...); Cancelled when `opts.progress`
///         returns false.
void write_mesh(const std::string& path, const TriMesh& mesh, const ExportOptions& opts = {});

/// Reads any format write_mesh() writes (positions, triangles, and normals/colours if present).
/// @throws InvalidInput with the file name and the reason when the file is unreadable or not a
///         valid mesh.
TriMesh read_mesh(const std::string& path);

/// The parameter file recorded in a mesh file by write_mesh() (glTF asset.extras, OBJ/PLY
/// comments, 3MF metadata), pretty-printed JSON; "" when the file records none (STL).
/// @throws InvalidInput like read_mesh().
std::string read_mesh_params(const std::string& path);

/// The files write_mesh(path, ...) creates: `path`, and for .gltf also its .bin (same base
/// name), so a caller that must remove them again (a later step failed) removes both.
/// @throws InvalidInput for an unknown extension.
std::vector<std::string> output_files(const std::string& path);

/// The extension of a format, with the dot (".glb").
const char* extension_of(MeshFormat format);

}  // namespace qjulia
