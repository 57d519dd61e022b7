// render_bench: times render() on a bumpy torus of about 1M triangles at 1024x1024.
// Usage: render_bench [FACES [SIZE [OUT.png]]]   (defaults 1000000, 1024)
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "qjulia/render/render.h"

namespace {

/// A torus (radii 1 and 0.4) with ripples, as a u x v grid of quads split in two triangles.
qjulia::TriMesh bumpy_torus(long faces) {
  const int nu = std::max(3, static_cast<int>(std::sqrt(faces / 2.0 * 2.5)));
  const int nv = std::max(3, static_cast<int>(faces / 2 / nu));
  qjulia::TriMesh m;
  m.positions.reserve(static_cast<std::size_t>(nu) * nv);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      const double r = 0.4 + 0.03 * std::sin(9 * u) * std::sin(7 * v);
      m.positions.push_back({static_cast<float>((1 + r * std::cos(v)) * std::cos(u)),
                             static_cast<float>((1 + r * std::cos(v)) * std::sin(u)),
                             static_cast<float>(r * std::sin(v))});
    }
  auto id = [&](int i, int j) { return static_cast<uint32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  const long faces = argc > 1 ? std::atol(argv[1]) : 1000000;
  const int size = argc > 2 ? std::atoi(argv[2]) : 1024;
  const qjulia::TriMesh mesh = bumpy_torus(faces);
  std::printf("mesh: %zu vertices, %zu triangles; image %dx%d; %d hardware threads\n",
              mesh.vertex_count(), mesh.face_count(), size, size, tbb::info::default_concurrency());
  qjulia::RenderOptions o;
  o.width = o.height = size;
  o.rotate_deg = {-60, 0, 20};
  const int max_threads = tbb::info::default_concurrency();
  for (int threads = 1; threads <= max_threads; threads *= 2) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    for (auto [shading, name] : {std::pair{qjulia::Shading::kSimple, "simple"},
                                 std::pair{qjulia::Shading::kLambert, "lambert"},
                                 std::pair{qjulia::Shading::kPhong, "phong"}}) {
      o.shading = shading;
      for (int ss : {1, 2}) {
        o.supersample = ss;
        double best = 1e9;
        for (int rep = 0; rep < 3; ++rep) {
          const auto t0 = std::chrono::steady_clock::now();
          const qjulia::Image im = qjulia::render(mesh, o);
          best = std::min(best, seconds_since(t0));
        }
        std::printf("threads %d  %-7s supersample %d: %.3f s (best of 3)\n", threads, name, ss,
                    best);
      }
    }
  }
  o.shading = qjulia::Shading::kPhong;
  o.supersample = 1;
  const qjulia::Image im = qjulia::render(mesh, o);
  const std::string out = argc > 3 ? argv[3] : "/tmp/render_bench.png";
  const auto t0 = std::chrono::steady_clock::now();
  qjulia::write_png(out, im);
  std::printf("write_png %s: %.3f s\n", out.c_str(), seconds_since(t0));
  return 0;
}
