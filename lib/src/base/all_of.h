#pragma once
// A check over every vertex or face of a mesh, in parallel: the passes that run on every mesh
// written.
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cstddef>

namespace qjulia::detail {

/// Whether holds(i) for every i in [0, n). Each block of items is tested whole, without a branch
/// on the outcome, so the loop vectorises; a failure is looked for (and described) afterwards.
template <class Holds>
bool all_of_parallel(std::size_t n, const Holds& holds) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, std::size_t{1} << 16), true,
      [&](const tbb::blocked_range<std::size_t>& r, bool ok) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) ok &= holds(i);
        return ok;
      },
      [](bool a, bool b) { return a && b; });
}

}  // namespace qjulia::detail
