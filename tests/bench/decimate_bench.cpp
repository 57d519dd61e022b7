// Decimation benchmark: a bumpy icosphere (level 9: 5.24M faces) decimated to 10%; prints input
// faces per second and the peak RSS.
// Usage: decimate_bench [LEVEL] [RATIO] [--self-intersections]   (RATIO < 0: max_error = -RATIO)
//        ... --avoid-self-intersections: DecimateOptions::avoid_self_intersections
//        decimate_bench --preset NAME RESOLUTION RATIO [SIZE_MM MIN_THICKNESS_MM]
//          (a real fractal mesh from the pipeline; optionally then scaled and thickened)
//        ... --quality: DecimateMethod::kQuality (OpenMesh) instead of the fast method
//        ... --compare: also prints compare()'s distances between the input and the output
//        ... --cancel-after SECONDS: requests the cancel token that long into decimate() and
//          prints how long decimate() took to throw Cancelled after that
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "../test_meshes.h"
#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/mesh/decimate.h"
#include "qjulia/mesh/print.h"
#include "qjulia/pipeline/pipeline.h"

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}
long peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;
}
}  // namespace

// Removes the flag argv[i] and its `values` values from the arguments.
void take(int& argc, char** argv, int i, int values) {
  for (int j = i; j + values + 1 <= argc; ++j) argv[j] = argv[j + values + 1];
  argc -= values + 1;
}

