#pragma once
// Large vectors whose pages are asked for by all threads, a block at a time: a fresh page costs
// far more than writing it (base/pages.h), and a vector's own resize() faults them in one at a
// time on one thread.
#include <tbb/parallel_for.h>

#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "base/pages.h"

namespace qjulia::detail {

/// Resizes `v` to `n` value-initialised elements, its new storage's pages made present in
/// parallel first.
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
  if (last > first) advise_huge_pages(reinterpret_cast<void*>(first), last - first);
  // The pages asked for a block at a time (written where the kernel cannot), in parallel.
  if (bytes >= 2 * kBlock)
    tbb::parallel_for(std::size_t{0}, (bytes + kBlock - 1) / kBlock, [&](std::size_t b) {
      const std::size_t size = std::min(kBlock, bytes - b * kBlock);
      if (!populate_pages(from + b * kBlock, size)) std::memset(from + b * kBlock, 0, size);
    });
  else
    populate_pages(from, bytes);
  v.resize(n);
}

}  // namespace qjulia::detail
