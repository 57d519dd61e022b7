#pragma once
/// @file classify.h
/// The exact per-point classifier and the continuous field of docs/design.md.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "qjulia/field/formula.h"
#include "qjulia/field/params.h"

namespace qjulia {
namespace detail {
struct KernelSetup;
}

/// What one orbit did.
struct Orbit {
  float field = 0;     ///< continuous F: < 0 in the solid, > 0 outside, never NaN
  int exit_step = -1;  ///< step n at which the orbit escaped / converged; -1 if it never did
  /// The refinement value: max_k s_k (escape) or -min_k t_k (cut-off) over the orbit up to its
  /// decision, clamped to +-1e6: <= 0 exactly in the solid, and continuous across the boundary.
  float root = 0;
  Quat last;  ///< the last finite iterate
};

/// Classifies sampled points (x, y, z) for a validated parameter set. Thread-safe, cheap to
/// copy. Clip planes and the box are not applied here (see Solid).
class Classifier {
 public:
  /// @throws InvalidInput when params do not validate.
  explicit Classifier(const Params& params);

  /// The quaternion the slice maps (x, y, z) to.
  Quat to_quaternion(double x, double y, double z) const;
  /// The continuous field F at (x, y, z): F <= 0 exactly when the point is in the solid.
  float field(double x, double y, double z) const { return orbit(x, y, z).field; }
  /// The whole orbit summary at (x, y, z).
  Orbit orbit(double x, double y, double z) const;
  /// The exact classification: field(x, y, z) <= 0.
  bool inside(double x, double y, double z) const { return field(x, y, z) <= 0; }

  /// F at n points (x[i], y[i], z[i]) at once, into out[i]: the same values as field() up to
  /// rounding (the vector kernel uses fused multiply-adds), computed in SIMD lanes on CPUs with
  /// AVX2 or AVX-512, else point by point. Thread-safe.
  /// @return the formula evaluations done (orbit steps, for speed figures)
  std::uint64_t field(const double* x, const double* y, const double* z, std::size_t n,
                      float* out) const;
  /// The refinement values (Orbit::root) of n points at once: they have the sign of F, and
  /// change smoothly where F has a kink (the two formulas of F meet at the boundary), so root
  /// finding on them converges fast.
  std::uint64_t root_field(const double* x, const double* y, const double* z, std::size_t n,
                           float* out) const;
  /// "AVX3" (AVX-512), "AVX2" or "scalar": how field(x, y, z, n, out) runs.
  std::string evaluator() const;
  /// The vector kernel's setup, or null when field(x, y, z, n, out) runs point by point.
  const detail::KernelSetup* kernel() const;

  const Params& params() const { return params_; }
  /// The same classifier for the grid of another resolution (nothing is compiled again).
  Classifier at_resolution(int resolution) const;

 private:
  std::uint64_t values(const double* x, const double* y, const double* z, std::size_t n, float* out,
                       bool root) const;
  Params params_;
  Formula formula_;
  std::shared_ptr<const detail::KernelSetup> kernel_;  // null: the scalar path
  std::vector<Quat> constants_;
  int c_index_ = -1;  // index of `c` in constants_ (Mandelbrot mode)
  Slice::General slice_;
};

/// The solid that is meshed: the classifier's set, intersected with the box and the clip
/// planes. Its field is max(F, plane terms); points outside the box or a clip are outside.
class Solid {
 public:
  explicit Solid(const Params& params);
  /// The same solid on the grid of another resolution (nothing is validated or compiled again):
  /// for the samplings of the memory estimate.
  Solid at_resolution(int resolution) const;
  const Classifier& classifier() const { return classifier_; }
  /// Field of the whole solid at (x, y, z): the constraint in voxels where it excludes the
  /// point, else max(F, constraint in voxels), so caps are flat and F is never evaluated
  /// outside the box.
  float field(double x, double y, double z) const;
  /// The field of the solid at n points at once (see Classifier::field(x, y, z, n, out)).
  /// @return the classifier's formula evaluations
  std::uint64_t field(const double* x, const double* y, const double* z, std::size_t n,
                      float* out) const;
  /// The refinement values of the solid at n points (the classifier's, combined with the box
  /// constraint as field() does). With clip planes, or with a point outside the box in the
  /// batch, they are the field's values (F combined with the constraints) for every point.
  std::uint64_t root_field(const double* x, const double* y, const double* z, std::size_t n,
                           float* out) const;
  /// Exact: in the box, on the kept side of every clip plane, and classified inside.
  bool inside(double x, double y, double z) const { return field(x, y, z) <= 0; }
  /// The signed distance to the box and clip constraints alone, model units (<= 0 where they
  /// keep the point).
  double constraint(double x, double y, double z) const;
  /// Along the segment from `in` (kept by the constraints) to `out` (excluded): the fraction s in
  /// (0, 1] of the way at which the box or a clip plane first excludes the point, exactly (the
  /// constraints are planes).
  double constraint_crossing(const std::array<double, 3>& in,
                             const std::array<double, 3>& out) const;
  /// The field of a point the box or a clip plane excludes (the constraint in voxels, > 0), or
  /// nothing when the constraints keep it.
  std::optional<float> excluded_field(double x, double y, double z) const;
  /// True when clip planes cut the box.
  bool has_clip() const { return !clip_.empty(); }

 private:
  std::uint64_t values(const double* x, const double* y, const double* z, std::size_t n, float* out,
                       bool root) const;
  Classifier classifier_;
  std::array<double, 3> min_, max_;
  std::vector<ClipPlane> clip_;  // normalised
  double voxel_ = 1.0;
};

}  // namespace qjulia
