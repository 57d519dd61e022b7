#pragma once
// The inside of SampledGrid, shared by the stages that read the bricks.
#include <array>
#include <cstdint>
#include <vector>

#include "grid/bricks.h"
#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"

namespace qjulia {

struct SampledGrid::Impl {
  Params params;
  GridGeometry geometry;
  std::unique_ptr<Solid> solid;
  /// The bricks, sorted by key: their point values and surface cells.
  detail::BrickList bricks;
  /// Coarse blocks (16^3, lower corner index / 16) whose samples were all inside.
  std::vector<std::array<int, 3>> interior;
  std::uint64_t evaluations = 0;
  std::uint64_t dense_evaluations = 0;
  /// The ranks of a distributed run (this process holds its slab's bricks), or null.
  detail::Distribution* distribution = nullptr;
};

}  // namespace qjulia
