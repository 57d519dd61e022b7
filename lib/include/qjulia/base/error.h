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

/// Thrown when a progress callback asked to stop.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace qjulia
