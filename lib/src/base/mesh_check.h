#pragma once
/// @file mesh_check.h
/// Small, fast topology checks and edits of clean and decimate; the vertex-fan test is shared with
/// measure().
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {

/// Edge and vertex topology of a triangle mesh.
struct TopologyCheck {
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;           ///< edges with one face
  std::size_t nonmanifold_edges = 0;        ///< edges with more than two faces
  std::size_t misoriented_edges = 0;        ///< two faces traversing the edge the same way
  std::size_t nonmanifold_vertices = 0;     ///< vertices whose faces form more than one fan
  std::size_t degenerate_faces = 0;         ///< repeated vertex index
  std::vector<uint32_t> boundary_vertices;  ///< vertices of boundary edges (sorted, unique)
  std::vector<uint32_t> bad_vertices;       ///< vertices of non-manifold/boundary/misoriented edges
                                            ///< and non-manifold vertices (sorted, unique)
  bool closed() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
  bool manifold() const { return nonmanifold_edges == 0 && nonmanifold_vertices == 0; }
  bool oriented() const { return misoriented_edges == 0; }
};

/// Checks edges and vertex fans (faces with a repeated index are counted and skipped). O(F),
/// multi-threaded.
/// With allow_boundary, boundary edges are counted but their vertices are not reported bad.
TopologyCheck check_topology(const TriMesh& mesh, bool allow_boundary = false);

/// Compressed vertex -> incident faces table.
struct VertexFaces {
  std::vector<uint32_t> offsets;  ///< #V + 1
  std::vector<uint32_t> faces;
  explicit VertexFaces(const TriMesh& mesh);
};

/// The undirected edges of a mesh, each counted once, found at its lower end from the faces
/// there (no sort of all half-edges).
struct EdgeScan {
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;     ///< one face
  std::size_t nonmanifold_edges = 0;  ///< more than two faces
  std::size_t misoriented_edges = 0;  ///< two faces traversing it the same way
  std::vector<uint32_t> edges_at;     ///< per vertex: the edges whose lower end it is
  std::vector<uint32_t> open_faces;   ///< the faces of each edge without exactly two
  std::vector<std::array<uint32_t, 2>> boundary;  ///< the ends of the boundary edges
  std::vector<std::array<uint32_t, 2>> bad;       ///< the ends of non-manifold, misoriented edges
};

/// Scans the edges of the faces (with `skip_degenerate`, faces with a repeated index hold none)
/// from `vf`, vertices in parallel; the lists come in no particular order. @throws Cancelled
/// when `cancel` is requested.
EdgeScan scan_edges(const TriMesh& mesh, const VertexFaces& vf, bool skip_degenerate,
                    const CancelToken* cancel = nullptr);

/// Per vertex: 1 when its faces (those without a repeated index) form more than one fan, i.e.
/// its link is not connected; the one vertex-fan test of measure() and check_topology().
/// Multi-threaded.
std::vector<uint8_t> pinched_vertices(const TriMesh& mesh, const VertexFaces& vf);

/// Vertex-connected components: per face its component id; returns the component count.
std::size_t face_components(const TriMesh& mesh, std::vector<uint32_t>& face_component);

/// Signed volume (divergence theorem) of the faces, in double precision (sum of per-face
/// tetra_volume about the origin).
double signed_volume(const TriMesh& mesh);

/// Drops faces with a repeated index, then pairs of faces on the same three vertices with
/// opposite orientation (the "fins" a collapse can leave; removing both keeps a closed mesh
/// closed), then extra same-orientation copies. Returns the number of faces dropped.
std::size_t drop_repeated_and_fins(TriMesh& mesh);

/// Removes unreferenced vertices (keeping normals/colors aligned). Returns how many were removed.
/// `old_to_new` (optional) receives the new index of every old vertex (0xffffffff if removed).
std::size_t compact_vertices(TriMesh& mesh, std::vector<uint32_t>* old_to_new = nullptr);

/// Pairs of faces that intersect other than in their shared vertices/edge (CGAL; defined in
/// clean_cgal.cpp). Faces a halfedge mesh cannot hold are skipped.
std::vector<std::pair<uint32_t, uint32_t>> self_intersecting_face_pairs(const TriMesh& mesh);

}  // namespace qjulia::detail
