// Decimation benchmark: a bumpy icosphere (level 9: 5.24M faces) decimated to 10%; prints input
// faces per second and the peak RSS. Usage: decimate_bench [LEVEL] [RATIO] [--self-intersections]
// or decimate_bench --ply FILE RATIO (a binary little-endian PLY with float xyz, uint/int lists).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "../clean_fixtures.h"
#include "qjulia/clean.h"
#include "qjulia/decimate.h"

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
long peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;
}
}  // namespace

int main(int argc, char** argv) {
  int level = argc > 1 ? std::atoi(argv[1]) : 9;
  double ratio = argc > 2 ? std::atof(argv[2]) : 0.1;
  bool self = argc > 3 && std::strcmp(argv[3], "--self-intersections") == 0;
  auto t0 = std::chrono::steady_clock::now();
  qjulia::TriMesh mesh = fixtures::noisy_sphere(level);
  std::printf("built noisy sphere level %d: %zu faces, %zu vertices in %.2f s\n", level,
              mesh.face_count(), mesh.vertex_count(), seconds_since(t0));
  t0 = std::chrono::steady_clock::now();
  qjulia::CleanReport cr;
  mesh = qjulia::clean(mesh, {}, &cr);
  double tc = seconds_since(t0);
  std::printf("clean: %.2f s (%.2f M faces/s), %zu components\n", tc, mesh.face_count() / tc / 1e6,
              cr.components_after);
  qjulia::DecimateOptions opts;
  opts.faces = static_cast<long long>(mesh.face_count() * ratio);
  qjulia::DecimateReport rep;
  t0 = std::chrono::steady_clock::now();
  qjulia::TriMesh out = qjulia::decimate(mesh, opts, &rep);
  double td = seconds_since(t0);
  auto topo = fixtures::check(out);
  std::printf(
      "decimate: %zu -> %zu faces in %.2f s = %.2f M input faces/s; hausdorff %.5f; "
      "closed+manifold+oriented %s; peak RSS %ld MB\n",
      rep.faces_before, rep.faces_after, td, rep.faces_before / td / 1e6, rep.hausdorff,
      topo.closed_manifold_oriented ? "yes" : "NO", peak_rss_mb());
  if (self) {
    t0 = std::chrono::steady_clock::now();
    std::size_t n = qjulia::count_self_intersections(mesh);
    std::printf("count_self_intersections on %zu faces: %zu pairs in %.2f s\n", mesh.face_count(),
                n, seconds_since(t0));
  }
  return topo.closed_manifold_oriented ? 0 : 1;
}
