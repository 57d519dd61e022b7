#pragma once
// OpenVDB's part of qjulia, in a module of its own (libqjulia_vdb.so) that is loaded on first
// use. Loading libopenvdb resolves its ~69,000 symbol relocations at once (Debian builds it with
// BIND_NOW): 50-80 ms that every process paid at its start, while only writing a grid (--vdb)
// and thickening (--min-thickness) use OpenVDB. The interface holds no OpenVDB type.
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace qjulia::detail {

/// Receives one point of a grid: global index (i, j, k) and value.
using VdbEmit = void (*)(void* sink, int i, int j, int k, float value);

/// A float grid as write_grid() writes it.
struct VdbGrid {
  std::string name;
  double voxel = 1;                          // the voxel's edge
  std::array<double, 3> origin{};            // where index (0, 0, 0) lies
  float background = 0;                      // outside; -background inside the interior blocks
  int block = 16;                            // the edge of an interior block, in voxels
  std::vector<std::array<int, 3>> interior;  // blocks filled with -background (inactive)
  // each_value(source, emit, sink) calls emit(sink, i, j, k, value) for every active point.
  void (*each_value)(const void* source, VdbEmit emit, void* sink) = nullptr;
  const void* source = nullptr;
  std::vector<std::pair<std::string, std::string>> metadata;  // string metadata
};

using VdbPositions = std::vector<std::array<float, 3>>;
using VdbTriangles = std::vector<std::array<std::uint32_t, 3>>;

/// What thicken() asks of OpenVDB: the mesh's signed distance field on a grid of `voxel`, opened
/// by `r` (what the opening loses is thinner than 2r), the lost parts dilated by r and joined to
/// the solid, and the zero level of the result as triangles wound as OpenVDB gives them.
struct VdbThicken {
  double voxel = 1;
  double r = 1;
  std::function<bool()> interrupted;     // true stops OpenVDB's tools (they return early)
  std::function<void(double)> progress;  // 0..1; may throw to stop
};

/// The module's entry points (kVdbApiVersion guards against a module built for another version
/// of this interface).
constexpr int kVdbApiVersion = 1;
struct VdbApi {
  int version = kVdbApiVersion;
  /// Writes `grid` as an OpenVDB file at `path`. @throws std::exception on failure.
  void (*write_grid)(const std::string& path, const VdbGrid& grid) = nullptr;
  /// @throws std::exception on failure.
  void (*thicken)(const VdbPositions& positions, const VdbTriangles& triangles,
                  const VdbThicken& opts, VdbPositions& out_positions,
                  VdbTriangles& out_triangles) = nullptr;
};

/// The entry points, the module loaded on the first call: from $QJULIA_VDB_MODULE if set, else
/// beside the program or module that calls (and its ../lib/qjulia), else where this build and
/// its installation put it. @throws std::runtime_error naming the paths tried.
const VdbApi& vdb_api();

}  // namespace qjulia::detail

/// The module's one exported symbol.
extern "C" const qjulia::detail::VdbApi* qjulia_vdb_api();
