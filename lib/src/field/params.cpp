#include "qjulia/field/params.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "field/presets.h"
#include "field/validated.h"
#include "qjulia/base/error.h"
#include "qjulia/field/formula.h"

namespace qjulia {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw InvalidInput(source + ": " + what);
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// `value` must lie in `range`: "'iterations' must be in 1..100000, not 0".
void check_range(double value, const ValueRange& range, const std::string& source,
                 const std::string& key) {
  if (!range.contains(value))
    fail(source, "'" + key + "' must be in " + to_string(range) + ", not " + number_text(value));
}

void check_range(const Quat& q, const ValueRange& range, const std::string& source,
                 const std::string& key) {
  for (double c : {q.w, q.x, q.y, q.z}) check_range(c, range, source, key);
}

// Every key of `object` must be one of `allowed`.
void check_keys(const json& object, std::initializer_list<const char*> allowed,
                const std::string& source, const std::string& where) {
  for (const auto& item : object.items()) {
    bool known = false;
    for (const char* name : allowed) known = known || item.key() == name;
    if (!known) {
      std::string list;
      for (const char* name : allowed) list += std::string(list.empty() ? "" : ", ") + name;
      fail(source, "unknown key '" + where + item.key() + "' (known: " + list + ")");
    }
  }
}

double get_number(const json& v, const std::string& source, const std::string& key) {
  if (!v.is_number()) fail(source, "'" + key + "' must be a number");
  return v.get<double>();  // the range is validate()'s to check
}

long long get_integer(const json& v, const std::string& source, const std::string& key,
                      const ValueRange& range) {
  const std::string expected = "'" + key + "' must be an integer in " + to_string(range);
  if (!v.is_number()) fail(source, expected);
  const double d = v.get<double>();
  if (!range.contains(d)) fail(source, expected + ", not " + number_text(d));
  if (v.is_number_float() && std::floor(d) != d) fail(source, expected + ", not " + number_text(d));
  return v.is_number_float() ? static_cast<long long>(d) : v.get<long long>();
}

std::string get_string(const json& v, const std::string& source, const std::string& key) {
  if (!v.is_string()) fail(source, "'" + key + "' must be a string");
  return v.get<std::string>();
}

// A quaternion: [w, x, y, z] or a real number.
Quat get_quat(const json& v, const std::string& source, const std::string& key) {
  if (v.is_number()) return Quat(get_number(v, source, key));
  if (!v.is_array() || v.size() != 4)
    fail(source, "'" + key + "' must be a number or an array of 4 numbers [w, x, y, z]");
  return {get_number(v[0], source, key), get_number(v[1], source, key),
          get_number(v[2], source, key), get_number(v[3], source, key)};
}

template <std::size_t N>
std::array<double, N> get_array(const json& v, const std::string& source, const std::string& key) {
  if (!v.is_array() || v.size() != N)
    fail(source, "'" + key + "' must be an array of " + std::to_string(N) + " numbers");
  std::array<double, N> a{};
  for (std::size_t i = 0; i < N; ++i) a[i] = get_number(v[i], source, key);
  return a;
}

json quat_json(const Quat& q) { return json::array({q.w, q.x, q.y, q.z}); }

bool is_identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char ch : s)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_')) return false;
  return true;
}

Method parse_method(const std::string& s, const std::string& source) {
  if (s == "escape") return Method::kEscape;
  if (s == "cutoff" || s == "cut-off") return Method::kCutoff;
  fail(source, "'method' must be \"escape\" or \"cutoff\", not \"" + s + "\"");
}

Mode parse_mode(const std::string& s, const std::string& source) {
  if (s == "julia") return Mode::kJulia;
  if (s == "mandelbrot") return Mode::kMandelbrot;
  fail(source, "'mode' must be \"julia\" or \"mandelbrot\", not \"" + s + "\"");
}

ColorMode parse_color(const std::string& s, const std::string& source) {
  if (s == "none") return ColorMode::kNone;
  if (s == "iterations") return ColorMode::kIterations;
  if (s == "basin") return ColorMode::kBasin;
  fail(source, "'mesh.color' must be \"none\", \"iterations\" or \"basin\", not \"" + s + "\"");
}

