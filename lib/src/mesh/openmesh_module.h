#pragma once
// OpenMesh's part of qjulia (decimate()'s quality method), in a module of its own
// (libqjulia_openmesh.so) loaded on first use: OpenMesh's two libraries, with their static
// initializers, took about 2.5 ms of every process's start, twice for the commands that restart
// themselves, while only DecimateMethod::kQuality uses them. The interface holds no OpenMesh
// type and throws nothing.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace qjulia::detail {

/// One decimation by OpenMesh's Decimater (see decimate_openmesh()).
struct OpenMeshJob {
  const std::array<float, 3>* positions = nullptr;
  std::size_t vertices = 0;
  const std::array<std::uint32_t, 3>* triangles = nullptr;
  std::size_t faces = 0;
  /// Per face, 1: left out of the decimation and put back as it is (its vertices locked).
  const std::uint8_t* frozen = nullptr;
  std::size_t target_faces = 0;      ///< stop at this many faces; 0 = as far as the bounds allow
  double tolerance = 0;              ///< ModHausdorff bound, model units; 0 = none
  double max_normal_deviation = 45;  ///< ModNormalFlipping bound per collapse, degrees
  /// Asked every few thousand collapses with the fraction done; false stops (null: never).
  bool (*keep_going)(double fraction, void* token) = nullptr;
  void* token = nullptr;
};

/// The module's entry points (kOpenMeshApiVersion guards against a module built for another
/// version of this interface).
constexpr int kOpenMeshApiVersion = 1;
struct OpenMeshApi {
  int version = kOpenMeshApiVersion;
  /// The triangles of the result into `out` (the frozen faces and those OpenMesh refuses first,
  /// as they are); `stopped` when keep_going() stopped it. "" or what failed.
  std::string (*decimate)(const OpenMeshJob& job, std::vector<std::array<std::uint32_t, 3>>& out,
                          bool& stopped) = nullptr;
};

/// The entry points, the module loaded on the first call: from $QJULIA_OPENMESH_MODULE if set,
/// else beside the program or module that calls (and its ../lib/qjulia), else where this build
/// and its installation put it. @throws std::runtime_error naming the paths tried.
const OpenMeshApi& openmesh_api();

}  // namespace qjulia::detail

/// The module's one exported symbol.
extern "C" const qjulia::detail::OpenMeshApi* qjulia_openmesh_api();
