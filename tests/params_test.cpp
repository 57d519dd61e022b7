#include "qjulia/field/params.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/base/error.h"

namespace qjulia {
namespace {

// The message of the InvalidInput that `fn` throws; fails the test when it throws nothing or
// something else.
template <class Fn>
std::string invalid_input_message(Fn&& fn) {
  try {
    fn();
  } catch (const InvalidInput& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw something other than InvalidInput: " << e.what();
    return {};
  }
  ADD_FAILURE() << "did not throw";
  return {};
}

std::string parse_error(const std::string& json) {
  return invalid_input_message([&] { parse_params(json, "test.json"); });
}

std::string validate_error(const Params& p) {
  return invalid_input_message([&] { validate(p); });
}

bool same(const Quat& a, const Quat& b) {
  return a.w == b.w && a.x == b.x && a.y == b.y && a.z == b.z;
}

// Every field of two parameter sets is equal.
void expect_same(const Params& a, const Params& b) {
  EXPECT_EQ(a.description, b.description);
  EXPECT_EQ(a.formula, b.formula);
  ASSERT_EQ(a.constants.size(), b.constants.size());
  for (std::size_t i = 0; i < a.constants.size(); ++i) {
    EXPECT_EQ(a.constants[i].first, b.constants[i].first);
    EXPECT_TRUE(same(a.constants[i].second, b.constants[i].second)) << a.constants[i].first;
  }
  EXPECT_EQ(a.mode, b.mode);
  EXPECT_EQ(a.method, b.method);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.bailout, b.bailout);
  EXPECT_TRUE(same(a.start, b.start));
  EXPECT_EQ(a.slice.general.has_value(), b.slice.general.has_value());
  if (a.slice.general && b.slice.general) {
    EXPECT_TRUE(same(a.slice.general->origin, b.slice.general->origin));
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(same(a.slice.general->directions[k], b.slice.general->directions[k]));
  } else {
    EXPECT_EQ(a.slice.axes, b.slice.axes);
    EXPECT_EQ(a.slice.fixed, b.slice.fixed);
  }
  EXPECT_EQ(a.bounds.min, b.bounds.min);
  EXPECT_EQ(a.bounds.max, b.bounds.max);
  EXPECT_EQ(a.resolution, b.resolution);
  EXPECT_EQ(a.mesh.color, b.mesh.color);
  EXPECT_EQ(a.mesh.faces, b.mesh.faces);
  EXPECT_EQ(a.mesh.max_error, b.mesh.max_error);
  EXPECT_EQ(a.mesh.decimate, b.mesh.decimate);
  EXPECT_EQ(a.mesh.min_component, b.mesh.min_component);
  ASSERT_EQ(a.mesh.clip.size(), b.mesh.clip.size());
  for (std::size_t i = 0; i < a.mesh.clip.size(); ++i) {
    EXPECT_EQ(a.mesh.clip[i].normal, b.mesh.clip[i].normal);
    EXPECT_EQ(a.mesh.clip[i].d, b.mesh.clip[i].d);
  }
  EXPECT_EQ(a.print.size_mm, b.print.size_mm);
  EXPECT_EQ(a.print.min_thickness_mm, b.print.min_thickness_mm);
  EXPECT_EQ(a.print.check, b.print.check);
}

// ---------------------------------------------------------------------------------------------
// Round trips and presets

TEST(Params, EveryPresetSurvivesARoundTripThroughJson) {
  const auto names = preset_names();
  ASSERT_FALSE(names.empty());
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const Params p = preset(name);
    const std::string text = params_to_json(p);
    const Params back = parse_params(text, name);
    expect_same(p, back);
    EXPECT_EQ(params_to_json(back), text);
    // The compact form parses to the same set as well.
    expect_same(p, parse_params(params_to_json(p, false), name));
  }
}