Decimation parse_decimation(const std::string& s, const std::string& source) {
  if (const auto d = decimation_named(s)) return *d;
  fail(source, "'mesh.decimate' must be \"fast\" or \"quality\", not \"" + s + "\"");
}

Quat axis_quat(char axis) {
  switch (axis) {
    case 'r':
      return {1, 0, 0, 0};
    case 'm':
      return {0, 1, 0, 0};
    case 'n':
      return {0, 0, 1, 0};
    default:
      return {0, 0, 0, 1};
  }
}

double dot4(const Quat& a, const Quat& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }

// The range of a parameter-file key ("bailout", "mesh.faces", "constants.c", ...).
const ValueRange& range_of(const std::string& key) {
  static const std::pair<const char*, const ValueRange*> kRanges[] = {
      {"iterations", &kIterationsRange},   {"bailout", &kBailoutRange},
      {"resolution", &kResolutionRange},   {"mesh.faces", &kFacesRange},
      {"mesh.max_error", &kMaxErrorRange}, {"mesh.min_component", &kMinComponentRange},
      {"print.size_mm", &kLengthMmRange},  {"print.min_thickness_mm", &kLengthMmRange}};
  for (const auto& [name, range] : kRanges)
    if (key == name) return *range;
  return kCoordinateRange;  // bounds, slice, constants, start and clip planes
}

}  // namespace

Slice::General Slice::resolved() const {
  if (general) return *general;
  General g;
  std::string rest = "rmnp";
  for (int a = 0; a < 3 && a < static_cast<int>(axes.size()); ++a) {
    g.directions[a] = axis_quat(axes[a]);
    const auto pos = rest.find(axes[a]);
    if (pos != std::string::npos) rest.erase(pos, 1);
  }
  if (rest.size() == 1) g.origin = fixed * axis_quat(rest[0]);
  return g;
}

const Quat* Params::constant(const std::string& name) const {
  for (const auto& [n, v] : constants)
    if (n == name) return &v;
  return nullptr;
}

void Params::set_constant(const std::string& name, const Quat& value) {
  for (auto& [n, v] : constants)
    if (n == name) {
      v = value;
      return;
    }
  constants.emplace_back(name, value);
}

const char* to_string(Method m) { return m == Method::kEscape ? "escape" : "cutoff"; }
const char* to_string(Mode m) { return m == Mode::kJulia ? "julia" : "mandelbrot"; }
const char* to_string(Decimation d) { return d == Decimation::kQuality ? "quality" : "fast"; }

std::optional<Decimation> decimation_named(const std::string& name) {
  for (Decimation d : {Decimation::kFast, Decimation::kQuality})
    if (name == to_string(d)) return d;
  return std::nullopt;
}

const char* to_string(ColorMode m) {
  return m == ColorMode::kNone ? "none" : m == ColorMode::kIterations ? "iterations" : "basin";
}

std::string to_string(const ValueRange& range) {
  return number_text(range.min) + ".." + number_text(range.max);
}

void validate(const Params& p) { detail::validate_and_compile(p); }

