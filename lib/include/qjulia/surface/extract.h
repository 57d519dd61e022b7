#pragma once
/// @file extract.h
/// Surface extraction: marching cubes over the sampled cells, vertices refined onto the exact
/// classification boundary, outward orientation.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"
#include "qjulia/grid/sample.h"

namespace qjulia {

/// Options of extract().
struct ExtractOptions {
  /// Stop refining a vertex when its bracket on the edge is shorter than this, in voxels.
  double tolerance = 0.02;
  /// At most this many classifier calls per vertex.
  int max_refine_steps = 24;
  /// Hand the memory freed between passes back to the system (malloc_trim) when the resident
  /// memory would otherwise pass twice the mesh (12 bytes a vertex and a face) + 150 MB, or
  /// memory_limit: lowers the peak of a large run, costs time (run_pipeline decides from its
  /// estimate).
  bool return_free_memory = true;
  /// The memory the run may use, bytes (0: not known): with return_free_memory, the passes keep
  /// within it too.
  std::size_t memory_limit = 0;
  /// Per-vertex colours (left empty for kNone).
  ColorMode color = ColorMode::kNone;
  /// Make the vertex normals. Without colours they may be left out, for the caller to make
  /// after removing faces: the mesh is measured per component (ExtractStats), so whole
  /// components can go first, and the normals then take memory the per-face data gave back.
  bool normals = true;
  /// Progress in [0, 1]; return false to cancel.
  ProgressFn progress;
  /// Checked throughout the work; when requested, the stage throws Cancelled.
  const CancelToken* cancel = nullptr;
};

/// What extract() did besides the mesh.
struct ExtractStats {
  std::uint64_t evaluations = 0;  ///< classifier calls for refinement and colours
  /// The measures of the mesh, from the bricks (no second pass over the mesh): valid when the
  /// bricks' half-edges all paired up (closed, manifold, oriented) and no face is degenerate;
  /// else use measure(mesh).
  MeshMeasure measure;
  bool measure_valid = false;
  /// Per face, its component (an index into measure.components).
  std::vector<std::uint32_t> face_component;
  /// Per component, its bounding box (min x, y, z, max x, y, z).
  std::vector<std::array<double, 6>> component_bbox;
  /// Cells whose triangles still cross one another after every triangulation the cell allows
  /// was tried (0 in an embedded mesh).
  std::size_t unembedded_cells = 0;
};

/// Extracts the closed, oriented, manifold surface of the sampled solid, brick by brick in
/// parallel; vertices are named by their global grid edge, so the bricks weld exactly. The
/// vertex and face order depends only on the parameters (not on the thread count).
/// @param[in] grid    from sample()
/// @param[out] stats  optional counters
/// @throws Cancelled when progress returns false or opts.cancel is requested.
TriMesh extract(const SampledGrid& grid, const ExtractOptions& opts = {},
                ExtractStats* stats = nullptr);

/// The same, releasing the grid's bricks as they are meshed, so the grid and the mesh are
/// never both whole in memory; `grid` is empty afterwards.
TriMesh extract(SampledGrid&& grid, const ExtractOptions& opts = {}, ExtractStats* stats = nullptr);

}  // namespace qjulia
