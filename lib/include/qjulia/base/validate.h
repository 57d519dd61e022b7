#pragma once
/// @file validate.h
/// The one check of a mesh where it enters the library: every reader and every public function
/// that takes a TriMesh runs it, so the later stages can trust what they get.
#include <string>

#include "qjulia/base/mesh.h"

namespace qjulia {

/// What validate_mesh() requires beyond a well-formed mesh.
struct MeshRequirements {
  /// At least one triangle (compare, the writers); clean, decimate and render accept an empty
  /// mesh.
  bool faces = false;
};

/// Checks that `mesh` is well formed:
///  - every triangle index is below #V, and #V < 2^32 - 1 (indices are 32-bit);
///  - every position is finite;
///  - normals and colours number 0 or #V;
///  - with `req.faces`, the mesh has at least one triangle.
/// Allowed, because every stage copes with them (clean removes them): degenerate triangles
/// (a repeated index, zero area), unreferenced vertices, and normal or colour values that are
/// zero, non-finite or out of range (the writers and the renderer replace such normals and
/// clamp colours). The readers drop triangles with a repeated index themselves (ReadReport).
/// Runs in O(V + F), one pass over each array.
/// @param[in] mesh    the mesh to check
/// @param[in] source  names the mesh in the message: a file name, or the function ("clean")
/// @throws InvalidInput "SOURCE: what is wrong", naming the first bad triangle or vertex.
void validate_mesh(const TriMesh& mesh, const std::string& source,
                   const MeshRequirements& req = {});

}  // namespace qjulia
