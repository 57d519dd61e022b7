#include "cli.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <cctype>
#include <charconv>
#include <cstdlib>

#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia::cli {

bool ParsedArgs::has(const std::string& name) const {
  for (const auto& [n, v] : options)
    if (n == name) return true;
  return false;
}

std::optional<std::string> ParsedArgs::get(const std::string& name) const {
  std::optional<std::string> out;
  for (const auto& [n, v] : options)
    if (n == name) out = v;
  return out;
}

std::vector<std::string> ParsedArgs::all(const std::string& name) const {
  std::vector<std::string> out;
  for (const auto& [n, v] : options)
    if (n == name) out.push_back(v);
  return out;
}

std::optional<std::string> ParsedArgs::output_file(const std::string& name) const {
  std::optional<std::string> out;
  for (const auto& [n, v] : options) {
    if (n != name) continue;
    if (out && *out != v)
      throw InvalidInput("--" + name + (name == "output" ? " (-o)" : "") + " is given twice ('" +
                         *out + "' and '" + v + "'): a run writes one, give it once");
    out = v;
  }
  return out;
}

ParsedArgs parse_args(const std::vector<std::string>& tokens, const std::vector<OptionSpec>& specs,
                      const std::string& command) {
  ParsedArgs out;
  bool only_positional = false;
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const std::string& tok = tokens[i];
    if (only_positional || tok.size() < 2 || tok[0] != '-' ||
        (tok[1] != '-' && tok != "-o" && tok != "-h")) {
      out.positional.push_back(tok);
      continue;
    }
    if (tok == "--") {
      only_positional = true;
      continue;
    }
    std::string name = tok == "-o" ? "output" : tok == "-h" ? "help" : tok.substr(2);
    std::optional<std::string> value;
    if (const auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    const OptionSpec* spec = nullptr;
    for (const auto& s : specs)
      if (s.name == name) spec = &s;
    if (!spec) throw InvalidInput("unknown option '--" + name + "' for 'qjulia " + command + "'");
    if (spec->takes_value) {
      if (!value) {
        if (i + 1 >= tokens.size()) throw InvalidInput("option '--" + name + "' needs a value");
        value = tokens[++i];  // may start with '-', as bounds often do
      }
    } else if (value) {
      throw InvalidInput("option '--" + name + "' takes no value");
    }
    out.options.emplace_back(name, value.value_or(""));
  }
  return out;
}

namespace {

[[noreturn]] void out_of_range(const std::string& what, const char* kind, const ValueRange& range,
                               const std::string& text) {
  throw InvalidInput(what + ": expected " + kind + " in " + to_string(range) + ", not '" + text +
                     "'");
}

// strtod over all of `text` (no leading blanks); nullopt when it is not a number.
std::optional<double> to_double(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return std::nullopt;
  const char* begin = text.c_str();
  char* end = nullptr;
  const double d = std::strtod(begin, &end);  // 1e400 gives inf, which no range holds
  if (end != begin + text.size()) return std::nullopt;
  return d;
}

}  // namespace

double parse_double(const std::string& text, const std::string& what, const ValueRange& range) {
  const auto d = to_double(text);
  if (!d || !range.contains(*d)) out_of_range(what, "a number", range, text);
  return *d;
}

long long parse_int(const std::string& text, const std::string& what, const ValueRange& range) {
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size() ||
      !range.contains(static_cast<double>(v)))
    out_of_range(what, "an integer", range, text);
  return v;
}

std::vector<double> parse_doubles(const std::string& text, std::size_t count,
                                  const std::string& what, const ValueRange& range) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    out.push_back(parse_double(text.substr(start, comma - start), what, range));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (count && out.size() != count)
    throw InvalidInput(what + ": expected " + std::to_string(count) +
                       " comma-separated numbers, not '" + text + "'");
  return out;
}

double parse_length_mm(const std::string& text, const std::string& what) {
  std::string number = text;
  double factor = 1.0;
  auto ends_with = [&](const char* suffix) {
    const std::string s(suffix);
    return number.size() > s.size() && number.compare(number.size() - s.size(), s.size(), s) == 0;
  };
  if (ends_with("mm")) {
    number.resize(number.size() - 2);
  } else if (ends_with("cm")) {
    number.resize(number.size() - 2);
    factor = 10.0;
  } else if (ends_with("m")) {
    number.resize(number.size() - 1);
    factor = 1000.0;
  }
  const auto v = to_double(number);
  if (!v || !kLengthMmRange.contains(*v * factor))
    throw InvalidInput(what + ": expected a length in " + to_string(kLengthMmRange) +
                       " mm (80, 80mm, 8cm, 0.08m), not '" + text + "'");
  return *v * factor;
}

ThreadLimit::ThreadLimit(const ParsedArgs& args) : threads_(tbb::info::default_concurrency()) {
  if (auto t = args.get("threads")) {
    threads_ = static_cast<int>(parse_int(*t, "--threads", kThreadsRange));
    control_ = std::make_shared<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                     static_cast<std::size_t>(threads_));
  }
}

