#pragma once
// Large vectors whose pages are first touched by all threads: a fresh page costs far more than
// writing it (the kernel clears it, and a virtual machine's host may have to back it), and a
// vector's own resize() touches them all on one thread.
#include <sys/mman.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "qjulia/base/memory.h"

namespace qjulia::detail {

/// Resizes `v` to `n` value-initialised elements, its new storage's pages touched in parallel.
template <class T>
void resize_first_touched(std::vector<T>& v, std::size_t n) {
  static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_default_constructible_v<T>);
  if (n <= v.size()) {
    v.resize(n);
    return;
  }
  v.reserve(n);
  // The storage is the allocator's and holds no live objects beyond size(): its bytes may be
  // written before resize() constructs the elements there.
  char* const from = reinterpret_cast<char*>(v.data() + v.size());
  const std::size_t bytes = (n - v.size()) * sizeof(T);
  constexpr std::size_t kBlock = std::size_t{1} << 21;
  // Huge pages where the kernel offers them on request and they pay (huge_page_choice()): one
  // fault per 2 MiB instead of 512.
  const std::uintptr_t first =
      (reinterpret_cast<std::uintptr_t>(from) + kBlock - 1) & ~(kBlock - 1);
  const std::uintptr_t last = (reinterpret_cast<std::uintptr_t>(from) + bytes) & ~(kBlock - 1);
  if (last > first)
    ::madvise(reinterpret_cast<void*>(first), last - first,
              huge_page_choice().on ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
  if (bytes >= 2 * kBlock)
    tbb::parallel_for(std::size_t{0}, (bytes + kBlock - 1) / kBlock, [&](std::size_t b) {
      std::memset(from + b * kBlock, 0, std::min(kBlock, bytes - b * kBlock));
    });
  v.resize(n);
}

}  // namespace qjulia::detail
