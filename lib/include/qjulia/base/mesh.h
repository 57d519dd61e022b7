#pragma once
/// @file mesh.h
/// The plain interchange mesh every stage passes on, and its measures.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace qjulia {

class CancelToken;

/// An indexed triangle mesh in slice coordinates (x, y, z as sampled), counter-clockwise seen
/// from outside (outward normals).
struct TriMesh {
  std::vector<std::array<float, 3>> positions;     ///< #V by 3
  std::vector<std::array<uint32_t, 3>> triangles;  ///< #F by 3 vertex indices
  std::vector<std::array<float, 3>> normals;       ///< empty or #V unit normals
  std::vector<std::array<float, 3>> colors;        ///< empty or #V linear RGB in [0, 1]

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t face_count() const { return triangles.size(); }
};

/// One vertex-connected component.
struct ComponentMeasure {
  std::size_t faces = 0;
  double volume = 0;     ///< signed, model units^3
  double area = 0;       ///< model units^2
  bool closed = false;   ///< no boundary or non-manifold edge
  long long euler = 0;   ///< V - E + F
  long long genus = -1;  ///< (2 - euler) / 2 when closed, else -1
};

/// Topology and geometry of a mesh.
struct MeshMeasure {
  std::size_t vertices = 0;  ///< referenced vertices
  std::size_t faces = 0;
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;        ///< edges with one face
  std::size_t nonmanifold_edges = 0;     ///< edges with more than two faces
  std::size_t nonmanifold_vertices = 0;  ///< vertices whose faces form more than one fan
  std::size_t misoriented_edges = 0;     ///< edges whose two faces traverse it the same way
  std::size_t degenerate_faces = 0;      ///< repeated index or zero area
  bool closed = false;                   ///< no boundary and no non-manifold edge
  bool manifold = false;                 ///< no non-manifold edge or vertex
  bool oriented = false;                 ///< no misoriented edge
  double volume = 0;                     ///< signed (divergence theorem), > 0 when outward
  double area = 0;
  std::array<double, 3> bbox_min{0, 0, 0};
  std::array<double, 3> bbox_max{0, 0, 0};
  long long euler = 0;                       ///< V - E + F over the whole mesh
  std::vector<ComponentMeasure> components;  ///< sorted by decreasing face count
};

/// Measures `mesh`. Each vertex sorts only the half-edges of its own faces: linear in V + F when
/// vertices have a few faces each, O(F log F) at worst; multi-threaded where it can. Faces with a
/// repeated index count towards the edges but not towards the vertex fans.
/// @throws InvalidInput when validate_mesh() refuses the mesh; Cancelled when `cancel` is
///         requested.
MeshMeasure measure(const TriMesh& mesh, const CancelToken* cancel = nullptr);

/// The vertex-connected component of every face (faces that share a vertex are in one), numbered
/// 0, 1, ... in the order of each component's first face. Runs in O(V + F).
/// @throws InvalidInput when validate_mesh() refuses the mesh.
std::vector<std::uint32_t> face_components(const TriMesh& mesh);

/// Area-weighted vertex normals of `mesh`: #V unit vectors, (0, 0, 1) where no face defines a
/// direction (isolated vertices, zero-area fans).
/// @throws InvalidInput when validate_mesh() refuses the mesh.
std::vector<std::array<float, 3>> area_weighted_normals(const TriMesh& mesh);

/// Sets mesh.normals to area_weighted_normals(mesh) (the normals it had, of any count, are
/// replaced; on a failure they stay). @throws InvalidInput as area_weighted_normals().
void compute_normals(TriMesh& mesh);

}  // namespace qjulia