std::optional<std::size_t> max_memory_from_args(const ParsedArgs& args) {
  if (auto v = args.get("max-memory")) return parse_memory_size(*v, "--max-memory");
  return std::nullopt;
}

std::vector<OptionSpec> param_option_specs() {
  return {{"preset"},      {"formula"},       {"const"},      {"mode"},   {"method"},
          {"iterations"},  {"bailout"},       {"resolution"}, {"bounds"}, {"axes"},
          {"fixed"},       {"start"},         {"color"},      {"faces"},  {"max-error"},
          {"decimate"},    {"min-component"}, {"clip"},       {"size"},   {"min-thickness"},
          {"check", false}};
}

Params params_from_args(const ParsedArgs& args, const std::string& params_file) {
  const auto preset_name = args.get("preset");
  if (!params_file.empty() && preset_name)
    throw InvalidInput("give either a parameter file or --preset, not both");
  Params p = !params_file.empty() ? read_params_from(params_file)
             : preset_name        ? preset(*preset_name)
                                  : preset("newton-cubic");
  if (auto v = args.get("formula")) p.formula = *v;
  for (const std::string& c : args.all("const")) {
    const auto eq = c.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InvalidInput("--const: expected NAME=w,x,y,z (or NAME=real), not '" + c + "'");
    const auto values =
        parse_doubles(c.substr(eq + 1), 0, "--const " + c.substr(0, eq), kCoordinateRange);
    if (values.size() != 1 && values.size() != 4)
      throw InvalidInput("--const: expected NAME=w,x,y,z (or NAME=real), not '" + c + "'");
    p.set_constant(c.substr(0, eq), values.size() == 1
                                        ? Quat(values[0])
                                        : Quat{values[0], values[1], values[2], values[3]});
  }
  if (auto v = args.get("mode")) {
    if (*v == "julia")
      p.mode = Mode::kJulia;
    else if (*v == "mandelbrot")
      p.mode = Mode::kMandelbrot;
    else
      throw InvalidInput("--mode: expected julia or mandelbrot, not '" + *v + "'");
  }
  if (auto v = args.get("method")) {
    if (*v == "escape")
      p.method = Method::kEscape;
    else if (*v == "cutoff" || *v == "cut-off")
      p.method = Method::kCutoff;
    else
      throw InvalidInput("--method: expected escape or cutoff, not '" + *v + "'");
  }
  if (auto v = args.get("iterations"))
    p.iterations = static_cast<int>(parse_int(*v, "--iterations", kIterationsRange));
  if (auto v = args.get("bailout")) p.bailout = parse_double(*v, "--bailout", kBailoutRange);
  if (auto v = args.get("resolution"))
    p.resolution = static_cast<int>(parse_int(*v, "--resolution", kResolutionRange));
  if (auto v = args.get("bounds")) {
    const auto b =
        parse_doubles(*v, 6, "--bounds (xmin,ymin,zmin,xmax,ymax,zmax)", kCoordinateRange);
    p.bounds.min = {b[0], b[1], b[2]};
    p.bounds.max = {b[3], b[4], b[5]};
  }
  if (auto v = args.get("axes")) {
    p.slice.general.reset();
    p.slice.axes = *v;
  }
  if (auto v = args.get("fixed")) {
    p.slice.general.reset();
    p.slice.fixed = parse_double(*v, "--fixed", kCoordinateRange);
  }
  if (auto v = args.get("start")) {
    const auto s = parse_doubles(*v, 4, "--start (w,x,y,z)", kCoordinateRange);
    p.start = {s[0], s[1], s[2], s[3]};
  }
  if (auto v = args.get("color")) {
    if (*v == "none")
      p.mesh.color = ColorMode::kNone;
    else if (*v == "iterations")
      p.mesh.color = ColorMode::kIterations;
    else if (*v == "basin")
      p.mesh.color = ColorMode::kBasin;
    else
      throw InvalidInput("--color: expected iterations, basin or none, not '" + *v + "'");
  }
  if (auto v = args.get("faces")) p.mesh.faces = parse_int(*v, "--faces", kFacesRange);
  if (auto v = args.get("max-error"))
    p.mesh.max_error = parse_double(*v, "--max-error", kMaxErrorRange);
  if (auto v = args.get("decimate")) {
    const auto d = decimation_named(*v);
    if (!d) throw InvalidInput("--decimate: expected fast or quality, not '" + *v + "'");
    p.mesh.decimate = *d;
  }
  if (auto v = args.get("min-component"))
    p.mesh.min_component = parse_double(*v, "--min-component", kMinComponentRange);
  for (const std::string& c : args.all("clip")) {
    const auto v = parse_doubles(c, 4, "--clip (nx,ny,nz,d)", kCoordinateRange);
    p.mesh.clip.push_back({{v[0], v[1], v[2]}, v[3]});
  }
  if (auto v = args.get("size")) p.print.size_mm = parse_length_mm(*v, "--size");
  if (auto v = args.get("min-thickness"))
    p.print.min_thickness_mm = parse_length_mm(*v, "--min-thickness");
  if (args.has("check")) p.print.check = true;
  validate(p);
  return p;
}

}  // namespace qjulia::cli
