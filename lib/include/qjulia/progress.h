#pragma once
/// @file progress.h
/// The progress callback every long stage takes.
#include <functional>

namespace qjulia {

/// Called with the fraction done in [0, 1]; return false to cancel (the stage then throws
/// Cancelled). May be called from any thread, but never concurrently.
using ProgressFn = std::function<bool(double)>;

}  // namespace qjulia