Formula detail::validate_and_compile(const Params& p) {
  const std::string src = "parameters";
  check_range(p.iterations, kIterationsRange, src, "iterations");
  check_range(p.bailout, kBailoutRange, src, "bailout");
  check_range(p.resolution, kResolutionRange, src, "resolution");
  for (int a = 0; a < 3; ++a) {
    check_range(p.bounds.min[a], kCoordinateRange, src, "bounds.min");
    check_range(p.bounds.max[a], kCoordinateRange, src, "bounds.max");
    if (!(p.bounds.min[a] < p.bounds.max[a]))
      fail(src, std::string("'bounds' min must be < max on every axis (axis ") + "xyz"[a] + ": " +
                    std::to_string(p.bounds.min[a]) + " >= " + std::to_string(p.bounds.max[a]) +
                    ")");
  }
  {
    const double ext[3] = {p.bounds.max[0] - p.bounds.min[0], p.bounds.max[1] - p.bounds.min[1],
                           p.bounds.max[2] - p.bounds.min[2]};
    const double longest = std::max({ext[0], ext[1], ext[2]});
    for (double e : ext)
      if (e / longest * p.resolution < 1.0)
        fail(src, "'bounds' is too flat for the resolution: every side needs at least one voxel");
  }
  if (p.slice.general) {
    const auto& g = *p.slice.general;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const double d = dot4(g.directions[a], g.directions[b]);
        if (!(std::abs(d - (a == b ? 1.0 : 0.0)) <= 1e-9))  // NaN fails too
          fail(src, "'slice.directions' must be three orthonormal 4D vectors");
      }
    check_range(g.origin, kCoordinateRange, src, "slice.origin");
  } else {
    const std::string& ax = p.slice.axes;
    if (ax.size() != 3 || ax.find_first_not_of("rmnp") != std::string::npos || ax[0] == ax[1] ||
        ax[0] == ax[2] || ax[1] == ax[2])
      fail(src,
           "'slice.axes' must be three distinct letters of \"rmnp\" (r=real, m=i, n=j, "
           "p=k), not \"" +
               ax + "\"");
    check_range(p.slice.fixed, kCoordinateRange, src, "slice.fixed");
  }
  std::vector<std::string> names;
  for (const auto& [name, value] : p.constants) {
    if (!is_identifier(name)) fail(src, "constant name '" + name + "' is not an identifier");
    if (name == "h" || name == "i" || name == "j" || name == "k")
      fail(src, "constant name '" + name + "' is reserved (h is the variable, i j k the units)");
    check_range(value, kCoordinateRange, src, "constants." + name);
    names.push_back(name);
  }
  if (p.mode == Mode::kMandelbrot && !p.constant("c")) names.push_back("c");
  check_range(p.start, kCoordinateRange, src, "start");
  Formula formula = Formula::compile(p.formula, names);  // throws InvalidInput naming the column
  for (const auto& c : p.mesh.clip) {
    for (double v : {c.normal[0], c.normal[1], c.normal[2], c.d})
      check_range(v, kCoordinateRange, src, "mesh.clip");
    if (c.normal[0] == 0 && c.normal[1] == 0 && c.normal[2] == 0)
      fail(src, "'mesh.clip' planes need a non-zero normal");
  }
  if (p.mesh.faces) check_range(static_cast<double>(*p.mesh.faces), kFacesRange, src, "mesh.faces");
  if (p.mesh.max_error) check_range(*p.mesh.max_error, kMaxErrorRange, src, "mesh.max_error");
  if (p.mesh.min_component)
    check_range(*p.mesh.min_component, kMinComponentRange, src, "mesh.min_component");
  if (p.print.size_mm) check_range(*p.print.size_mm, kLengthMmRange, src, "print.size_mm");
  if (p.print.min_thickness_mm)
    check_range(*p.print.min_thickness_mm, kLengthMmRange, src, "print.min_thickness_mm");
  return formula;
}

