#pragma once
/// @file classify.h
/// The exact per-point classifier and the continuous field of docs/design.md.
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "qjulia/field/formula.h"
#include "qjulia/field/params.h"

namespace qjulia {

/// What one orbit did.
struct Orbit {
  float field = 0;     ///< continuous F: < 0 in the solid, > 0 outside, never NaN
  int exit_step = -1;  ///< step n at which the orbit escaped / converged; -1 if it never did
  Quat last;           ///< the last finite iterate
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

  const Params& params() const { return params_; }

 private:
  Params params_;
  Formula formula_;
  std::vector<Quat> constants_;
  int c_index_ = -1;  // index of `c` in constants_ (Mandelbrot mode)
  Slice::General slice_;
};

/// The solid that is meshed: the classifier's set, intersected with the box and the clip
/// planes. Its field is max(F, plane terms); points outside the box or a clip are outside.
class Solid {
 public:
  explicit Solid(const Params& params);
  const Classifier& classifier() const { return classifier_; }
  /// Field of the whole solid at (x, y, z): the constraint in voxels where it excludes the
  /// point, else max(F, constraint in voxels), so caps are flat and F is never evaluated
  /// outside the box.
  float field(double x, double y, double z) const;
  /// Exact: in the box, on the kept side of every clip plane, and classified inside.
  bool inside(double x, double y, double z) const { return field(x, y, z) <= 0; }
  /// The signed distance to the box and clip constraints alone, model units (<= 0 where they
  /// keep the point).
  double constraint(double x, double y, double z) const;
  /// The field of a point the box or a clip plane excludes (the constraint in voxels, > 0), or
  /// nothing when the constraints keep it.
  std::optional<float> excluded_field(double x, double y, double z) const;
  /// True when clip planes cut the box.
  bool has_clip() const { return !clip_.empty(); }

 private:
  Classifier classifier_;
  std::array<double, 3> min_, max_;
  std::vector<ClipPlane> clip_;  // normalised
  double voxel_ = 1.0;
};

}  // namespace qjulia