TEST(Params, ANonDefaultSetWithEveryOptionSurvivesARoundTrip) {
  Params p;
  p.description = "every field set";
  p.formula = "p*h^2+q";
  p.set_constant("p", {0.9, 0.3, 0.2, 0.1});
  p.set_constant("q", {-0.3, 0.5, 0.3, 0.1});
  p.mode = Mode::kMandelbrot;
  p.method = Method::kEscape;
  p.iterations = 33;
  p.bailout = 0.123456789012345;
  p.start = {0.1, -0.2, 0.3, -0.4};
  const double s = std::sqrt(0.5);
  p.slice.general =
      Slice::General{{0.25, 0, 0, 0.5}, {Quat{s, s, 0, 0}, {0, 0, 1, 0}, {-s, s, 0, 0}}};
  p.bounds = {{-1.25, -2, -0.5}, {1, 2.5, 0.75}};
  p.resolution = 300;
  p.mesh.color = ColorMode::kBasin;
  p.mesh.faces = 12345;
  p.mesh.max_error = 0.002;
  p.mesh.decimate = Decimation::kQuality;
  p.mesh.min_component = 1e-4;
  p.mesh.clip = {{{0, 0, 1}, 0.1}, {{1, 2, 3}, -0.5}};
  p.print.size_mm = 80;
  p.print.min_thickness_mm = 0.8;
  p.print.check = true;
  validate(p);
  expect_same(p, parse_params(params_to_json(p)));
}

TEST(Params, AnEmptyFileGivesTheDefaultNewtonCubicWithTheCutoffMethod) {
  const Params p = parse_params("{}");
  expect_same(p, Params{});
  EXPECT_EQ(p.formula, "(2*h^3+1)/(3*h^2)");
  EXPECT_EQ(p.method, Method::kCutoff);
  EXPECT_EQ(p.mode, Mode::kJulia);
  EXPECT_EQ(p.iterations, 12);
  EXPECT_EQ(p.bailout, 0.01);
  EXPECT_EQ(p.slice.axes, "rmn");
}

TEST(Params, TheExampleFileOfTheDesignParses) {
  const Params p = parse_params(R"json({
    "formula": "(2*h^3+1)/(3*h^2)",
    "constants": { "c": [0, 0, 0, 0] },
    "mode": "julia",
    "method": "cutoff",
    "iterations": 12,
    "bailout": 0.01,
    "slice": { "axes": "rmn", "fixed": 0.0 },
    "bounds": { "min": [-2, -2, -2], "max": [2, 2, 2] },
    "resolution": 256
  })json");
  ASSERT_NE(p.constant("c"), nullptr);
  EXPECT_TRUE(same(*p.constant("c"), Quat{}));
  EXPECT_EQ(p.resolution, 256);
}

TEST(Params, EveryPresetHasADescriptionAndValidates) {
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    const Params p = preset(name);
    EXPECT_FALSE(p.description.empty());
    EXPECT_EQ(preset_description(name), p.description);
    EXPECT_EQ(p.description.find('\n'), std::string::npos) << "a description is one line";
    EXPECT_NO_THROW(validate(p));
  }
}