Params parse_params(const std::string& json_text, const std::string& source) {
  json j;
  std::string key;  // the key whose value is being read, for the message of a number overflow
  try {
    std::vector<std::string> path;
    j = json::parse(json_text, [&](int depth, json::parse_event_t event, json& parsed) {
      if (event == json::parse_event_t::key) {
        path.resize(depth > 0 ? depth - 1 : 0);
        path.push_back(parsed.get<std::string>());
        key.clear();
        for (const auto& k : path) key += (key.empty() ? "" : ".") + k;
      }
      return true;
    });
  } catch (const json::parse_error& e) {
    // nlohmann's message carries line and column.
    fail(source, std::string("not valid JSON: ") + e.what());
  } catch (const json::out_of_range&) {
    // A number beyond double's range (1e400) stops the parser itself.
    fail(source, "'" + key + "' must be in " + to_string(range_of(key)) +
                     ", not a number beyond the range of a double");
  }
  if (!j.is_object()) fail(source, "a parameter file is a JSON object");
  check_keys(j,
             {"description", "formula", "constants", "mode", "method", "iterations", "bailout",
              "start", "slice", "bounds", "resolution", "mesh", "print"},
             source, "");
  Params p;
  if (j.contains("description"))
    p.description = get_string(j["description"], source, "description");
  if (j.contains("formula")) p.formula = get_string(j["formula"], source, "formula");
  if (j.contains("constants")) {
    const json& c = j["constants"];
    if (!c.is_object()) fail(source, "'constants' must be an object of name: [w, x, y, z]");
    for (const auto& item : c.items())
      p.set_constant(item.key(), get_quat(item.value(), source, "constants." + item.key()));
  }
  if (j.contains("mode")) p.mode = parse_mode(get_string(j["mode"], source, "mode"), source);
  if (j.contains("method"))
    p.method = parse_method(get_string(j["method"], source, "method"), source);
  if (j.contains("iterations"))
    p.iterations =
        static_cast<int>(get_integer(j["iterations"], source, "iterations", kIterationsRange));
  if (j.contains("bailout")) p.bailout = get_number(j["bailout"], source, "bailout");
  if (j.contains("start")) p.start = get_quat(j["start"], source, "start");
  if (j.contains("slice")) {
    const json& s = j["slice"];
    if (!s.is_object()) fail(source, "'slice' must be an object");
    check_keys(s, {"axes", "fixed", "origin", "directions"}, source, "slice.");
    if (s.contains("axes")) p.slice.axes = get_string(s["axes"], source, "slice.axes");
    if (s.contains("fixed")) p.slice.fixed = get_number(s["fixed"], source, "slice.fixed");
    if (s.contains("origin") || s.contains("directions")) {
      if (!s.contains("origin") || !s.contains("directions"))
        fail(source, "a general slice needs both 'slice.origin' and 'slice.directions'");
      Slice::General g;
      g.origin = get_quat(s["origin"], source, "slice.origin");
      const json& d = s["directions"];
      if (!d.is_array() || d.size() != 3)
        fail(source, "'slice.directions' must be an array of three [w, x, y, z]");
      for (int a = 0; a < 3; ++a) g.directions[a] = get_quat(d[a], source, "slice.directions");
      p.slice.general = g;
    }
  }
  if (j.contains("bounds")) {
    const json& b = j["bounds"];
    if (!b.is_object()) fail(source, "'bounds' must be an object {\"min\": [...], \"max\": [...]}");
    check_keys(b, {"min", "max"}, source, "bounds.");
    if (b.contains("min")) p.bounds.min = get_array<3>(b["min"], source, "bounds.min");
    if (b.contains("max")) p.bounds.max = get_array<3>(b["max"], source, "bounds.max");
  }
  if (j.contains("resolution"))
    p.resolution =
        static_cast<int>(get_integer(j["resolution"], source, "resolution", kResolutionRange));
  if (j.contains("mesh")) {
    const json& m = j["mesh"];
    if (!m.is_object()) fail(source, "'mesh' must be an object");
    check_keys(m, {"color", "faces", "max_error", "decimate", "min_component", "clip"}, source,
               "mesh.");
    if (m.contains("color"))
      p.mesh.color = parse_color(get_string(m["color"], source, "mesh.color"), source);
    if (m.contains("faces") && !m["faces"].is_null())
      p.mesh.faces = get_integer(m["faces"], source, "mesh.faces", kFacesRange);
    if (m.contains("max_error") && !m["max_error"].is_null())
      p.mesh.max_error = get_number(m["max_error"], source, "mesh.max_error");
    if (m.contains("decimate"))
      p.mesh.decimate =
          parse_decimation(get_string(m["decimate"], source, "mesh.decimate"), source);
    if (m.contains("min_component") && !m["min_component"].is_null())
      p.mesh.min_component = get_number(m["min_component"], source, "mesh.min_component");
    if (m.contains("clip")) {
      if (!m["clip"].is_array()) fail(source, "'mesh.clip' must be an array of [nx, ny, nz, d]");
      for (const json& c : m["clip"]) {
        const auto a = get_array<4>(c, source, "mesh.clip");
        p.mesh.clip.push_back({{a[0], a[1], a[2]}, a[3]});
      }
    }
  }
  if (j.contains("print")) {
    const json& pr = j["print"];
    if (!pr.is_object()) fail(source, "'print' must be an object");
    check_keys(pr, {"size_mm", "min_thickness_mm", "check"}, source, "print.");
    if (pr.contains("size_mm") && !pr["size_mm"].is_null())
      p.print.size_mm = get_number(pr["size_mm"], source, "print.size_mm");
    if (pr.contains("min_thickness_mm") && !pr["min_thickness_mm"].is_null())
      p.print.min_thickness_mm =
          get_number(pr["min_thickness_mm"], source, "print.min_thickness_mm");
    if (pr.contains("check")) {
      if (!pr["check"].is_boolean()) fail(source, "'print.check' must be true or false");
      p.print.check = pr["check"].get<bool>();
    }
  }
  try {
    validate(p);
  } catch (const InvalidInput& e) {
    std::string what = e.what();
    const std::string prefix = "parameters: ";
    if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
    fail(source, what);
  }
  return p;
}

