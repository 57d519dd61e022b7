// Writes and reads a ~5M-triangle mesh (a 2x2 grid of fine tori, with colours) in every format
// and prints seconds and MB/s. Usage: export_bench [DIR] [--tris N] [--no-colors]
// (default DIR: /tmp; the files stay there as qjulia_export_bench.*, for the validators).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include "qjulia/io/mesh_io.h"

namespace {

qjulia::TriMesh torus_grid(std::size_t target_tris) {
  // 4 tori of U x V quads each: 8 U V triangles in all; U = 2.5 V.
  const std::size_t v_seg = std::max<std::size_t>(8, std::size_t(std::sqrt(target_tris / 20.0)));
  const std::size_t u_seg = v_seg * 5 / 2;
  qjulia::TriMesh m;
  const double pi = std::acos(-1.0);
  for (int t = 0; t < 4; ++t) {
    const float ox = float(t % 2) * 3.0f, oy = float(t / 2) * 3.0f;
    const uint32_t base = uint32_t(m.positions.size());
    for (std::size_t i = 0; i < u_seg; ++i) {
      const double u = 2 * pi * double(i) / double(u_seg);
      for (std::size_t j = 0; j < v_seg; ++j) {
        const double v = 2 * pi * double(j) / double(v_seg);
        const double r = 1.0 + 0.35 * std::cos(v);
        m.positions.push_back(
            {ox + float(r * std::cos(u)), oy + float(r * std::sin(u)), float(0.35 * std::sin(v))});
        m.colors.push_back({float(0.5 + 0.5 * std::cos(u)), float(0.5 + 0.5 * std::sin(v)), 0.3f});
      }
    }
    for (std::size_t i = 0; i < u_seg; ++i)
      for (std::size_t j = 0; j < v_seg; ++j) {
        const uint32_t a = base + uint32_t(i * v_seg + j);
        const uint32_t b = base + uint32_t(((i + 1) % u_seg) * v_seg + j);
        const uint32_t c = base + uint32_t(((i + 1) % u_seg) * v_seg + (j + 1) % v_seg);
        const uint32_t d = base + uint32_t(i * v_seg + (j + 1) % v_seg);
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
      }
  }
  return m;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = "/tmp";
  std::size_t tris = 5'000'000;
  bool colors = true;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no-colors") == 0) {
      colors = false;
    } else if (std::strcmp(argv[i], "--tris") == 0 && i + 1 < argc) {
      tris = std::stoul(argv[++i]);
    } else {
      dir = argv[i];
    }
  }
  auto t0 = std::chrono::steady_clock::now();
  qjulia::TriMesh mesh = torus_grid(tris);
  if (!colors) mesh.colors.clear();
  std::printf("mesh: %zu vertices, %zu triangles, %s colours (built in %.2f s)\n",
              mesh.vertex_count(), mesh.face_count(), colors ? "with" : "without",
              seconds_since(t0));
  std::printf("%-6s %10s %9s %9s %9s %9s\n", "format", "MB", "write s", "write MB/s", "read s",
              "read MB/s");
  for (const char* ext : {".glb", ".gltf", ".obj", ".ply", ".stl", ".3mf"}) {
    const std::string path = dir + "/qjulia_export_bench" + ext;
    t0 = std::chrono::steady_clock::now();
    qjulia::write_mesh(path, mesh, {"{\"bench\": true}", "mm", {}});
    const double tw = seconds_since(t0);
    double mb = double(std::filesystem::file_size(path)) / 1e6;
    if (std::string(ext) == ".gltf") {
      mb += double(std::filesystem::file_size(dir + "/qjulia_export_bench.bin")) / 1e6;
    }
    t0 = std::chrono::steady_clock::now();
    const qjulia::TriMesh back = qjulia::read_mesh(path);
    const double tr = seconds_since(t0);
    if (back.face_count() != mesh.face_count()) {
      std::fprintf(stderr, "%s: read %zu triangles, wrote %zu\n", ext, back.face_count(),
                   mesh.face_count());
      return 1;
    }
    std::printf("%-6s %10.1f %9.2f %9.0f %9.2f %9.0f\n", ext, mb, tw, mb / tw, tr, mb / tr);
    std::fflush(stdout);
  }
  return 0;
}
