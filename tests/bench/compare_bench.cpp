// compare_bench: times compare() on two synthetic surfaces of about a million faces each (a
// torus and a bumpy torus of different tessellation), the figure of the issue ("1M faces
// against 1M faces in under 10 s").
// With --newton RES it compares real surfaces instead: Newton's cubic by the cut-off method
// (preset newton-cubic) and by the escape method (preset newton-escape), meshed at RES.
// Usage: compare_bench [--faces N] [--samples S] [--threads T] [--newton RES]
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "../test_meshes.h"
#include "qjulia/field/params.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/pipeline/pipeline.h"

namespace {

// CPU seconds of this process (all threads): the work, whatever else loads the machine.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  long faces = 1000000;
  qjulia::CompareOptions opts;
  int threads = 0, newton = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--faces"))
      faces = std::atol(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--samples"))
      opts.samples = std::atol(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--threads"))
      threads = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--newton"))
      newton = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr,
                   "usage: compare_bench [--faces N] [--samples S] [--threads T] [--newton RES]\n");
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  threads);
  qjulia::TriMesh a, b;
  if (newton > 0) {
    qjulia::Params cut = qjulia::preset("newton-cubic"), esc = qjulia::preset("newton-escape");
    cut.resolution = esc.resolution = newton;
    a = qjulia::run_pipeline(cut).mesh;
    b = qjulia::run_pipeline(esc).mesh;
    std::printf("newton-cubic (cut-off) against newton-escape at resolution %d\n", newton);
  } else {
    // A: a 2:1 grid, B: a square grid with a bump, both with about `faces` triangles.
    const int an = static_cast<int>(std::sqrt(static_cast<double>(faces)));
    const int bn = static_cast<int>(std::sqrt(faces / 2.0));
    a = fixtures::torus(an, static_cast<int>(faces / 2 / an), 0.0);
    b = fixtures::torus(bn, bn, 0.02);
  }

  double setup = 0, setup_cpu = 0;
  const double cpu0 = cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  opts.progress = [&](double f) {
    if (setup == 0 && f > 0) {
      setup = seconds_since(t0);
      setup_cpu = cpu_seconds() - cpu0;
    }
    return true;
  };
  const auto r = qjulia::compare(a, b, opts);
  const double total = seconds_since(t0);
  const double cpu = cpu_seconds() - cpu0;

  std::printf("compare_bench: A %zu faces, B %zu faces, %zu + %zu samples, %u hardware threads%s\n",
              a.face_count(), b.face_count(), r.a_to_b.samples, r.b_to_a.samples,
              std::thread::hardware_concurrency(),
              threads > 0 ? (", limited to " + std::to_string(threads)).c_str() : "");
  std::printf("  setup (measure, BVH, samples): %.2f s wall, %.2f s CPU\n", setup, setup_cpu);
  std::printf("  distance queries:              %.2f s wall, %.2f s CPU\n", total - setup,
              cpu - setup_cpu);
  std::printf("  total:                         %.2f s wall, %.2f s CPU (all threads)\n", total,
              cpu);
  std::printf("  hausdorff %.6f (a->b max %.6f mean %.6f, b->a max %.6f mean %.6f)\n", r.hausdorff,
              r.a_to_b.max, r.a_to_b.mean, r.b_to_a.max, r.b_to_a.mean);
  return 0;
}