Params read_params_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidInput(path + ": cannot read the parameter file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_params(text.str(), path);
}

std::string params_to_json(const Params& p, bool pretty) {
  json j = json::object();
  if (!p.description.empty()) j["description"] = p.description;
  j["formula"] = p.formula;
  json c = json::object();
  for (const auto& [name, value] : p.constants) c[name] = quat_json(value);
  j["constants"] = c;
  j["mode"] = to_string(p.mode);
  j["method"] = to_string(p.method);
  j["iterations"] = p.iterations;
  j["bailout"] = p.bailout;
  if (p.mode == Mode::kMandelbrot || norm2(p.start) != 0) j["start"] = quat_json(p.start);
  json s = json::object();
  if (p.slice.general) {
    s["origin"] = quat_json(p.slice.general->origin);
    s["directions"] = json::array();
    for (const Quat& d : p.slice.general->directions) s["directions"].push_back(quat_json(d));
  } else {
    s["axes"] = p.slice.axes;
    s["fixed"] = p.slice.fixed;
  }
  j["slice"] = s;
  j["bounds"] = {{"min", p.bounds.min}, {"max", p.bounds.max}};
  j["resolution"] = p.resolution;
  json m = json::object();
  m["color"] = to_string(p.mesh.color);
  if (p.mesh.faces) m["faces"] = *p.mesh.faces;
  if (p.mesh.max_error) m["max_error"] = *p.mesh.max_error;
  // Written when not the default, so that files without it read back the same.
  if (p.mesh.decimate != Decimation::kFast) m["decimate"] = to_string(p.mesh.decimate);
  if (p.mesh.min_component) m["min_component"] = *p.mesh.min_component;
  if (!p.mesh.clip.empty()) {
    m["clip"] = json::array();
    for (const auto& cp : p.mesh.clip)
      m["clip"].push_back({cp.normal[0], cp.normal[1], cp.normal[2], cp.d});
  }
  j["mesh"] = m;
  json pr = json::object();
  if (p.print.size_mm) pr["size_mm"] = *p.print.size_mm;
  if (p.print.min_thickness_mm) pr["min_thickness_mm"] = *p.print.min_thickness_mm;
  pr["check"] = p.print.check;
  j["print"] = pr;
  return j.dump(pretty ? 2 : -1) + (pretty ? "\n" : "");
}

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const auto& [name, text] : detail::embedded_presets()) names.emplace_back(name);
  return names;
}

Params preset(const std::string& name) {
  for (const auto& [n, text] : detail::embedded_presets())
    if (name == n) return parse_params(text, "preset " + name);
  std::string list;
  for (const auto& known : preset_names()) list += (list.empty() ? "" : ", ") + known;
  throw InvalidInput("unknown preset '" + name + "' (known: " + list + ")");
}

std::string preset_description(const std::string& name) { return preset(name).description; }

GridGeometry grid_geometry(const Params& params) {
  GridGeometry g;
  double longest = 0;
  for (int a = 0; a < 3; ++a)
    longest = std::max(longest, params.bounds.max[a] - params.bounds.min[a]);
  g.voxel = longest / params.resolution;
  for (int a = 0; a < 3; ++a) {
    // Points sit at the centres of the voxels, so no point lies on a wall of the box and caps
    // never pass through grid points.
    g.origin[a] = params.bounds.min[a] + 0.5 * g.voxel;
    const double cells = (params.bounds.max[a] - params.bounds.min[a]) / g.voxel;
    // Points strictly inside the box: (i + 1/2) * voxel < extent.
    g.points[a] = std::max(1, static_cast<int>(std::ceil(cells - 0.5 - 1e-9)));
  }
  return g;
}

}  // namespace qjulia
