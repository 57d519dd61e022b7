#pragma once
/// @file records.h
/// Fixed-size records formatted in parallel straight into a file's stage (the binary PLY and
/// STL writers).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>

#include "qjulia/base/atomic_file.h"

namespace qjulia::detail {

/// Writes records 0 .. count-1 of `record` bytes each: put(p, i) fills record i at p. The
/// records that fit in the stage are made in parallel, so the file's bytes do not depend on the
/// threads.
template <class Put>
void put_records(BufferedWriter& out, std::size_t count, std::size_t record, const Put& put) {
  constexpr std::size_t kGrain = 8192;
  for (std::size_t first = 0; first < count;) {
    char* const p = out.reserve(record);
    const std::size_t n = std::min(count - first, out.room() / record);
    if (n < 2 * kGrain) {
      for (std::size_t i = 0; i < n; ++i) put(p + i * record, first + i);
    } else {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i)
                            put(p + i * record, first + i);
                        });
    }
    out.advance(n * record);
    first += n;
  }
}

}  // namespace qjulia::detail
