#pragma once
// Command-line plumbing shared by the subcommands of `qjulia`.
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/field/params.h"

namespace qjulia::cli {

/// One option a subcommand accepts: "--name" with or without a value.
struct OptionSpec {
  std::string name;  ///< without the leading dashes
  bool takes_value = true;
};

/// Options and positional arguments of one subcommand, in the order given.
struct ParsedArgs {
  std::vector<std::string> positional;
  std::vector<std::pair<std::string, std::string>> options;

  bool has(const std::string& name) const;
  /// The last value given for `name`.
  std::optional<std::string> get(const std::string& name) const;
  /// Every value given for `name`, in order (repeatable options).
  std::vector<std::string> all(const std::string& name) const;
};

/// Parses `tokens`: `--opt value` and `--opt=value` (values may start with '-'), flags, and
/// positional arguments. @throws InvalidInput for an unknown option or a missing value.
ParsedArgs parse_args(const std::vector<std::string>& tokens, const std::vector<OptionSpec>& specs,
                      const std::string& command);

/// Strict number parsing; @throws InvalidInput naming `what`.
double parse_double(const std::string& text, const std::string& what);
long long parse_int(const std::string& text, const std::string& what);
/// Comma-separated numbers; exactly `count` of them unless count is 0.
std::vector<double> parse_doubles(const std::string& text, std::size_t count,
                                  const std::string& what);
/// A length in millimetres: "80", "80mm", "8cm", "0.08m". @throws InvalidInput.
double parse_length_mm(const std::string& text, const std::string& what);

/// The options shared by every command that makes a mesh from parameters (mesh, compare,
/// bench): the parameter file, --preset and the flags that override it.
std::vector<OptionSpec> param_option_specs();
/// Builds the parameters from the parameter file / preset given in `args` (the positional
/// `params_file` if non-empty) and applies the override flags. Validates the result.
/// @throws InvalidInput.
Params params_from_args(const ParsedArgs& args, const std::string& params_file);

}  // namespace qjulia::cli
