#pragma once
// The inside of SampledGrid, shared by the stages that need the OpenVDB grid.
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"

namespace qjulia {

struct SampledGrid::Impl {
  Params params;
  GridGeometry geometry;
  /// F at every evaluated grid point (active voxels); inactive tiles of -background inside
  /// uniform interior blocks, background (> 0) elsewhere.
  openvdb::FloatGrid::Ptr grid;
  /// Cells (min corner, packed with detail::pack) whose corners differ in sign, sorted.
  std::vector<std::uint64_t> crossing;
  std::uint64_t evaluations = 0;
  std::uint64_t dense_evaluations = 0;
};

namespace detail {

// Cell and point coordinates range over -1 .. 2^20 - 2 per axis; packed as 20-bit fields
// (60 bits), which leaves two bits for an edge's axis.
constexpr int kPackBits = 20;
constexpr std::uint64_t kPackMask = (std::uint64_t{1} << kPackBits) - 1;

inline std::uint64_t pack(int i, int j, int k) {
  return (static_cast<std::uint64_t>(i + 1) << (2 * kPackBits)) |
         (static_cast<std::uint64_t>(j + 1) << kPackBits) | static_cast<std::uint64_t>(k + 1);
}
inline openvdb::Coord unpack(std::uint64_t key) {
  return openvdb::Coord(static_cast<int>((key >> (2 * kPackBits)) & kPackMask) - 1,
                        static_cast<int>((key >> kPackBits) & kPackMask) - 1,
                        static_cast<int>(key & kPackMask) - 1);
}

/// The value at grid point (i, j, k) if it is never evaluated: outside the index range, the box
/// or a clip plane (the constraint in voxels, > 0). Returns false for points that are sampled.
inline bool virtual_value(const GridGeometry& geo, const Solid& solid, int i, int j, int k,
                          float* value) {
  if (i < 0 || j < 0 || k < 0 || i >= geo.points[0] || j >= geo.points[1] || k >= geo.points[2]) {
    *value = 1.0f;
    return true;
  }
  // Every point in the index range is inside the box; only clip planes can exclude it.
  if (!solid.has_clip()) return false;
  const auto excluded = solid.excluded_field(
      geo.origin[0] + i * geo.voxel, geo.origin[1] + j * geo.voxel, geo.origin[2] + k * geo.voxel);
  if (excluded) *value = *excluded;
  return excluded.has_value();
}

/// The value at grid point (i, j, k): virtual, or read from the sampled grid through `acc`.
template <typename Accessor>
float point_value(const GridGeometry& geo, const Solid& solid, const Accessor& acc, int i, int j,
                  int k) {
  float v;
  if (virtual_value(geo, solid, i, j, k, &v)) return v;
  return acc.getValue(openvdb::Coord(i, j, k));
}

}  // namespace detail
}  // namespace qjulia