TEST(Params, ThePresetsTheDesignAndTestsNameExist) {
  const auto names = preset_names();
  for (const char* name : {"unit-ball", "classic-julia", "newton-cubic"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
}

TEST(Params, UnknownPresetThrowsAndListsTheKnownOnes) {
  const std::string msg = invalid_input_message([] { preset("nope"); });
  EXPECT_NE(msg.find("nope"), std::string::npos) << msg;
  for (const std::string& name : preset_names())
    EXPECT_NE(msg.find(name), std::string::npos) << msg << " does not list " << name;
  EXPECT_THROW(preset_description("nope"), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Parse errors name the key

TEST(Params, TheDecimationMethodIsReadWrittenWhenNotTheDefaultAndChecked) {
  EXPECT_EQ(parse_params(R"({"mesh": {"decimate": "quality"}})").mesh.decimate,
            Decimation::kQuality);
  EXPECT_EQ(parse_params(R"({"mesh": {"decimate": "fast"}})").mesh.decimate, Decimation::kFast);
  EXPECT_EQ(parse_params("{}").mesh.decimate, Decimation::kFast);
  // The default is left out, so that files written before it read back the same.
  Params p;
  EXPECT_EQ(params_to_json(p).find("decimate"), std::string::npos);
  p.mesh.decimate = Decimation::kQuality;
  EXPECT_NE(params_to_json(p).find("\"decimate\": \"quality\""), std::string::npos)
      << params_to_json(p);
  const std::string msg = parse_error(R"({"mesh": {"decimate": "best"}})");
  EXPECT_NE(msg.find("mesh.decimate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("best"), std::string::npos) << msg;
}

TEST(Params, UnknownTopLevelKeyIsAnErrorNamingTheKey) {
  const std::string msg = parse_error(R"({"formula": "h^2", "colour": "red"})");
  EXPECT_NE(msg.find("colour"), std::string::npos) << msg;
  EXPECT_NE(msg.find("test.json"), std::string::npos) << "the source is named: " << msg;
}

TEST(Params, UnknownKeysInNestedObjectsAreErrorsNamingTheKey) {
  const struct {
    const char* json;
    const char* key;
  } cases[] = {
      {R"({"slice": {"axes": "rmn", "rotation": 1}})", "rotation"},
      {R"({"bounds": {"min": [-1,-1,-1], "max": [1,1,1], "center": [0,0,0]}})", "center"},
      {R"({"mesh": {"colour": "basin"}})", "colour"},
      {R"({"print": {"size": 80}})", "size"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.json);
    const std::string msg = parse_error(c.json);
    EXPECT_NE(msg.find(c.key), std::string::npos) << msg;
  }
}

TEST(Params, TypeErrorsNameTheKey) {
  const struct {
    const char* json;
    const char* key;
  } cases[] = {
      {R"({"iterations": "ten"})", "iterations"},
      {R"({"iterations": 2.5})", "iterations"},
      {R"({"bailout": "big"})", "bailout"},
      {R"({"formula": 3})", "formula"},
      {R"({"resolution": [256]})", "resolution"},
      {R"({"method": 1})", "method"},
      {R"({"constants": {"c": [1, 2]}})", "constants.c"},
      {R"({"constants": {"c": "one"}})", "constants.c"},
      {R"({"slice": {"axes": 5}})", "slice.axes"},
      {R"({"slice": {"fixed": "zero"}})", "slice.fixed"},
      {R"({"bounds": {"min": [1, 2]}})", "bounds.min"},
      {R"({"bounds": {"max": ["a", 1, 1]}})", "bounds.max"},
      {R"({"mesh": {"faces": "many"}})", "mesh.faces"},
      {R"({"print": {"check": "yes"}})", "print.check"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.json);
    const std::string msg = parse_error(c.json);
    EXPECT_NE(msg.find(c.key), std::string::npos) << msg;
  }
}

TEST(Params, InvalidJsonIsAnErrorNamingTheSource) {
  const std::string msg = parse_error(R"({"formula": "h^2",)");
  EXPECT_NE(msg.find("test.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("JSON"), std::string::npos) << msg;
  EXPECT_FALSE(parse_error("[1, 2, 3]").empty()) << "an array is not a parameter file";
}

TEST(Params, ReadingAMissingFileNamesTheFile) {
  const std::string msg =
      invalid_input_message([] { read_params_file("/nonexistent/dir/params-404.json"); });
  EXPECT_NE(msg.find("params-404.json"), std::string::npos) << msg;
}

TEST(Params, ParseAlsoValidates) {
  EXPECT_NE(parse_error(R"({"resolution": 0})").find("resolution"), std::string::npos);
  EXPECT_NE(parse_error(R"({"bailout": -1})").find("bailout"), std::string::npos);
  EXPECT_NE(parse_error(R"({"formula": "h^"})").find("1:3"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// validate()

TEST(Validate, TheDefaultsAreValid) { EXPECT_NO_THROW(validate(Params{})); }

TEST(Validate, RejectsResolutionOutsideTheRange) {
  // 1..1000000: what fits in memory is the memory estimate's to decide, not a fixed cap.
  for (int r : {0, -3, 1000001}) {
    Params p;
    p.resolution = r;
    const std::string msg = validate_error(p);
    EXPECT_NE(msg.find("resolution"), std::string::npos) << r << ": " << msg;
    EXPECT_NE(msg.find("1..1000000"), std::string::npos) << r << ": " << msg;
  }
  for (int r : {1, 2, 4096, 5000, 1000000}) {
    Params p;
    p.resolution = r;
    EXPECT_NO_THROW(validate(p)) << r;
  }
}

TEST(Validate, RejectsZeroIterations) {
  Params p;
  p.iterations = 0;
  EXPECT_NE(validate_error(p).find("iterations"), std::string::npos);
  p.iterations = 1;
  EXPECT_NO_THROW(validate(p));
}

TEST(Validate, RejectsBailoutThatIsZeroNegativeOrNotANumber) {
  for (double r : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                   std::numeric_limits<double>::infinity()}) {
    Params p;
    p.bailout = r;
    const std::string msg = validate_error(p);
    EXPECT_NE(msg.find("bailout"), std::string::npos) << r << ": " << msg;
  }
  Params p;
  p.bailout = 0.8;  // the paper's escape radius is below 1, so this must be accepted
  EXPECT_NO_THROW(validate(p));
}

TEST(Validate, RejectsBoundsWithMinNotBelowMaxAndNamesTheAxis) {
  for (int axis = 0; axis < 3; ++axis) {
    for (double max : {0.5, 0.0}) {  // min == max, and min > max
      Params p;
      p.bounds.min[axis] = 0.5;
      p.bounds.max[axis] = max;
      const std::string msg = validate_error(p);
      SCOPED_TRACE(msg);
      EXPECT_NE(msg.find("bounds"), std::string::npos);
      EXPECT_NE(msg.find(std::string("axis ") + "xyz"[axis]), std::string::npos);
    }
  }
}

TEST(Validate, RejectsBadAxes) {
  for (const char* axes : {"rmm", "xyz", "rm", "rmnp", ""}) {
    Params p;
    p.slice.axes = axes;
    const std::string msg = validate_error(p);
    EXPECT_NE(msg.find("axes"), std::string::npos) << axes << ": " << msg;
  }
  for (const char* axes : {"rmn", "pnm", "mnp", "rnp"}) {
    Params p;
    p.slice.axes = axes;
    EXPECT_NO_THROW(validate(p)) << axes;
  }
}

TEST(Validate, RejectsANonOrthonormalGeneralSlice) {
  Params p;
  // Unit length but not orthogonal.
  const double s = std::sqrt(0.5);
  p.slice.general = Slice::General{{}, {Quat{1, 0, 0, 0}, {s, s, 0, 0}, {0, 0, 0, 1}}};
  EXPECT_NE(validate_error(p).find("slice"), std::string::npos);
  // Orthogonal but not unit length.
  p.slice.general = Slice::General{{}, {Quat{2, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}}};
  EXPECT_NE(validate_error(p).find("slice"), std::string::npos);
  // A rotation in the r-m plane is fine.
  p.slice.general = Slice::General{{}, {Quat{s, s, 0, 0}, {-s, s, 0, 0}, {0, 0, 0, 1}}};
  EXPECT_NO_THROW(validate(p));
}

TEST(Validate, RejectsReservedConstantNames) {
  for (const char* name : {"h", "i"}) {
    Params p;
    p.formula = "h^2";
    p.set_constant(name, Quat(0.5));
    const std::string msg = validate_error(p);
    EXPECT_NE(msg.find(std::string("'") + name + "'"), std::string::npos) << msg;
  }
}

TEST(Validate, MalformedFormulaNamesTheColumn) {
  const struct {
    const char* formula;
    const char* where;
  } cases[] = {
      {"h^", "1:3"},    // the exponent is missing after column 2
      {"h+*2", "1:3"},  // '*' cannot start an operand
      {"(h+1", "1:5"},  // ')' expected at the end
      {"h^2+c", "c"},   // c is not a constant of this set
  };
  for (const auto& c : cases) {
    Params p;
    p.formula = c.formula;
    const std::string msg = validate_error(p);
    EXPECT_NE(msg.find(c.where), std::string::npos) << c.formula << ": " << msg;
  }
}

TEST(Validate, MandelbrotModeProvidesTheConstantC) {
  Params p;
  p.formula = "h^2+c";
  p.mode = Mode::kMandelbrot;
  EXPECT_NO_THROW(validate(p));
  p.mode = Mode::kJulia;
  EXPECT_THROW(validate(p), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Slice::resolved()

void expect_quat(const Quat& got, const Quat& want) {
  EXPECT_TRUE(same(got, want)) << "got (" << got.w << ", " << got.x << ", " << got.y << ", "
                               << got.z << "), want (" << want.w << ", " << want.x << ", " << want.y
                               << ", " << want.z << ")";
}

TEST(Slice, AxesMnpPutTheFixedValueOnTheRealPart) {
  Slice s;
  s.axes = "mnp";
  s.fixed = 0.5;
  const Slice::General g = s.resolved();
  expect_quat(g.origin, {0.5, 0, 0, 0});
  expect_quat(g.directions[0], {0, 1, 0, 0});
  expect_quat(g.directions[1], {0, 0, 1, 0});
  expect_quat(g.directions[2], {0, 0, 0, 1});
}

TEST(Slice, DefaultAxesMapXyzToRealIAndJ) {
  Slice s;
  s.fixed = -0.25;
  const Slice::General g = s.resolved();
  expect_quat(g.origin, {0, 0, 0, -0.25});
  expect_quat(g.directions[0], {1, 0, 0, 0});
  expect_quat(g.directions[1], {0, 1, 0, 0});
  expect_quat(g.directions[2], {0, 0, 1, 0});
}

TEST(Slice, AxesInAnyOrderFollowTheLetters) {
  Slice s;
  s.axes = "pnr";
  s.fixed = 2;
  const Slice::General g = s.resolved();
  expect_quat(g.origin, {0, 2, 0, 0});
  expect_quat(g.directions[0], {0, 0, 0, 1});
  expect_quat(g.directions[1], {0, 0, 1, 0});
  expect_quat(g.directions[2], {1, 0, 0, 0});
}

TEST(Slice, AGeneralSliceResolvesToItself) {
  Slice s;
  s.axes = "mnp";  // ignored
  s.fixed = 7;     // ignored
  const double c = std::sqrt(0.5);
  s.general = Slice::General{{0.1, 0.2, 0.3, 0.4}, {Quat{c, c, 0, 0}, {0, 0, 1, 0}, {-c, c, 0, 0}}};
  const Slice::General g = s.resolved();
  expect_quat(g.origin, s.general->origin);
  for (int k = 0; k < 3; ++k) expect_quat(g.directions[k], s.general->directions[k]);
}

// ---------------------------------------------------------------------------------------------
// Numeric ranges: every number of the parameter file, at both ends of its range and beyond

// A parameter-file key, a file with `@` where the number goes, and the ends of its range.
struct RangeCase {
  std::string key;
  std::string file;
  ValueRange range;
  std::string below, above;  // just outside the range
};

std::vector<RangeCase> range_cases() {
  return {
      {"iterations", R"({"iterations": @})", kIterationsRange, "0", "100001"},
      {"bailout", R"({"bailout": @})", kBailoutRange, "9e-13", "1.1e12"},
      {"resolution", R"({"resolution": @})", kResolutionRange, "0", "1000001"},
      {"bounds.min", R"({"bounds": {"min": [@, -1e6, -1e6], "max": [1e6, 1e6, 1e6]}})",
       kCoordinateRange, "-1000001", ""},
      {"bounds.max", R"({"bounds": {"min": [-1e6, -1e6, -1e6], "max": [@, 1e6, 1e6]}})",
       kCoordinateRange, "", "1000001"},
      {"slice.fixed", R"({"slice": {"axes": "rmn", "fixed": @}})", kCoordinateRange, "-1.1e6",
       "1.1e6"},
      {"constants.c", R"({"formula": "h^2+c", "constants": {"c": [0, @, 0, 0]}})", kCoordinateRange,
       "-1.1e6", "1.1e6"},
      {"start", R"({"mode": "mandelbrot", "formula": "h^2+c", "start": [@, 0, 0, 0]})",
       kCoordinateRange, "-1.1e6", "1.1e6"},
      {"mesh.clip", R"({"mesh": {"clip": [[0, 0, 1, @]]}})", kCoordinateRange, "-1.1e6", "1.1e6"},
      {"mesh.faces", R"({"mesh": {"faces": @}})", kFacesRange, "3", "1000000001"},
      {"mesh.max_error", R"({"mesh": {"max_error": @}})", kMaxErrorRange, "9e-10", "1.1e6"},
      {"mesh.min_component", R"({"mesh": {"min_component": @}})", kMinComponentRange, "-1e-9",
       "1.1e18"},
      {"print.size_mm", R"({"print": {"size_mm": @}})", kLengthMmRange, "0.0009", "1.1e6"},
      {"print.min_thickness_mm", R"({"print": {"min_thickness_mm": @}})", kLengthMmRange, "0.0009",
       "1.1e6"},
  };
}

std::string with_number(const std::string& file, const std::string& number) {
  std::string out = file;
  out.replace(out.find('@'), 1, number);
  return out;
}

std::string number_json(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

TEST(Ranges, EveryNumberOfTheParameterFileIsAcceptedAtBothEndsOfItsRange) {
  for (const RangeCase& c : range_cases())
    for (double end : {c.range.min, c.range.max}) {
      // bounds.min cannot reach +1e6 (min < max), nor bounds.max -1e6.
      if ((c.key == "bounds.min" && end > 0) || (c.key == "bounds.max" && end < 0)) continue;
      const std::string file = with_number(c.file, number_json(end));
      EXPECT_NO_THROW(parse_params(file, "test.json")) << file;
    }
}

TEST(Ranges, NumbersOutsideTheRangeNameTheKeyAndTheRange) {
  for (const RangeCase& c : range_cases()) {
    std::vector<std::string> outside = {"1e400", "-1e400"};
    if (!c.below.empty()) outside.push_back(c.below);
    if (!c.above.empty()) outside.push_back(c.above);
    for (const std::string& number : outside) {
      const std::string file = with_number(c.file, number);
      const std::string msg = parse_error(file);
      EXPECT_NE(msg.find("'" + c.key + "'"), std::string::npos) << file << ": " << msg;
      EXPECT_NE(msg.find(to_string(c.range)), std::string::npos) << file << ": " << msg;
    }
    // NaN and Infinity are not JSON: the file is refused as such, naming line and column.
    for (const char* number : {"NaN", "Infinity"}) {
      const std::string msg = parse_error(with_number(c.file, number));
      EXPECT_NE(msg.find("not valid JSON"), std::string::npos) << c.key << ": " << msg;
    }
  }
}

TEST(Ranges, ValidateRefusesNonFiniteValuesNamingTheFieldAndTheRange) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<std::string, std::function<void(Params&, double)>>> fields = {
      {"bailout", [](Params& p, double v) { p.bailout = v; }},
      {"bounds.min", [](Params& p, double v) { p.bounds.min[1] = v; }},
      {"bounds.max", [](Params& p, double v) { p.bounds.max[2] = v; }},
      {"slice.fixed", [](Params& p, double v) { p.slice.fixed = v; }},
      {"start", [](Params& p, double v) { p.start.z = v; }},
      {"constants.c",
       [](Params& p, double v) {
         p.set_constant("c", Quat{0, v, 0, 0});
       }},
      {"mesh.clip",
       [](Params& p, double v) {
         p.mesh.clip.push_back({{v, 0, 1}, 0});
       }},
      {"mesh.max_error", [](Params& p, double v) { p.mesh.max_error = v; }},
      {"mesh.min_component", [](Params& p, double v) { p.mesh.min_component = v; }},
      {"print.size_mm", [](Params& p, double v) { p.print.size_mm = v; }},
      {"print.min_thickness_mm", [](Params& p, double v) { p.print.min_thickness_mm = v; }},
  };
  for (const auto& [key, set] : fields)
    for (double v : {nan, inf, -inf}) {
      Params p;
      set(p, v);
      const std::string msg = validate_error(p);
      EXPECT_NE(msg.find("'" + key + "'"), std::string::npos) << key << " = " << v << ": " << msg;
      EXPECT_NE(msg.find(" in "), std::string::npos) << key << " = " << v << ": " << msg;
    }
  Params p;
  p.slice.general = Slice::General{{}, {Quat{nan, 0, 0, 0}, Quat{0, 1, 0, 0}, Quat{0, 0, 1, 0}}};
  EXPECT_NE(validate_error(p).find("slice"), std::string::npos);
}

// Parameter files the fuzzer found (tests/fuzz/regressions/params/), read as params_fuzz reads
// them: each parses, and writes back to a file that parses to the same, or is InvalidInput.
TEST(FuzzRegressions, EveryParameterFileThatOnceFailedParsesOrIsRefusedCleanly) {
  const std::filesystem::path dir =
      std::filesystem::path(QJULIA_SOURCE_DIR) / "tests/fuzz/regressions/params";
  std::size_t inputs = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    ++inputs;
    std::ifstream in(e.path(), std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    SCOPED_TRACE(e.path().string());
    try {
      const std::string json = params_to_json(parse_params(text, "fuzz"));
      EXPECT_EQ(params_to_json(parse_params(json, "fuzz")), json);
    } catch (const InvalidInput&) {
    }
  }
  EXPECT_GT(inputs, 0u);
}

}  // namespace
}  // namespace qjulia
