#pragma once
// The pairing of one brick's half-edges: which edges of its faces lie inside the brick (a
// half-edge each way), which on its border (one half-edge, listed on the brick's face for the
// neighbour's to pair with), and how many half-edges and listings fit neither.
#include <array>
#include <cstddef>
#include <cstdint>

namespace qjulia::detail {

struct HalfEdgePairing {
  std::size_t edges = 0;     ///< edges inside the brick, each counted once
  std::size_t problems = 0;  ///< half-edges and listings that pair with nothing, or with too many
};

/// The faces' corners as local slots (three a face, each below `slots`) and the border's
/// listings as (from, to) slots. An edge with one half-edge each way and no listing is inside
/// the brick; an edge with one half-edge, listed once in that direction, is on the border.
/// Every other half-edge and listing is a problem, as is a half-edge from a slot to itself.
HalfEdgePairing pair_half_edges(const std::uint32_t* corner, std::size_t faces, std::size_t slots,
                                const std::array<std::uint32_t, 2>* listed, std::size_t listings);

}  // namespace qjulia::detail
