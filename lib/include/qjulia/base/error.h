#pragma once
/// @file error.h
/// Exceptions shared by every stage.
#include <stdexcept>
#include <string>

namespace qjulia {

/// Thrown when input (a parameter, an option, a formula, a file) is invalid. The message names
/// the field and the accepted range. The CLI prints it on one line and exits with code 2.
class InvalidInput : public std::invalid_argument {
 public:
  explicit InvalidInput(const std::string& what) : std::invalid_argument(what) {}
};

/// Thrown when a job would need more memory than it may use (the memory estimate of a run, or
/// an input too large to load). The message gives the estimate, the limit and what fits (e.g.
/// the largest resolution). An InvalidInput: the CLI exits 2, Python raises MemoryError.
class TooLarge : public InvalidInput {
 public:
  explicit TooLarge(const std::string& what) : InvalidInput(what) {}
};

/// Thrown when a progress callback or a CancelToken asked to stop.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace qjulia
