#include "qjulia/field/kernel_speed.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "field/reference_kernel.h"
#include "qjulia/base/error.h"
#include "qjulia/field/classify.h"

namespace qjulia {
namespace {

KernelSpeed measure(const Params& p, const Classifier& cls, const std::vector<double>& x,
                    const std::vector<double>& y, const std::vector<double>& z, int repeats,
                    const char* name) {
  KernelSpeed s;
  s.batch = name;
  s.points = x.size();
  s.compiled_target = cls.evaluator();
  s.reference_isa = detail::reference_kernel_isa();
  const std::size_t n = x.size();
  std::vector<float> f(n);
  std::vector<std::int32_t> steps(n);
  const Quat c = *p.constant("c");
  // Useful iterations: the steps until escape, at most N, which both kernels compute.
  const bool reference = detail::reference_julia_escape(x.data(), y.data(), z.data(), n, c,
                                                        p.iterations, p.bailout, steps.data()) > 0;
  double useful = 0;
  for (std::int32_t e : steps) useful += e < 0 ? p.iterations : e;
  if (!reference) {
    useful = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Orbit o = cls.orbit(x[i], y[i], z[i]);
      useful += o.exit_step >= 0 ? o.exit_step : p.iterations;
    }
  }
  s.iterations = useful;
  auto seconds = [](auto&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  // In blocks of 4096, as the pipeline's batches are at most that long.
  auto compiled_pass = [&] {
    for (std::size_t i = 0; i < n; i += 4096)
      cls.field(x.data() + i, y.data() + i, z.data() + i, std::min<std::size_t>(4096, n - i),
                f.data() + i);
  };
  auto reference_pass = [&] {
    detail::reference_julia_escape(x.data(), y.data(), z.data(), n, c, p.iterations, p.bailout,
                                   steps.data());
  };
  // Each timing runs the batch `passes` times, at least kMinSeconds in all: a batch of a few
  // thousand points takes a fraction of a millisecond, which the clock's steps, an interrupt or
  // the core's change of frequency would otherwise decide.
  constexpr double kMinSeconds = 0.02;
  int passes = 1;
  while (passes < (1 << 20) && seconds(compiled_pass) * passes < kMinSeconds) passes *= 2;
  auto timed = [&](auto&& pass) {
    return seconds([&] {
             for (int k = 0; k < passes; ++k) pass();
           }) /
           passes;
  };
  double best_compiled = 1e300, best_reference = 1e300;
  for (int r = 0; r < repeats; ++r) {
    best_compiled = std::min(best_compiled, timed(compiled_pass));
    if (reference) best_reference = std::min(best_reference, timed(reference_pass));
  }
  s.compiled = useful / best_compiled;
  s.reference = reference ? useful / best_reference : 0.0;
  return s;
}

}  // namespace

std::pair<KernelSpeed, KernelSpeed> measure_kernel_speed(int resolution, int repeats) {
  if (resolution < 16 || resolution > 512)
    throw InvalidInput("kernel speed: resolution " + std::to_string(resolution) +
                       " is outside 16..512");
  Params p = preset("classic-julia");
  p.resolution = resolution;
  const Classifier cls(p);
  std::vector<double> x, y, z, bx, by, bz;
  const double voxel =
      std::max({p.bounds.max[0] - p.bounds.min[0], p.bounds.max[1] - p.bounds.min[1],
                p.bounds.max[2] - p.bounds.min[2]}) /
      resolution;
  for (int i = 0; i < resolution; ++i)
    for (int j = 0; j < resolution; ++j)
      for (int k = 0; k < resolution; ++k) {
        const double px = p.bounds.min[0] + (i + 0.5) * voxel,
                     py = p.bounds.min[1] + (j + 0.5) * voxel,
                     pz = p.bounds.min[2] + (k + 0.5) * voxel;
        x.push_back(px);
        y.push_back(py);
        z.push_back(pz);
        if (std::abs(cls.field(px, py, pz)) < 0.5) {
          bx.push_back(px);
          by.push_back(py);
          bz.push_back(pz);
        }
      }
  return {measure(p, cls, bx, by, bz, repeats, "surface band |F| < 0.5"),
          measure(p, cls, x, y, z, repeats, "whole box")};
}

}  // namespace qjulia
