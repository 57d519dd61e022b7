#pragma once
// A bounding volume hierarchy over the triangles of a mesh, for closest-point queries (the
// distance from a point to a surface). Built once, then queried from many threads at once.
#include <array>
#include <cstdint>
#include <vector>

namespace qjulia::detail {

/// The closest point of a surface to a query point.
struct ClosestHit {
  float distance_sq = 0;  ///< squared distance, model units^2
  uint32_t face = 0;      ///< the triangle that holds the closest point
  uint32_t slot = 0;      ///< its place in the tree (a hint for the next query)
};

/// A binary BVH (axis-aligned boxes, up to kLeafSize triangles per leaf) built top-down with the
/// binned surface area heuristic (16 bins per axis; the median when no split helps). Queries
/// are read-only and thread-safe.
class TriangleBvh {
 public:
  static constexpr int kLeafSize = 4;

  /// Builds the tree (multi-threaded). Triangles with an index out of range are skipped.
  /// @param[in] positions  #V by 3 vertex positions
  /// @param[in] triangles  #F by 3 vertex indices
  TriangleBvh(const std::vector<std::array<float, 3>>& positions,
              const std::vector<std::array<uint32_t, 3>>& triangles);

  /// True when the tree holds no triangle.
  bool empty() const { return tri_.empty(); }

  /// The closest point of the surface to `p`. `hint` is the slot of a triangle likely to be
  /// close (the previous hit of a nearby query): the search starts from its distance, which
  /// prunes most of the tree. Requires !empty().
  ClosestHit closest(const std::array<float, 3>& p, uint32_t hint = UINT32_MAX) const;

 private:
  struct Node {
    float lo[3], hi[3];
    uint32_t first;  // leaf: first index into tri_; inner: index of the right child
    uint32_t count;  // leaf: triangle count (> 0); inner: 0 (the left child follows the node)
  };
  // A triangle stored by its corners, in leaf order: a, b - a, c - a (cache-friendly queries).
  struct Tri {
    float a[3], ab[3], ac[3];
    uint32_t face;
  };

  uint32_t build(std::vector<uint32_t>& order, const std::vector<std::array<float, 3>>& centroid,
                 const std::vector<std::array<float, 6>>& boxes, uint32_t begin, uint32_t end,
                 int depth);

  std::vector<Node> nodes_;
  std::vector<Tri> tri_;
};

/// Squared distance from p to the triangle (a, a + ab, a + ac) (Ericson, Real-Time Collision
/// Detection, 5.1.5: Voronoi regions of the vertices and edges, else the face).
float point_triangle_distance_sq(const float p[3], const float a[3], const float ab[3],
                                 const float ac[3]);

}  // namespace qjulia::detail
