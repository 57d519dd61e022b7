#include "base/weld.h"

#include <cstring>
#include <vector>

namespace qjulia::detail {

std::size_t weld_table_slots(std::size_t n) {
  std::size_t cap = 16;
  while (cap < n + n / 2) cap <<= 1;
  return cap;
}

std::size_t number_positions(const std::array<float, 3>* p, std::size_t n, std::uint32_t* index) {
  // Open addressing on the bit patterns: several times faster than std::unordered_map on
  // millions of positions. A slot holds the first position of its group.
  const std::size_t cap = weld_table_slots(n);
  std::vector<std::uint32_t> table(cap, UINT32_MAX);
  auto key_of = [](const std::array<float, 3>& q) {
    std::array<std::uint32_t, 3> k;
    for (int i = 0; i < 3; ++i) {
      const float f = q[i] + 0.0f;  // -0 and +0 are one position
      std::memcpy(&k[i], &f, 4);
    }
    return k;
  };
  std::size_t distinct = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto k = key_of(p[i]);
    std::uint64_t h = (std::uint64_t(k[0]) * 0x9E3779B97F4A7C15ull) ^
                      (std::uint64_t(k[1]) * 0xC2B2AE3D27D4EB4Full) ^
                      (std::uint64_t(k[2]) * 0x165667B19E3779F9ull);
    h ^= h >> 29;
    for (std::size_t slot = h & (cap - 1);; slot = (slot + 1) & (cap - 1)) {
      const std::uint32_t first = table[slot];
      if (first == UINT32_MAX) {
        table[slot] = static_cast<std::uint32_t>(i);
        index[i] = static_cast<std::uint32_t>(distinct++);
        break;
      }
      if (key_of(p[first]) == k) {
        index[i] = index[first];
        break;
      }
    }
  }
  return distinct;
}

void first_positions(const std::array<float, 3>* p, std::size_t n, const std::uint32_t* index,
                     std::array<float, 3>* out) {
  // Numbers go in the order of first occurrence: position i is the first of its number when
  // that number is the next one.
  std::size_t next = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (index[i] == next) out[next++] = {p[i][0] + 0.0f, p[i][1] + 0.0f, p[i][2] + 0.0f};
}

}  // namespace qjulia::detail
