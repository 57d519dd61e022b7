#pragma once
/// @file hausdorff.h
/// Decimation's error measure: the sampled two-sided Hausdorff distance between a mesh and its
/// simplifications, through the BVH that compare() uses (base/bvh.h).
#include <cstddef>
#include <memory>

#include "base/bvh.h"
#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {

/// Sampling budget of Hausdorff.
struct HausdorffOptions {
  std::size_t max_samples = 500'000;    ///< per direction; vertices or faces are strided beyond
  const CancelToken* cancel = nullptr;  ///< checked between batches of queries
};

/// One-sided distances, model units.
struct HausdorffResult {
  double a_to_b = 0;  ///< max over samples of A of the distance to B
  double b_to_a = 0;
  double distance() const { return a_to_b > b_to_a ? a_to_b : b_to_a; }
};

/// Two-sided Hausdorff distance between a fixed mesh A (decimation's input) and meshes B (its
/// simplifications), estimated by sampling: each side's vertices when it is at least as fine as
/// the other, else points on its faces spaced like the other side's edges, at most
/// opts.max_samples per direction (strided). Distances from a sample to the other surface are
/// exact (float). Unreferenced vertices are ignored. A's BVH is built at the first call and kept
/// for the next ones. The result depends only on the meshes, not on the threads.
class Hausdorff {
 public:
  /// Keeps a reference to `a`: it must outlive this object.
  explicit Hausdorff(const TriMesh& a, const HausdorffOptions& opts = {});
  ~Hausdorff();

  /// The distances between A and `b`. @throws Cancelled when opts.cancel is requested.
  HausdorffResult to(const TriMesh& b);

 private:
  const TriMesh& a_;
  HausdorffOptions opts_;
  std::unique_ptr<TriangleBvh> a_tree_;
};

}  // namespace qjulia::detail
