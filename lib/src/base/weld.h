#pragma once
/// @file weld.h
/// Vertices at the same position, found once for every stage that merges them: the STL reader
/// (whose triangles carry their own corners), clean() and compare()'s measures (files that split
/// vertices at seams, as glTF and PLY exporters do).
#include <array>
#include <cstddef>
#include <cstdint>

namespace qjulia::detail {

/// The slots of the hash table number_positions() uses for `n` positions (4 bytes each).
std::size_t weld_table_slots(std::size_t n);

/// Numbers the distinct positions among the `n` at `p` (bit-identical after -0 -> +0) in the
/// order of their first occurrence: index[i] is the number of position i. Returns how many
/// there are.
std::size_t number_positions(const std::array<float, 3>* p, std::size_t n, std::uint32_t* index);

/// The welded positions: out[k] is the first of the `n` positions at `p` that number_positions()
/// gave the number k (with -0 -> +0, as they were keyed); `out` holds as many as it returned.
void first_positions(const std::array<float, 3>* p, std::size_t n, const std::uint32_t* index,
                     std::array<float, 3>* out);

}  // namespace qjulia::detail
