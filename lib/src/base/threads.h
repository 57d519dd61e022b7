#pragma once
/// @file threads.h
/// How many threads the library's parallel loops may run on.
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>

namespace qjulia::detail {

/// The threads that may run a parallel loop here: the arena's size, lowered by a global_control
/// limit such as --threads 1 (which the arena's size ignores).
inline std::size_t threads_that_may_run() {
  return std::min<std::size_t>(
      static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency())),
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace qjulia::detail
