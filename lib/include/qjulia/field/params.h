#pragma once
/// @file params.h
/// The parameter set of a run: the map, the method, the slice, the box, the resolution, and the
/// options of the later stages. Read from / written to the JSON parameter file of docs/design.md.
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/field/quaternion.h"

namespace qjulia {

/// An inclusive range of accepted values.
struct ValueRange {
  double min, max;
  /// False for NaN.
  constexpr bool contains(double v) const { return v >= min && v <= max; }
};

/// "1..100000", "1e-12..1e+12": a range as messages and --help show it.
std::string to_string(const ValueRange& range);

/// The accepted ranges of the numeric parameters. validate() enforces them; the CLI quotes them
/// in --help and in its messages.
inline constexpr ValueRange kIterationsRange{1, 100000};
inline constexpr ValueRange kBailoutRange{1e-12, 1e12};
/// Voxels along the longest side. What fits in memory is the memory estimate's to decide.
inline constexpr ValueRange kResolutionRange{1, 1000000};
/// Every component of bounds, slice.fixed, slice.origin, constants, start and clip planes.
inline constexpr ValueRange kCoordinateRange{-1e6, 1e6};
inline constexpr ValueRange kFacesRange{4, 1e9};
inline constexpr ValueRange kMaxErrorRange{1e-9, 1e6};    ///< model units
inline constexpr ValueRange kMinComponentRange{0, 1e18};  ///< model units^3
inline constexpr ValueRange kLengthMmRange{0.001, 1e6};   ///< print.size_mm, min_thickness_mm

/// How a point is classified (docs/design.md, section 1).
enum class Method {
  kEscape,  ///< in the solid when |h_k| <= R for every k in 0..N
  kCutoff,  ///< in the solid when |h_k - h_(k-1)| >= R for every k in 1..N
};

/// What the sampled point is.
enum class Mode {
  kJulia,       ///< h0 is the sampled point, constants fixed
  kMandelbrot,  ///< the constant `c` is the sampled point, h0 = start
};

/// Maps a sampled point (x, y, z) to the quaternion origin + x*dir[0] + y*dir[1] + z*dir[2].
struct Slice {
  /// Which quaternion component each of x, y, z becomes: three distinct letters of "rmnp"
  /// (r = real, m = i, n = j, p = k). Ignored when `general` is set.
  std::string axes = "rmn";
  /// The value of the fourth component. Ignored when `general` is set.
  double fixed = 0.0;
  /// A general slice: origin and three orthonormal 4D directions (a 4D rotation).
  struct General {
    Quat origin;
    std::array<Quat, 3> directions;
  };
  std::optional<General> general;

  /// The origin and directions this slice stands for (from axes/fixed or from general).
  General resolved() const;
};

/// An axis-aligned box in slice coordinates.
struct Bounds {
  std::array<double, 3> min{-2, -2, -2};
  std::array<double, 3> max{2, 2, 2};
};

/// Keeps the part of the solid with normal . x <= d.
struct ClipPlane {
  std::array<double, 3> normal{0, 0, 1};
  double d = 0.0;
};

/// Per-vertex colour written by the exporters.
enum class ColorMode { kNone, kIterations, kBasin };

/// How a face budget or error bound is met (qjulia::DecimateMethod): "fast", qjulia's edge
/// collapses that keep the topology, in parallel, or "quality", OpenMesh's Decimater, with a
/// lower error at the same face count on fractal meshes (much slower, one thread).
enum class Decimation { kFast, kQuality };

/// Options of the stages after sampling (the "mesh" section of the parameter file).
struct MeshParams {
  ColorMode color = ColorMode::kNone;   ///< COLOR_0 / vertex colours
  std::optional<long long> faces;       ///< decimate to at most this many faces
  std::optional<double> max_error;      ///< decimation error bound, model units
  Decimation decimate = Decimation::kFast;  ///< the decimation method (with faces or max_error)
  std::optional<double> min_component;  ///< drop components below this volume (model
                                        ///< units^3); unset = the default of clean()
  std::vector<ClipPlane> clip;          ///< sections, applied to the field before meshing
};

/// Options for 3D printing (the "print" section of the parameter file).
struct PrintParams {
  std::optional<double> size_mm;           ///< scale so the longest side is this long, in mm
  std::optional<double> min_thickness_mm;  ///< thicken parts thinner than this, in mm
  bool check = false;                      ///< run the self-intersection test
};

/// A complete parameter set. Every field has the default of the built-in Newton cubic.
struct Params {
  std::string description;  ///< one line about the set (presets have one)
  std::string formula = "(2*h^3+1)/(3*h^2)";
  /// Named quaternion constants, in file order.
  std::vector<std::pair<std::string, Quat>> constants;
  Mode mode = Mode::kJulia;
  Method method = Method::kCutoff;
  int iterations = 12;    ///< N, kIterationsRange
  double bailout = 0.01;  ///< R, kBailoutRange (bailout radius or cut-off rate)
  Quat start;             ///< h0 in Mandelbrot mode
  Slice slice;
  Bounds bounds;
  int resolution = 256;  ///< voxels along the longest side of the box, kResolutionRange
  MeshParams mesh;
  PrintParams print;

  /// The value of a constant, or nullptr.
  const Quat* constant(const std::string& name) const;
  /// Sets (or adds) a constant.
  void set_constant(const std::string& name, const Quat& value);
};

/// Checks ranges (the k...Range constants above) and consistency (formula compiles, bounds
/// min < max, axes, ...). @throws InvalidInput naming the field and the accepted range.
void validate(const Params& params);

/// Parses a parameter file. Unknown keys are an error. Missing keys keep the defaults.
/// @param[in] json_text  the file's contents
/// @param[in] source     a name for messages (the file name)
/// @throws InvalidInput naming the key and what is wrong.
Params parse_params(const std::string& json_text, const std::string& source = "parameters");

/// Reads and parses a parameter file. @throws InvalidInput when unreadable or invalid.
Params read_params_file(const std::string& path);

/// The parameter file for `params` (pretty-printed JSON; parse_params gives it back).
std::string params_to_json(const Params& params, bool pretty = true);

/// Built-in presets, embedded from data/presets at build time.
std::vector<std::string> preset_names();
/// One line that describes a preset. @throws InvalidInput for an unknown name.
std::string preset_description(const std::string& name);
/// A preset's parameters. @throws InvalidInput for an unknown name, listing the known ones.
Params preset(const std::string& name);

/// "escape" / "cutoff", "julia" / "mandelbrot", "none" / "iterations" / "basin".
const char* to_string(Method m);
const char* to_string(Mode m);
const char* to_string(ColorMode m);
const char* to_string(Decimation d);
/// The method named `name` ("fast", "quality": to_string()'s names), or none.
std::optional<Decimation> decimation_named(const std::string& name);

/// Where the grid points of a parameter set are: point (i, j, k) is at origin + (i, j, k) *
/// voxel for 0 <= i < points[0] etc., at the centres of voxels of the box, so the walls of the
/// box lie half a voxel beyond the outermost points.
struct GridGeometry {
  std::array<double, 3> origin{0, 0, 0};  ///< bounds.min + voxel / 2
  double voxel = 1.0;                     ///< longest side of the box / resolution
  std::array<int, 3> points{0, 0, 0};
};

/// The grid of `params` (not validated here).
GridGeometry grid_geometry(const Params& params);

}  // namespace qjulia
