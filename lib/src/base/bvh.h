#pragma once
/// @file bvh.h
/// The one bounding volume hierarchy over the triangles of a mesh, for closest-point queries (the
/// distance from a point to a surface): compare() and decimate's error measurement use it. Built
/// once, then queried from many threads at once.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "qjulia/base/progress.h"

namespace qjulia::detail {

/// The closest point of a surface to a query point.
struct ClosestHit {
  float distance_sq = 0;  ///< squared distance, model units^2
  uint32_t slot = 0;      ///< the triangle's place in the tree (a hint for the next query)
};

/// A binary BVH (axis-aligned boxes, up to kLeafSize triangles per leaf) over the Morton order of
/// the triangles' box centres: a node is split where the codes change their highest bit, a set
/// of triangles that share one code by the binned surface area heuristic. The build is
/// multi-threaded and its result depends only on the input. Queries are read-only and
/// thread-safe.
class TriangleBvh {
 public:
  static constexpr int kLeafSize = 8;

  /// Builds the tree. Triangles with an index out of range are skipped.
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

  /// The distance (not squared; infinity when empty()) from every point to the surface,
  /// multi-threaded. The points go in fixed blocks of consecutive points, each query starting
  /// from the previous hit of its block, so the result depends only on the input (not on the
  /// threads). Between batches of 65,536 points the calling thread checks `cancel` (throws
  /// Cancelled) and calls `step` with the fraction done (it may throw to stop).
  std::vector<float> distances(const std::vector<std::array<float, 3>>& points,
                               const CancelToken* cancel = nullptr,
                               const std::function<void(double)>& step = {}) const;

  /// Makes points [begin, end) of a sequence in `out` (from several threads at once).
  using PointSource =
      std::function<void(std::size_t begin, std::size_t end, std::array<float, 3>* out)>;
  /// Takes the distances of points [begin, begin + n) (on the calling thread, in order).
  using DistanceSink = std::function<void(std::size_t begin, const float* d, std::size_t n)>;
  /// The same distances for `count` points that `source` makes batch by batch, handed to `sink`
  /// batch by batch: the same values as distances() of the whole sequence, in memory of one
  /// batch rather than of all the points.
  void distances(std::size_t count, const PointSource& source, const DistanceSink& sink,
                 const CancelToken* cancel = nullptr,
                 const std::function<void(double)>& step = {}) const;

  // Layout, for the builder in bvh.cpp.
  struct Node {
    float lo[3], hi[3];
    uint32_t first;  ///< leaf: first index into tri_; inner: index of the right child
    uint32_t count;  ///< leaf: triangle count (> 0); inner: 0 (the left child follows the node)
  };
  /// A triangle stored by its corners, in leaf order: a, b - a, c - a (cache-friendly queries).
  struct Tri {
    float a[3], ab[3], ac[3];
  };

 private:
  std::vector<Node> nodes_;
  std::vector<Tri> tri_;
};

}  // namespace qjulia::detail