int main(int argc, char** argv) {
  double cancel_after = -1;  // the flags, taken out of the positional arguments
  bool quality = false, with_compare = false, avoid_self_intersections = false;
  for (int i = 1; i < argc;) {
    if (i + 1 < argc && std::strcmp(argv[i], "--cancel-after") == 0) {
      cancel_after = std::atof(argv[i + 1]);
      take(argc, argv, i, 1);
    } else if (std::strcmp(argv[i], "--quality") == 0) {
      quality = true;
      take(argc, argv, i, 0);
    } else if (std::strcmp(argv[i], "--avoid-self-intersections") == 0) {
      avoid_self_intersections = true;
      take(argc, argv, i, 0);
    } else if (std::strcmp(argv[i], "--compare") == 0) {
      with_compare = true;
      take(argc, argv, i, 0);
    } else {
      ++i;
    }
  }
  const bool from_preset = argc > 1 && std::strcmp(argv[1], "--preset") == 0;
  if (from_preset && argc < 5) {
    std::fprintf(stderr, "usage: decimate_bench --preset NAME RESOLUTION RATIO\n");
    return 2;
  }
  int level = argc > 1 && !from_preset ? std::atoi(argv[1]) : 9;
  double ratio = from_preset ? std::atof(argv[4]) : (argc > 2 ? std::atof(argv[2]) : 0.1);
  bool self = !from_preset && argc > 3 && std::strcmp(argv[3], "--self-intersections") == 0;
  auto t0 = std::chrono::steady_clock::now();
  qjulia::TriMesh mesh;
  if (from_preset) {
    qjulia::Params params = qjulia::preset(argv[2]);
    params.resolution = std::atoi(argv[3]);
    mesh = qjulia::run_pipeline(params).mesh;  // sampled, extracted, cleaned
    std::printf("pipeline %s at %d: %zu faces, %zu vertices in %.2f s\n", argv[2],
                params.resolution, mesh.face_count(), mesh.vertex_count(), seconds_since(t0));
  } else {
    mesh = fixtures::noisy_sphere(level);
    std::printf("built noisy sphere level %d: %zu faces, %zu vertices in %.2f s\n", level,
                mesh.face_count(), mesh.vertex_count(), seconds_since(t0));
  }
  t0 = std::chrono::steady_clock::now();
  qjulia::CleanReport cr;
  mesh = qjulia::clean(mesh, {}, &cr);
  double tc = seconds_since(t0);
  std::printf("clean: %.2f s (%.2f M faces/s), %zu components\n", tc, mesh.face_count() / tc / 1e6,
              cr.components_after);
  qjulia::DecimateOptions opts;
  if (quality) opts.method = qjulia::DecimateMethod::kQuality;
  if (ratio > 0)
    opts.faces = static_cast<long long>(mesh.face_count() * ratio);
  else
    opts.max_error = -ratio;  // a negative RATIO is an error bound instead of a face ratio
  opts.avoid_self_intersections = avoid_self_intersections;
  qjulia::DecimateReport rep;
  if (cancel_after >= 0) {
    qjulia::CancelToken token;
    opts.cancel = &token;
    std::chrono::steady_clock::time_point requested;
    std::thread canceller([&] {
      std::this_thread::sleep_for(std::chrono::duration<double>(cancel_after));
      requested = std::chrono::steady_clock::now();
      token.request();
    });
    try {
      qjulia::decimate(mesh, opts, &rep);
      canceller.join();
      std::printf("decimate finished before the token was requested\n");
    } catch (const qjulia::Cancelled&) {
      const auto caught = std::chrono::steady_clock::now();
      canceller.join();  // after it, `requested` may be read
      const double latency = std::chrono::duration<double>(caught - requested).count();
      std::printf("decimate: cancelled %.3f s after the request (requested at %.2f s)\n", latency,
                  cancel_after);
    }
    return 0;
  }
  t0 = std::chrono::steady_clock::now();
  const double c0 = cpu_seconds();
  qjulia::TriMesh out = qjulia::decimate(mesh, opts, &rep);
  double td = seconds_since(t0);
  double cpu = cpu_seconds() - c0;
  auto topo = fixtures::check(out);
  std::printf(
      "decimate: %zu -> %zu faces in %.2f s wall (%.2f s CPU) = %.2f M input faces/s; "
      "hausdorff %.5f; closed+manifold+oriented %s (euler %lld); peak RSS %ld MB\n",
      rep.faces_before, rep.faces_after, td, cpu, rep.faces_before / td / 1e6, rep.hausdorff,
      topo.closed_manifold_oriented ? "yes" : "NO", topo.euler, peak_rss_mb());
  if (rep.self_intersections)
    std::printf("self-intersecting pairs left: %zu\n", *rep.self_intersections);
  if (with_compare) {
    const auto r = qjulia::compare(mesh, out);
    std::printf("compare: hausdorff %.5f (input -> output %.5f, output -> input %.5f), mean %.6f\n",
                r.hausdorff, r.a_to_b.max, r.b_to_a.max, 0.5 * (r.a_to_b.mean + r.b_to_a.mean));
  }
  if (self) {
    t0 = std::chrono::steady_clock::now();
    const double c1 = cpu_seconds();
    std::size_t n = qjulia::count_self_intersections(mesh);
    std::printf("count_self_intersections on %zu faces: %zu pairs in %.2f s wall (%.2f s CPU)\n",
                mesh.face_count(), n, seconds_since(t0), cpu_seconds() - c1);
  }
  if (from_preset && argc > 6) {
    const double size = std::atof(argv[5]), thickness = std::atof(argv[6]);
    qjulia::scale_to_longest_side(out, size);
    const double before = fixtures::volume(out);
    t0 = std::chrono::steady_clock::now();
    const double c2 = cpu_seconds();
    qjulia::ThickenOptions topts;
    topts.min_thickness = thickness;
    qjulia::TriMesh thick = qjulia::thicken(out, topts);
    auto tt = fixtures::check(thick);
    std::printf(
        "thicken to %.2f mm at %.0f mm: %zu -> %zu faces in %.2f s wall (%.2f s CPU); volume "
        "%.1f -> %.1f mm^3; closed+manifold+oriented %s; peak RSS %ld MB\n",
        thickness, size, out.face_count(), thick.face_count(), seconds_since(t0),
        cpu_seconds() - c2, before, fixtures::volume(thick),
        tt.closed_manifold_oriented ? "yes" : "NO", peak_rss_mb());
  }
  return topo.closed_manifold_oriented ? 0 : 1;
}
