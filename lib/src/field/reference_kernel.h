#pragma once
// A hand-written kernel of one map, h^2 + c with the escape method, for measuring the compiled
// formula against: AVX-512 intrinsics (AVX2 on CPUs without AVX-512), fused multiply-adds and
// four independent vectors in flight, no lane refill (a group of vectors runs until all its
// lanes have escaped or reached N). It computes the exit step of every point, not F.
#include <cstddef>
#include <cstdint>

#include "qjulia/field/quaternion.h"

namespace qjulia::detail {

/// Runs h0 = (x[i], y[i], z[i], 0), h <- h^2 + c for at most n_iter steps, until |h| > bailout;
/// writes each exit step (or -1) to exit_step[i]. Returns the steps computed for points that
/// had not escaped yet (the useful iterations), or 0 when the CPU has neither AVX-512 nor AVX2.
std::uint64_t reference_julia_escape(const double* x, const double* y, const double* z,
                                     std::size_t n, const Quat& c, int n_iter, double bailout,
                                     std::int32_t* exit_step);

/// "AVX-512", "AVX2" or "none": what reference_julia_escape() runs on this CPU.
const char* reference_kernel_isa();

}  // namespace qjulia::detail
