#pragma once
/// @file mesh_io.h
/// Writing and reading meshes: glTF 2.0 (.glb, .gltf + .bin), OBJ, PLY, STL, 3MF.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"

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
  /// Checked between the blocks written (4 MiB at most); when requested, write_mesh throws
  /// Cancelled and leaves no file.
  const CancelToken* cancel = nullptr;
};

/// Writes `mesh` to `path` in the format of its extension, through AtomicFile (a temporary
/// file renamed at the end), so no half-written file is ever left. Normals are written unit
/// length (computed area-weighted when `mesh.normals` is empty; zero or non-finite ones are
/// replaced); colours are clamped to [0, 1]. A `.gltf` also writes `.bin` beside it (same base
/// name). PLY and OBJ store colours sRGB-encoded (as viewers expect), glTF linear (as its spec
/// says).
/// @throws InvalidInput for an unknown extension, a mesh that validate_mesh() refuses (or that
///         has no triangles), `opts.params_json` that is not valid JSON, or a path that may not
///         be written (check_output_path: a directory, device or FIFO; a missing or read-only
///         directory); std::runtime_error when writing fails (disk full, ...); Cancelled when
///         `opts.progress` returns false or `opts.cancel` is set.
void write_mesh(const std::string& path, const TriMesh& mesh, const ExportOptions& opts = {});

/// What a reader did to the mesh of a file besides reading it.
struct ReadReport {
  /// Triangles with a repeated vertex index ("1 1 2"): dropped, they have no area and no
  /// orientation (zero-area triangles with three distinct indices are kept).
  std::size_t dropped_faces = 0;
  /// Vertices no triangle uses: kept, so vertex numbers stay those of the file.
  std::size_t unreferenced_vertices = 0;
};

/// Options of read_mesh() and read_mesh_from_memory().
struct ReadOptions {
  /// Bytes the reader may allocate, on top of the system's limits (memory_limits()); unset:
  /// the system's limits only.
  std::optional<std::size_t> max_memory;
  /// Names the mesh in messages when it is read from memory ("<memory>" when empty).
  std::string name;
  /// When set, receives what the reader dropped and kept (ReadReport).
  ReadReport* report = nullptr;
};

/// Reads any format write_mesh() writes (positions, triangles, and normals/colours if
/// present), checks it (validate_mesh) and drops triangles with a repeated index (ReadReport).
/// Every count a file announces is checked against the bytes that hold it before anything is
/// allocated. A .gltf reads only buffers that are data: URIs or regular files inside its own
/// folder (no absolute path, no "..", no link leading out, no device). A .3mf may decompress
/// to at most 100 times its size.
/// @throws InvalidInput "PATH: what is wrong" when the file is unreadable or not a valid mesh;
///         TooLarge (an InvalidInput) when the mesh would not fit the memory limits.
TriMesh read_mesh(const std::string& path, const ReadOptions& opts = {});

/// read_mesh() of a file's bytes held in memory, in `format`. A .gltf read this way may use
/// data: URIs only.
/// @throws as read_mesh(), naming `opts.name`.
TriMesh read_mesh_from_memory(std::string_view bytes, MeshFormat format,
                              const ReadOptions& opts = {});

/// The parameter file recorded in a mesh file by write_mesh() (glTF asset.extras, OBJ/PLY
/// comments, 3MF metadata), pretty-printed JSON; "" when the file records none (STL).
/// @throws InvalidInput like read_mesh().
std::string read_mesh_params(const std::string& path);

/// The parameters in `path`: those a mesh file records (read_mesh_params(); by its extension:
/// .glb .gltf .obj .ply .3mf), or a parameter file (any other name). A mesh made from them
/// again is the recorded one, at the recorded resolution unless overridden.
/// @throws InvalidInput naming `path` when it cannot be read, records no parameters (an STL
///         file: its sidecar `path`.json is the parameter file) or holds invalid ones.
Params read_params_from(const std::string& path);

/// The files write_mesh(path, ...) creates: `path`, and for .gltf also its .bin (same base
/// name), so a caller that must remove them again (a later step failed) removes both.
/// @throws InvalidInput for an unknown extension.
std::vector<std::string> output_files(const std::string& path);

/// The extension of a format, with the dot (".glb").
const char* extension_of(MeshFormat format);

}  // namespace qjulia
