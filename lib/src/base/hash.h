#pragma once
/// @file hash.h
/// The one 64-bit mixer (splitmix64's finaliser): compare()'s counter-based random samples and
/// the content hash that names a 3MF file's objects.
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace qjulia::detail {

/// splitmix64: a bijection of 64-bit words whose outputs for consecutive inputs look random.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Folds `n` bytes at `p` into the hash `h`, eight bytes at a time (the length included, so
/// runs of zeros of different lengths differ). The result depends only on the bytes.
inline std::uint64_t hash_bytes(std::uint64_t h, const void* p, std::size_t n) {
  const auto* b = static_cast<const unsigned char*>(p);
  h = splitmix64(h ^ n);
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, b + i, 8);
    h = splitmix64(h ^ w);
  }
  if (i < n) {
    std::uint64_t w = 0;
    std::memcpy(&w, b + i, n - i);
    h = splitmix64(h ^ w);
  }
  return h;
}

}  // namespace qjulia::detail
