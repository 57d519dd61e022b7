#pragma once
// Command-line plumbing shared by the subcommands of `qjulia`: argument parsing, numbers with
// their ranges, the parameter flags, the thread limit.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "qjulia/field/params.h"
#include "qjulia/mesh/compare.h"

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
  /// The file an output option names: one run writes one such file, so two different values
  /// are refused rather than the first one dropped. @throws InvalidInput naming both.
  std::optional<std::string> output_file(const std::string& name) const;
};

/// Parses `tokens`: `--opt value` and `--opt=value` (values may start with '-'), flags, and
/// positional arguments. @throws InvalidInput for an unknown option or a missing value.
ParsedArgs parse_args(const std::vector<std::string>& tokens, const std::vector<OptionSpec>& specs,
                      const std::string& command);

/// A number in `range`. @throws InvalidInput naming `what` and the range when `text` is not a
/// number or lies outside (nan, inf and 1e400 always do).
double parse_double(const std::string& text, const std::string& what, const ValueRange& range);
/// An integer in `range`. @throws InvalidInput naming `what` and the range.
long long parse_int(const std::string& text, const std::string& what, const ValueRange& range);
/// Comma-separated numbers, each in `range`; exactly `count` of them unless count is 0.
/// @throws InvalidInput naming `what`.
std::vector<double> parse_doubles(const std::string& text, std::size_t count,
                                  const std::string& what, const ValueRange& range);
/// A length in millimetres in kLengthMmRange: "80", "80mm", "8cm", "0.08m".
/// @throws InvalidInput naming `what` and the range.
double parse_length_mm(const std::string& text, const std::string& what);

/// The options shared by every command that makes a mesh from parameters (mesh, compare,
/// params): the parameter file, --preset and the flags that override it.
std::vector<OptionSpec> param_option_specs();
/// Builds the parameters from the parameter file / preset given in `args` (the positional
/// `params_file` if non-empty) and applies the override flags. Validates the result.
/// @throws InvalidInput.
Params params_from_args(const ParsedArgs& args, const std::string& params_file);

/// Accepted --threads.
inline constexpr ValueRange kThreadsRange{1, 1024};
/// Accepted --samples of compare and experiment.
inline constexpr ValueRange kSamplesRange{0, double(kMostCompareSamples)};

/// The --threads of a command, applied to every stage it runs: while this object lives, TBB
/// uses at most that many threads (no limit without the option). The one place --threads is
/// read. @throws InvalidInput naming --threads and its range.
class ThreadLimit {
 public:
  explicit ThreadLimit(const ParsedArgs& args);
  /// The threads the command runs on: the option, else TBB's default (all cores).
  int threads() const { return threads_; }

 private:
  std::shared_ptr<void> control_;  // a tbb::global_control; TBB stays out of this header
  int threads_ = 0;
};

/// --max-memory SIZE (qjulia::parse_memory_size: at least 1M), unset without the option.
/// @throws InvalidInput naming --max-memory.
std::optional<std::size_t> max_memory_from_args(const ParsedArgs& args);

}  // namespace qjulia::cli
