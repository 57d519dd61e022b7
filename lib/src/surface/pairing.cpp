#include "surface/pairing.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace qjulia::detail {
namespace {

// Bricks with at most this many slots count in a matrix (2 kMatrixSlots^2 bytes a thread), the
// others in a hash table.
constexpr std::size_t kMatrixSlots = 1024;

// The counts of one edge {lo < hi}: its faces' half-edges lo -> hi (up) and hi -> lo (down), and
// its listings either way.
void judge(std::size_t up, std::size_t down, std::size_t listed_up, std::size_t listed_down,
           HalfEdgePairing& out) {
  if (up == 1 && down == 1 && listed_up == 0 && listed_down == 0) {
    ++out.edges;
    return;
  }
  // A half-edge is right only as the edge's one half-edge, listed once in its direction; a
  // listing only with that one half-edge.
  if (!(up == 1 && listed_up == 1 && down == 0 && listed_down == 0)) out.problems += up;
  if (!(down == 1 && listed_down == 1 && up == 0 && listed_up == 0)) out.problems += down;
  if (!(up == 1 && listed_up == 1)) out.problems += listed_up;
  if (!(down == 1 && listed_down == 1)) out.problems += listed_down;
}

// Calls add(a, b, kind) for each half-edge (kind 0) and listing (kind 2) from a to b, a != b;
// returns the half-edges and listings from a slot to itself.
template <class Add>
std::size_t each_half_edge(const std::uint32_t* corner, std::size_t faces,
                           const std::array<std::uint32_t, 2>* listed, std::size_t listings,
                           Add&& add) {
  std::size_t loops = 0;
  auto one = [&](std::uint32_t a, std::uint32_t b, int kind) {
    if (a == b)
      ++loops;
    else
      add(a, b, kind);
  };
  for (std::size_t f = 0; f < faces; ++f) {
    const std::uint32_t* t = corner + 3 * f;
    one(t[0], t[1], 0);
    one(t[1], t[2], 0);
    one(t[2], t[0], 0);
  }
  for (std::size_t l = 0; l < listings; ++l) one(listed[l][0], listed[l][1], 2);
  return loops;
}

// In a matrix over the slots: an entry per edge {lo < hi} with four counts of four bits (up,
// down, listed up, listed down), judged from the list of the entries touched and cleared. False
// (the matrix cleared, nothing counted) when a count would pass 15.
bool pair_in_matrix(const std::uint32_t* corner, std::size_t faces, std::size_t slots,
                    const std::array<std::uint32_t, 2>* listed, std::size_t listings,
                    HalfEdgePairing& out) {
  thread_local std::vector<std::uint16_t> count(kMatrixSlots * kMatrixSlots, 0);
  thread_local std::vector<std::uint32_t> touched;
  touched.clear();
  bool saturated = false;
  const std::size_t loops = each_half_edge(
      corner, faces, listed, listings, [&](std::uint32_t a, std::uint32_t b, int kind) {
        int shift = 4 * kind;
        if (a > b) {
          std::swap(a, b);
          shift += 4;
        }
        const std::uint32_t at = a * static_cast<std::uint32_t>(slots) + b;
        std::uint16_t& c = count[at];
        if (c == 0) touched.push_back(at);
        if (((c >> shift) & 15) == 15) saturated = true;
        c = static_cast<std::uint16_t>(c + (1u << shift));
      });
  HalfEdgePairing p;
  p.problems = loops;
  for (const std::uint32_t at : touched) {
    const unsigned c = count[at];
    count[at] = 0;
    judge(c & 15, (c >> 4) & 15, (c >> 8) & 15, c >> 12, p);
  }
  if (saturated) return false;
  out = p;
  return true;
}

// In a hash table by edge, for bricks with many slots (or counts beyond the matrix's).
HalfEdgePairing pair_in_table(const std::uint32_t* corner, std::size_t faces,
                              const std::array<std::uint32_t, 2>* listed, std::size_t listings) {
  struct Entry {
    std::uint64_t key;       // (lo << 32 | hi) + 1; 0: empty
    std::uint32_t count[4];  // up, down, listed up, listed down
  };
  thread_local std::vector<Entry> table;
  thread_local std::vector<std::uint32_t> used;
  std::size_t size = 64;
  while (size < 2 * (3 * faces + listings)) size *= 2;
  if (table.size() < size) table.assign(size, Entry{0, {0, 0, 0, 0}});
  used.clear();
  const std::size_t mask = size - 1;
  const std::size_t loops = each_half_edge(
      corner, faces, listed, listings, [&](std::uint32_t a, std::uint32_t b, int kind) {
        const std::uint64_t key = ((std::uint64_t{std::min(a, b)} << 32) | std::max(a, b)) + 1;
        for (std::size_t h = (key * 0x9E3779B97F4A7C15ull) >> 20;; ++h) {
          Entry& e = table[h & mask];
          if (e.key == 0) {
            e.key = key;
            used.push_back(static_cast<std::uint32_t>(h & mask));
          }
          if (e.key == key) {
            ++e.count[kind + (a > b)];
            return;
          }
        }
      });
  HalfEdgePairing p;
  p.problems = loops;
  for (const std::uint32_t u : used) {
    Entry& e = table[u];
    judge(e.count[0], e.count[1], e.count[2], e.count[3], p);
    e = Entry{0, {0, 0, 0, 0}};  // the table is left empty for the next brick
  }
  return p;
}

}  // namespace

HalfEdgePairing pair_half_edges(const std::uint32_t* corner, std::size_t faces, std::size_t slots,
                                const std::array<std::uint32_t, 2>* listed, std::size_t listings) {
  HalfEdgePairing p;
  if (slots <= kMatrixSlots && pair_in_matrix(corner, faces, slots, listed, listings, p)) return p;
  return pair_in_table(corner, faces, listed, listings);
}

}  // namespace qjulia::detail
