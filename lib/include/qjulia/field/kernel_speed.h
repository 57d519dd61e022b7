#pragma once
/// @file kernel_speed.h
/// The speed of the compiled formula against a hand-written kernel of the same map.
#include <cstddef>
#include <string>

namespace qjulia {

/// Voxel-iterations per second on one core: the compiled kernel of classic-julia (h^2 + c,
/// escape method, F with its smooth fraction) and the hand-written reference (AVX-512 or AVX2
/// intrinsics, FMA, four vectors in flight, exit steps only), over the same points.
struct KernelSpeed {
  std::string batch;  ///< which points
  std::size_t points = 0;
  double iterations = 0;  ///< useful iterations per pass (steps until escape, at most N)
  double compiled = 0;    ///< voxel-iterations per second
  double reference = 0;   ///< 0 when the CPU has neither AVX-512 nor AVX2
  std::string compiled_target, reference_isa;
};

/// Measures both on two batches: the grid points of a resolution-`resolution` box within
/// |F| < 0.5 of the surface (what sampling evaluates), and every grid point of the box. Each
/// figure is the best of `repeats` timings, the two kernels alternating; each timing repeats the
/// batch for at least 20 ms.
/// @throws InvalidInput when resolution is outside 16..512.
std::pair<KernelSpeed, KernelSpeed> measure_kernel_speed(int resolution = 128, int repeats = 7);

}  // namespace qjulia
